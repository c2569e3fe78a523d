"""The ``energy_balance`` extension: a twin from :mod:`pavement_mcmc.synthetic` with a known
energy balance (h = h_a + h_b u, Priestley-Taylor latent heat on the net radiation) recovered by
the MAP, the no-wind fallback's law, the partition's closure and the day pieces."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.data import load_case
from pavement_mcmc.physics import Model, candidate_names, extension_names
from pavement_mcmc.physics.catalogue.energy import day_index, energy_partition
from pavement_mcmc.physics.catalogue.surface import priestley_taylor_weight
from pavement_mcmc.posterior import build_problem, find_map
from pavement_mcmc.synthetic import SyntheticSpec
from pavement_mcmc.synthetic.corpus import FIELD
from pavement_mcmc.synthetic.io import write_case

REPO = Path(__file__).resolve().parents[2]
TRUE = {"h_a": 4.0, "h_b": 3.0, "et_alpha": 1.0}

CASE = """
name = "energy-twin"
[data]
csv = "measurements.csv"
sigma = 0.1
observed_cm = [2, 5, 10, 20]
bottom_cm = 50
[model]
extensions = ["energy_balance"]
[grid]
kind = "stretched"
[parameters.kappa]
prior = { dist = "truncnormal", mean = 1.4, sd = 0.4 }
[parameters.C]
prior = { dist = "truncnormal", mean = 2.3e6, sd = 0.5e6 }
"""


@pytest.fixture(scope="module")
def twin(tmp_path_factory):
    """48 h of the grass-site geometry (kappa 1.2, C 2.6e6, spring weather), the twin's own
    fine-grid column with h = 4 + 3 u and LE = 1.0 s/(s+gamma) max(R_n, 0), noise 0.1 degC."""
    d = tmp_path_factory.mktemp("energy-twin")
    spec = SyntheticSpec(**{**FIELD, "flux_depths_cm": ()}, sigma=0.1, hours=48.0, seed=7,
                         effects={"wind_convection": {"h_a": TRUE["h_a"], "h_b": TRUE["h_b"]},
                                  "evapotranspiration": {"et_alpha": TRUE["et_alpha"]}},
                         et_available="net")
    write_case(spec, d)
    (d / "case.toml").write_text(CASE)
    return build_problem(load_case(d / "case.toml")), json.loads((d / "truth.json").read_text())


def test_twin_energy_balance_recovered_at_the_map(twin):
    pb, truth = twin
    lap = find_map(pb.posterior, pb.space.start_vector())
    est = dict(zip(lap.names, lap.theta, strict=True))
    sd = dict(zip(lap.names, lap.sd, strict=True))
    assert pb.space.free == ["kappa", "C", "eb_h0", "eb_h1", "eb_alpha_1", "eb_alpha_2"]
    for name, true in (("eb_h0", TRUE["h_a"]), ("eb_h1", TRUE["h_b"]),
                       ("eb_alpha_1", TRUE["et_alpha"]), ("eb_alpha_2", TRUE["et_alpha"])):
        assert abs(est[name] - true) < 1.96 * sd[name], (name, est[name], sd[name])
    # kappa/C exactly, kappa and C within 5 % (3 % low here, far outside their 1 % intervals:
    # the initial profile above the 2 cm sensor is a guess, the first hours carry it)
    assert est["kappa"] / est["C"] == pytest.approx(truth["kappa"] / truth["C"], rel=0.02)
    assert est["kappa"] == pytest.approx(truth["kappa"], rel=0.05)
    assert est["C"] == pytest.approx(truth["C"], rel=0.05)
    # the latent heat the fit implies is the twin's (recorded in truth.json)
    part = energy_partition(pb.model, pb.space.expand(lap.theta[None]))
    q_et = np.asarray(truth["q_et_obs"])
    day = pb.meas.q_net > 0.5 * pb.meas.q_net.max()
    assert part.LE[0, day].sum() == pytest.approx(q_et[day].sum(), rel=0.03)
    rmse = np.sqrt(np.mean(lap.rmse**2))
    assert rmse < 1.3 * truth["sigma"]


def test_partition_closes_and_matches_the_laws(twin):
    pb, _ = twin
    m = pb.model
    p = {k: np.array([v, 1.3 * v]) for k, v in pb.space.value_dict().items()}
    part = energy_partition(m, p)
    np.testing.assert_allclose(part.H + part.LE + part.G, part.Rn, atol=1e-9)
    w = priestley_taylor_weight(m.meas.T_air) * np.clip(m.meas.q_net, 0, None)
    np.testing.assert_allclose(part.LE, np.outer([p["eb_alpha_1"][0], 1.3 * p["eb_alpha_1"][0]], w),
                               rtol=1e-12)
    # H = h_H (T_s - T_air), h_H = eb_h0 + eb_h1 u averaged over the interval ending at each time
    T_s = m.solve(p)[..., 0]
    hH = p["eb_h0"][:, None] + p["eb_h1"][:, None] * m.meas.wind[None, :]
    h_int = 0.5 * (hH[:, 1:] + hH[:, :-1])
    np.testing.assert_allclose(part.H[:, 1:], h_int * (T_s - m.meas.T_air)[:, 1:],
                               rtol=1e-9, atol=1e-9)
    mid = part.midday()
    assert set(mid) == {"bowen", "G_Rn", "LE_Rn", "H_Rn"}
    np.testing.assert_allclose(mid["G_Rn"] + mid["LE_Rn"] + mid["H_Rn"], 1.0, atol=1e-12)


def test_no_wind_fallback_has_one_transfer_coefficient_and_no_eb_h1(twin):
    """Without a wind column the law has no drive for eb_h1: it is not a parameter (before, a
    stand-in drive max(Rn, 0)/500 kept it, and the desert record ran it to its bound 0)."""
    pb, _ = twin
    meas = replace(pb.meas, wind=None)
    m = Model(meas, pb.model.grid, pb.model.h_basis, ["energy_balance"])
    space = m.parameter_space()
    assert "eb_h1" not in space.names
    assert space.free == ["kappa", "C", "eb_h0", "eb_alpha_1", "eb_alpha_2"]
    assert "no wind" in space["eb_h0"].description
    assert "h(t) from energy_balance" in m.describe() and not any(n.startswith("h_") for n in space.free)
    p = {k: np.array([v, 2.0 * v]) for k, v in space.value_dict().items()}
    h = m.coefficients(p).h
    np.testing.assert_allclose(h, np.repeat(p["eb_h0"][:, None], meas.t.size - 1, axis=1),
                               rtol=1e-12)


def test_window_alpha_variant_has_one_coefficient(twin):
    """``energy_balance_window``: one eb_alpha for the window, LE = eb_alpha w(T_a) max(Rn, 0)
    at every time, equal to the daily law with every day's alpha the same."""
    pb, _ = twin
    m1 = Model(pb.meas, pb.model.grid, pb.model.h_basis, ["energy_balance_window"])
    md = Model(pb.meas, pb.model.grid, pb.model.h_basis, ["energy_balance"])
    assert [n for n in m1.parameter_space().names if n.startswith("eb_alpha")] == ["eb_alpha"]
    assert "energy_balance_window" not in candidate_names()
    p1 = {k: np.array([v]) for k, v in m1.parameter_space().value_dict().items()}
    p1["eb_alpha"] = np.array([0.7])
    pd = {k: np.array([v]) for k, v in md.parameter_space().value_dict().items()}
    pd.update(eb_alpha_1=np.array([0.7]), eb_alpha_2=np.array([0.7]))
    np.testing.assert_allclose(m1.predict(p1), md.predict(pd), rtol=1e-12)
    part = energy_partition(m1, p1)
    w = priestley_taylor_weight(pb.meas.T_air) * np.clip(pb.meas.q_net, 0, None)
    np.testing.assert_allclose(part.LE[0], 0.7 * w, rtol=1e-12)


