"""The season: the measured midday G/Rn beside a batch's rows, its figure, and the desert
record's daily-window case (``runs/desert_daily.toml``; the record is read in place and those
tests skip without it)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.batch import G_RN, midday_ratio, season_rows, window_units

REPO = Path(__file__).resolve().parents[2]
DESERT = REPO.parent / "shared" / "data" / "soilvue_utah" / "measurements.csv"


def _day(n_days: int = 2):
    """Hourly net radiation: a half-sine of 600 W m-2 from 06 to 18 h, -60 at night."""
    hours = np.arange(24 * n_days + 1, dtype=float)
    local = hours % 24
    q = np.where((local > 6) & (local < 18), 600.0 * np.sin(np.pi * (local - 6) / 12), -60.0)
    return hours, q


def test_midday_ratio_is_the_share_over_the_rows_above_half_the_peak():
    _, q = _day(1)
    assert midday_ratio(0.3 * q, q) == pytest.approx(0.3, rel=1e-12)
    # a flux that differs only outside midday (Rn <= 300 W m-2) leaves the ratio unchanged
    G = np.where(q > 300.0, 0.3 * q, 55.0)
    assert midday_ratio(G, q) == pytest.approx(0.3, rel=1e-12)
    # by hand: 600 sin > 300 W m-2 from 9 to 15 h, 7 rows
    rows = q > 300.0
    assert rows.sum() == 7 and midday_ratio(np.where(rows, 1.0, 0.0), q) == pytest.approx(
        7.0 / q[rows].sum())
    gap = 0.3 * q
    gap[12] = np.nan
    assert math.isnan(midday_ratio(gap, q))  # a gap at midday is not filled
    night = 0.3 * q
    night[0] = np.nan
    assert midday_ratio(night, q) == pytest.approx(0.3)  # a gap at night does not matter
    assert math.isnan(midday_ratio(np.zeros(5), -np.ones(5)))  # never positive
    with pytest.raises(ValueError, match="shape"):
        midday_ratio(np.zeros(3), np.zeros(4))


def _write(path: Path, hours, cols: dict) -> Path:
    times = [f"2025-07-{1 + int(h) // 24:02d}T{int(h) % 24:02d}:00:00Z" for h in hours]
    with open(path, "w") as fh:
        fh.write(",".join(["time", *cols]) + "\n")
        for i, t in enumerate(times):
            cells = ["" if np.isnan(v[i]) else repr(float(v[i])) for v in cols.values()]
            fh.write(",".join([t, *cells]) + "\n")
    return path


def test_season_rows_take_each_windows_own_midday_share(tmp_path):
    hours, q = _day(2)
    G = np.where(hours < 24, 0.2, 0.4) * q
    meas = _write(tmp_path / "m.csv", hours, {"T_air": q * 0, "q_net": q})
    extras = _write(tmp_path / "e.csv", hours, {"G_surface": G})
    rows = [{"key": "a", "start_h": 0.0, "end_h": 24.0}, {"key": "b", "start_h": 24.0, "end_h": 48.0},
            {"key": "c", "start_h": math.nan, "end_h": math.nan}]
    out = season_rows(rows, meas, extras)
    assert out[0][G_RN] == pytest.approx(0.2) and out[1][G_RN] == pytest.approx(0.4)
    assert math.isnan(out[2][G_RN]) and out[0]["key"] == "a" and G_RN not in rows[0]
    from pavement_mcmc.data import DataError

    with pytest.raises(DataError, match="H_flux"):
        season_rows(rows, meas, extras, flux="H_flux")
    short = _write(tmp_path / "s.csv", hours[:24], {"G_surface": G[:24]})
    with pytest.raises(DataError, match="same times"):
        season_rows(rows, meas, short)


def test_season_figure_has_four_labelled_panels_and_breaks_at_failed_days():
    from pavement_mcmc.plotting import plot_season

    rows = []
    for i in range(6):
        failed = i == 3
        r = {"key": f"d{i}", "site": "desert", "start_time": f"2025-07-{1 + i:02d}T07:00:00Z",
             "start_h": 24.0 * i, "end_h": 24.0 * (i + 1), "status": "failed" if failed else "ok",
             "converged": not failed and i != 4, G_RN: 0.2 + 0.01 * i}
        for col, v in (("kappa", 0.7), ("C", 1.8e6), ("diffusivity", 0.39e-6)):
            r[col], r[f"{col}_lo"], r[f"{col}_hi"] = ((math.nan,) * 3 if failed
                                                     else (v, 0.8 * v, 1.2 * v))
        rows.append(r)
    fig = plot_season(rows, flux_label="G_surface (extras.csv)", note="κ and C: their priors")
    axes = fig.axes
    assert len(axes) == 4
    assert [a.get_ylabel() for a in axes] == ["κ (W m⁻¹ K⁻¹)", "C (MJ m⁻³ K⁻¹)", "κ/C (mm² s⁻¹)",
                                              "midday G/Rn (–)"]
    mean_line = [ln for ln in axes[2].get_lines() if ln.get_label().endswith("posterior mean")][0]
    y = np.asarray(mean_line.get_ydata(), float)
    assert np.isnan(y[3]) and y[0] == pytest.approx(0.39)  # the failed day breaks the line
    flux_line = [ln for ln in axes[3].get_lines() if "G_surface" in ln.get_label()][0]
    assert np.isnan(np.asarray(flux_line.get_ydata(), float)).sum() == 0  # every day measured
    labels = [t.get_text() for t in axes[3].get_legend().get_texts()]
    assert any("G_surface" in t for t in labels) and "1 failed" in fig._suptitle.get_text()
    assert any(t.get_text() == "not converged" for t in axes[0].get_legend().get_texts())
    assert axes[0].get_title(loc="left") == "κ and C: their priors"


@pytest.mark.skipif(not DESERT.is_file(), reason=f"the shared desert record is not here ({DESERT})")
def test_desert_daily_case_loads_and_cuts_30_july_days_and_the_season():
    from pavement_mcmc.data import load_case

    case = REPO / "runs" / "desert_daily.toml"
    cfg = load_case(case)
    m = cfg.measurements
    assert cfg.raw["model"]["top"] == "measured" and list(m.depths * 100) == [5, 10, 20, 30]
    july = window_units(case, windows=[(2928.0 + 24 * i, 2952.0 + 24 * i) for i in range(30)])
    assert len(july) == 30 and len({u.key for u in july}) == 30
    assert july[0].start_time == "2025-07-01T07:00:00Z" and july[-1].start_time == "2025-07-30T07:00:00Z"
    one = load_case(case, overrides=july[-1].config_overrides(1)).measurements
    assert one.T_obs.shape == (25, 4)
    season = window_units(case, "24h", "24h")
    assert len(season) == 213 and season[0].start_time == "2025-03-01T07:00:00Z"
