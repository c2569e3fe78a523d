"""``energy_balance_pm``: latent heat in the Penman–Monteith form where the record has RH
(physics/catalogue/penman.py). Its limits by hand, and a twin from the independent simulator
whose latent heat follows Penman–Monteith on its own h(t) and vapour pressure
(``SyntheticSpec.surface_resistance``): the law recovers the resistance and the soil, and the
Priestley–Taylor law, blind to the air's dryness, does not."""

from __future__ import annotations

import numpy as np
import pytest

from pavement_mcmc.criticism import refit
from pavement_mcmc.criticism.point import case_problem
from pavement_mcmc.physics import get_extension
from pavement_mcmc.physics.catalogue.energy import energy_partition
from pavement_mcmc.physics.catalogue.penman import GAMMA, RHO_CP, penman_monteith, saturation
from pavement_mcmc.synthetic import SyntheticSpec
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin
from pavement_mcmc.synthetic.simulate import simulate

#: the simulator's Penman-Monteith on its own R_n - G (et_available's default), lagged a step
PM = {"vapour_kPa": 1.0, "surface_resistance": 150.0, "tower": 1.0}


def test_the_limits_by_hand():
    T, Rn, h = np.array([10.0, 20.0, 30.0]), np.array([400.0, 400.0, -60.0]), 12.0
    es, s = saturation(T)
    # saturated air, no resistance: the equilibrium evaporation s Rn / (s + gamma), dew at night
    np.testing.assert_allclose(penman_monteith(Rn, T, 100.0, h, 0.0), s * Rn / (s + GAMMA))
    # a large resistance: the supply limit (s A + h D) rho c_p / (gamma r_s h)
    r_s = 1e6
    D = es * (1 - 0.4)
    np.testing.assert_allclose(penman_monteith(Rn, T, 40.0, h, r_s),
                               (s * Rn + h * D) * RHO_CP / (GAMMA * r_s * h),
                               rtol=1e-3)
    # one value worked by hand: 20 degC, RH 50 %, Rn 400, h 12, r_s 70: e_s 2.338 kPa, s 0.1447
    # kPa/K, D 1.169 kPa, denominator 0.1447 + 0.066 x 1.7 = 0.2569: (57.90 + 14.03) / 0.2569
    assert penman_monteith(400.0, 20.0, 50.0, 12.0, 70.0) == pytest.approx(279.9, abs=0.2)
    # the ground's share comes off the available energy: f (Rn - G)
    assert (penman_monteith(400.0, 20.0, 50.0, 12.0, 70.0)
            - penman_monteith(400.0, 20.0, 50.0, 12.0, 70.0, G=100.0)) == pytest.approx(
        100.0 * 57.90 / 400.0 / 0.2569, rel=2e-3)
    # a drier air draws more, a larger resistance less
    assert np.all(penman_monteith(Rn, T, 30.0, h, 100.0) > penman_monteith(Rn, T, 70.0, h, 100.0))
    assert np.all(penman_monteith(Rn, T, 50.0, h, 300.0) < penman_monteith(Rn, T, 50.0, h, 100.0))


def test_the_twin_carries_rh_and_its_latent_heat():
    cols, truth = simulate(SyntheticSpec(hours=48.0, step_minutes=30.0, seed=4, **PM))
    rh = cols["RH"]
    assert 0 < rh.min() and rh.max() <= 100.0
    assert np.corrcoef(rh, cols["T_air"])[0, 1] < -0.9  # a fixed vapour pressure: RH falls as T rises
    assert np.median(cols["LE"][cols["q_net"] > 300]) > 100  # the tower sees the latent heat
    with pytest.raises(ValueError, match="needs vapour_kPa > 0"):
        simulate(SyntheticSpec(hours=24.0, surface_resistance=100.0))
    with pytest.raises(ValueError, match="must be >= 0"):
        simulate(SyntheticSpec(hours=24.0, vapour_kPa=-1.0))


def test_the_law_refuses_a_record_without_humidity(tmp_path):
    twin = forecast_twins((), (5,), hours=48.0)[0]
    pb, _ = case_problem(write_twin(twin, tmp_path / "dry"))
    with pytest.raises(ValueError, match="needs the air.s humidity"):
        get_extension("energy_balance_pm").parameters(pb.meas)


def test_a_penman_monteith_twin_is_recovered_and_priestley_taylor_is_not(tmp_path):
    twin = forecast_twins(("wind_convection",), (1,), hours=72.0, spec=PM)[0]
    case = write_twin(twin, tmp_path / twin.name)
    pb, _ = case_problem(f"{case}+energy_balance_pm_window")
    fit = refit(pb)
    v = fit.values()
    assert v["eb_rs"] == pytest.approx(150.0, rel=0.15)
    assert v["kappa"] == pytest.approx(twin.spec.kappa, rel=0.1)
    assert v["C"] == pytest.approx(twin.spec.C, rel=0.2)
    p = {k: np.array([x]) for k, x in {**pb.space.value_dict(), **v}.items()}
    LE = energy_partition(pb.model, p).LE[0]
    day = pb.meas.q_net > 300
    measured = np.asarray(pb.meas.extras["LE"])  # the twin's tower closes 100 %, +-10 % noise
    assert abs(np.mean(LE[day] - measured[day])) < 0.05 * np.mean(measured[day])
    assert np.sqrt(np.mean((LE[day] - measured[day]) ** 2)) < 0.15 * np.mean(measured[day])
    pt, _ = case_problem(f"{case}+energy_balance_window")
    pt_fit = refit(pt)
    assert pt_fit.rmse > 1.2 * fit.rmse
    assert abs(pt_fit.values()["C"] / twin.spec.C - 1) > 0.3  # it pays with the soil


def test_one_resistance_a_day_is_a_group():
    ext = get_extension("energy_balance_pm")

    class Meas:
        t = np.arange(0, 72 * 3600 + 1, 1800.0)
        q_net = np.ones(t.size)
        wind = None
        extras = {"RH": np.full(t.size, 50.0)}

    names = [p.name for p in ext.parameters(Meas)]
    assert names == ["eb_h0", "eb_rs_1", "eb_rs_2", "eb_rs_3"]
    assert {p.group for p in ext.parameters(Meas) if p.name.startswith("eb_rs")} == {"eb_rs"}
    Meas.extras = {"RH": np.r_[np.nan, np.full(Meas.t.size - 1, 50.0)]}
    with pytest.raises(ValueError, match="without gaps"):
        ext.parameters(Meas)


def test_the_report_names_the_latent_heat_law(tmp_path):
    from pavement_mcmc.report.energy import energy_section

    twin = forecast_twins(("wind_convection",), (2,), hours=48.0, spec=PM)[0]
    case = write_twin(twin, tmp_path / twin.name)
    for law, words in (("energy_balance_pm_window", "Penman–Monteith"),
                       ("energy_balance_window", "Priestley–Taylor")):
        pb, _ = case_problem(f"{case}+{law}")
        class View:
            def __init__(self, th):
                self.th = th

            def draws(self, n):
                return self.th[:n]

        frag, _ = energy_section(pb, View(pb.space.initial()[None, :].repeat(2, axis=0)), n_draws=2)
        assert words in frag and "flux tower" in frag