def test_one_alpha_per_day_and_the_forecast_day_keeps_the_last():
    t = np.arange(0, 72 * 3600 + 1, 1800.0)
    assert day_index(t).max() == 2 and day_index(t)[-1] == 2 and day_index(t)[48] == 1
    t4 = np.arange(0, 96 * 3600 + 1, 1800.0)
    assert day_index(t4, 3).max() == 2 and day_index(t4).max() == 3


def test_energy_balance_is_named_not_a_default_candidate():
    assert "energy_balance" in extension_names()
    assert "energy_balance" not in candidate_names()
    assert "wind_convection" in candidate_names()


def test_energy_figure_and_report_section(twin):
    """The figure holds Rn and the three fluxes (medians with bands) through the window and the
    mean day; the report section reads the draws of a run view and skips other models."""
    from pavement_mcmc.report.energy import energy_section

    pb, _ = twin
    rng = np.random.default_rng(0)
    th = pb.space.initial()[None, :] * (1 + 0.05 * rng.standard_normal((20, len(pb.space.free))))

    class View:  # the one method of RunView the section uses
        def draws(self, n):
            return th[:n]

    frag, figs = energy_section(pb, View(), n_draws=20)
    assert "Bowen ratio H/LE" in frag and "G/Rn" in frag
    (fig,) = figs
    left, right = fig.axes
    assert [ln.get_label() for ln in left.get_lines()][:4] == [
        "net radiation Rn (measured)", "sensible heat H", "latent heat LE", "ground heat G"]
    assert len(left.collections) == 3 and len(right.collections) == 3  # the bands
    assert "Bowen ratio" in fig._suptitle.get_text()
    x = right.get_lines()[0].get_xdata()
    assert x.min() > 0 and x.max() < 24 and np.all(np.diff(x) > 0)
    base = build_problem(load_case(REPO / "runs" / "caseA.toml"))
    assert energy_section(base, View()) is None


