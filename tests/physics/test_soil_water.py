"""``energy_balance_swc``: latent heat limited by the measured top-soil water content
(physics/catalogue/soil_water.py). The law by hand, its refusals, and its place in the balance
(the same H as the Priestley–Taylor balance, LE zero on a dry soil whatever its coefficient)."""

from __future__ import annotations

import numpy as np
import pytest

from pavement_mcmc.physics import get_extension
from pavement_mcmc.physics.catalogue.surface import priestley_taylor_weight


class Meas:
    t = np.arange(0, 48 * 3600 + 1, 3600.0)
    q_net = 500.0 * np.clip(np.sin(2 * np.pi * (t / 86400.0 - 0.25)), -0.15, None)
    T_air = 20.0 + 5.0 * np.sin(2 * np.pi * (t / 86400.0 - 0.375))
    wind = None
    extras = {"SWC": np.linspace(0.0, 0.4, t.size)}


def _p(**kw):
    ext = get_extension("energy_balance_swc")
    p = {q.name: np.array([q.value]) for q in ext.parameters(Meas)}
    p.update({k: np.atleast_1d(np.asarray(v, float)) for k, v in kw.items()})
    return ext, p


def test_the_law_by_hand():
    ext, p = _p(eb_alpha=[1.2, 0.6], eb_theta_fc=[0.25, 0.1], eb_h0=[5.0, 5.0])
    LE = ext.latent(p, Meas)
    theta = Meas.extras["SWC"]
    pt = priestley_taylor_weight(Meas.T_air) * np.maximum(Meas.q_net, 0.0)
    np.testing.assert_allclose(LE[0], 1.2 * np.minimum(1, theta / 0.25) * pt)
    np.testing.assert_allclose(LE[1], 0.6 * np.minimum(1, theta / 0.1) * pt)
    wet = theta >= 0.25
    np.testing.assert_allclose(LE[0, wet], 1.2 * pt[wet])  # above the field capacity: a wet surface
    assert LE[:, Meas.q_net <= 0].max() == 0.0  # no latent heat at night
    assert LE[:, 0].max() == 0.0 and theta[0] == 0.0  # a dry soil does not evaporate
    # the sensible heat is the balance's: one coefficient without a wind column
    np.testing.assert_allclose(ext.transfer(p, Meas), 5.0)


def test_its_parameters_and_refusals():
    ext = get_extension("energy_balance_swc")
    ps = {q.name: q for q in ext.parameters(Meas)}
    assert list(ps) == ["eb_h0", "eb_alpha", "eb_theta_fc"]
    assert ps["eb_alpha"].value == 0.0 and (ps["eb_alpha"].lower, ps["eb_alpha"].upper) == (0.0, 1.6)
    assert not ps["eb_theta_fc"].vary and ps["eb_theta_fc"].value == 0.25
    assert ps["eb_theta_fc"].unit == "m3 m-3"

    class Dry(Meas):
        extras = {}

    with pytest.raises(ValueError, match="needs the top soil's water content"):
        ext.parameters(Dry)

    class Gap(Meas):
        extras = {"SWC": np.r_[np.nan, Meas.extras["SWC"][1:]]}

    with pytest.raises(ValueError, match="without gaps"):
        ext.parameters(Gap)
