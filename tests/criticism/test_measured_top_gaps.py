"""Criticism of a measured-top fit whose record has gaps in the forcing it does not use."""

from __future__ import annotations

import numpy as np

from pavement_mcmc.criticism.ranking import rank_missing_effects
from pavement_mcmc.criticism.residuals import derived_signals
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem


def _case(tmp_path):
    """24 half-hourly rows; sensors at 2 (the top), 5, 10 and 50 cm (the bottom); the air
    temperature and net radiation blank for 3.5 h."""
    rows = []
    for i in range(24):
        air, q = ("", "") if 5 <= i < 12 else (f"{10 + 0.5 * i:.2f}", f"{50.0 * i:.1f}")
        rows.append(f"2020-04-05T{i // 2:02d}:{30 * (i % 2):02d}:00Z,{air},{q},"
                    f"{9 + 0.3 * np.sin(i / 3):.3f},{8.5 + 0.1 * np.sin(i / 3 - 0.5):.3f},8.0,7.0")
    (tmp_path / "m.csv").write_text("time,T_air,q_net,T_2cm,T_5cm,T_10cm,T_50cm\n" + "\n".join(rows) + "\n")
    (tmp_path / "case.toml").write_text('[data]\ncsv = "m.csv"\nsigma = 0.1\n[model]\ntop = "measured"\n')
    return build_problem(load_case(tmp_path / "case.toml"))


def test_surface_candidates_are_not_tried_under_a_measured_top(tmp_path):
    """A surface candidate fed the blank radiation made the solver refuse non-finite
    coefficients (diagnose crashed on 12 desert days); under a measured top it has nothing to
    act on and is listed as not tried, while the material candidates are scored."""
    pb = _case(tmp_path)
    rk = rank_missing_effects(pb, {"kappa": 0.8, "C": 1.6e6}, forecast=False)
    tried = {e.name for e in rk.entries}
    for name in ("radiation_factor", "evapotranspiration", "surface_layer"):
        assert "measured top" in rk.skipped[name]
        assert name not in tried
    assert {"two_layer", "sensor_bias"} <= tried
    assert all(np.isfinite(e.score) for e in rk.entries)


def test_signals_with_a_gap_are_left_out_of_the_correlations(tmp_path):
    meas = _case(tmp_path).model.meas
    sig = derived_signals(meas)
    assert "q_net" not in sig and "T_air-T_s" not in sig and "tod_sin" in sig
    assert all(np.isfinite(v).all() for v in sig.values())


def test_the_forecast_of_a_measured_top_fit_says_what_drives_it(tmp_path):
    """No h(t) is carried forward under a measured top: the caption must not say so."""
    from pavement_mcmc.criticism.forecast import forecast

    fc = forecast(_case(tmp_path), {"kappa": 0.8, "C": 1.6e6})
    assert fc.top_measured and fc.future == "then the measured top sensor alone"
    assert np.isfinite(fc.rmse) and fc.n > 0