def test_fit_output_names_the_midday_partition(twin):
    from types import SimpleNamespace

    from pavement_mcmc.cli.fit import _energy_line

    pb, _ = twin
    line = _energy_line(SimpleNamespace(problem=pb, table=[{"parameter": "eb_alpha_1", "mean": 0.0},
                                                           {"parameter": "eb_alpha_2", "mean": 0.0}]))
    assert line.startswith("surface energy balance at midday") and "LE/Rn 0.00" in line
    base = build_problem(load_case(REPO / "runs" / "caseA.toml"))
    assert _energy_line(SimpleNamespace(problem=base, table=[])) is None


def test_forecast_keeps_the_last_fitted_days_alpha(twin):
    """A forecast past the training days keeps the last fitted day's Priestley-Taylor
    coefficient (the daily coefficients are one parameter group). Before, a future day's
    coefficient stayed at its start value 0.5: the desert window's next-day forecast then
    evaporated 0.5 of the net radiation from a dry soil (forecast RMSE 2.5 against 0.84 degC)."""
    from pavement_mcmc.criticism.forecast import future_values, split_rows, training_problem

    pb, _ = twin
    train = training_problem(pb, split_rows(pb.meas.t, 20.0))
    assert [n for n in train.space.names if n.startswith("eb_alpha")] == ["eb_alpha_1"]
    fitted = {**train.space.value_dict(), "eb_alpha_1": 0.93, "kappa": 1.1}
    vals = future_values(pb, train, fitted)
    assert vals["eb_alpha_2"] == 0.93 and vals["kappa"] == 1.1


def test_needs_net_radiation(twin):
    pb, _ = twin
    meas = replace(pb.meas, q_net=np.zeros_like(pb.meas.q_net))
    with pytest.raises(ValueError, match="net radiation"):
        Model(meas, pb.model.grid, pb.model.h_basis, ["energy_balance"]).parameter_space()


def test_the_midday_line_says_when_the_bowen_ratio_is_undefined():
    """With no latent heat (the dry desert, alpha fixed at 0) H/LE has no value: the line a
    user reads says so instead of 'Bowen ratio H/LE nan'."""
    from pavement_mcmc.physics.catalogue.energy import Partition

    t = np.arange(0.0, 24 * 3600.0, 3600.0)
    Rn = np.clip(500 * np.sin(np.pi * (t / 3600.0 - 6) / 12), 0, None)[None, :]
    part = Partition(t, Rn, 0.7 * Rn, 0.0 * Rn, 0.3 * Rn)
    text = part.summary_text()
    assert "nan" not in text and "Bowen ratio H/LE undefined (no latent heat)" in text
    assert "G/Rn 0.30" in text and "LE/Rn 0.00" in text


def test_partition_with_a_surface_layer_is_the_skin_balance(twin):
    """With ``surface_layer`` (coeffs.h and coeffs.q damped by 1 + hR) H is still the skin's
    H = Rn - LE - G = h_H (T_k - T_a), and nothing is 'kept off the spot' without a shadow."""
    pb, _ = twin
    from pavement_mcmc.physics.skin import skin_temperature
    m = Model(pb.meas, pb.model.grid, pb.model.h_basis, ["energy_balance", "surface_layer"])
    p = {k: np.array([v]) for k, v in pb.space.value_dict().items()}
    p["R_surface"] = np.array([0.3])
    part = energy_partition(m, p)
    assert np.max(np.abs(part.off)) == 0.0
    assert "off_Rn" not in part.midday()
    np.testing.assert_allclose(part.H + part.LE + part.G, part.Rn, atol=1e-9)
    co = m.coefficients(p)
    T_k = skin_temperature(m, m.solve(p), co, p)
    hH = p["eb_h0"][:, None] + p["eb_h1"][:, None] * m.meas.wind[None, :]
    law = hH * (T_k - m.meas.T_air)  # at the times (the model's h is per interval: ~ 5 %)
    day = m.meas.q_net > 0.5 * m.meas.q_net.max()
    assert part.H[0, day].sum() == pytest.approx(law[0, day].sum(), rel=0.05)


def test_the_balance_sets_h_before_a_layer_damps_it_whatever_the_order_listed(twin):
    """``surface_layer`` listed before the balance damped an h of 0 and lost its resistance
    (the balance then overwrote h): the law that replaces h(t) runs first, so both orders give
    the same coefficients (the gradient in that order: tests/posterior/test_gradients.py)."""
    pb, _ = twin
    p = {k: np.array([v]) for k, v in pb.space.value_dict().items()}
    p["R_surface"] = np.array([0.3])
    after, before = (Model(pb.meas, pb.model.grid, pb.model.h_basis, names) for names in
                     (["energy_balance", "surface_layer"], ["surface_layer", "energy_balance"]))
    ca, cb = after.coefficients(p), before.coefficients(p)
    np.testing.assert_allclose(cb.h, ca.h)
    np.testing.assert_allclose(cb.q, ca.q)
    assert np.mean(ca.h) < 0.5 * np.mean(after.extensions[0].transfer(p, pb.meas))  # damped


def test_a_layer_damps_every_other_surface_term_whatever_the_order_listed(twin):
    """A shadow (or any term that adds to q) listed after ``surface_layer`` escaped its damping:
    the layer's hook runs last, so every order gives the same coefficients."""
    pb, _ = twin
    p = {k: np.array([v]) for k, v in pb.space.value_dict().items()}
    p.update(R_surface=np.array([0.3]), shade_start=np.array([-2.0]),
             shade_length=np.array([4.0]), shade_fraction=np.array([0.8]))
    orders = (["energy_balance", "shading", "surface_layer"],
              ["energy_balance", "surface_layer", "shading"],
              ["surface_layer", "shading", "energy_balance"])
    co = [Model(pb.meas, pb.model.grid, pb.model.h_basis, names).coefficients(p) for names in orders]
    for c in co[1:]:
        np.testing.assert_allclose(c.h, co[0].h)
        np.testing.assert_allclose(c.q, co[0].q)


@pytest.mark.parametrize("other, value", [("radiation_factor", {"rad_factor": 1.2}),
                                          ("shading", {"shade_start": -2.0, "shade_length": 4.0,
                                                       "shade_fraction": 0.8})])
def test_the_partition_books_other_surface_terms_apart_from_the_sensible_heat(twin, other, value):
    """Rn = H + LE + G + off with ``off`` every other surface term (not only a shadow): H stays
    the law's h_H (T_s - T_a); a radiation factor used to land in H."""
    pb, _ = twin
    m = Model(pb.meas, pb.model.grid, pb.model.h_basis, ["energy_balance", other])
    p = {k: np.array([v]) for k, v in pb.space.value_dict().items()}
    p.update({k: np.array([v]) for k, v in value.items()})
    part = energy_partition(m, p)
    T_s = m.solve(p)[..., 0]
    law = m.extensions[0].transfer(p, m.meas) * (T_s - m.meas.T_air[None, :])
    day = m.meas.q_net > 0.5 * m.meas.q_net.max()
    assert np.abs(part.off[0, day]).mean() > 30.0  # the term is on
    assert np.mean(np.abs(part.H[0, day] - law[0, day])) < 10.0
