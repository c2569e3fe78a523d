"""The residual figures a user reads first: every signal named in words (not `tod_sin`), the
depth x time map on the same time axis as the per-sensor series, every sensor's depth a tick."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pavement_mcmc.criticism.residuals import SIGNALS, analyse
from pavement_mcmc.data import load_case
from pavement_mcmc.plotting.criticism import plot_residual_correlations, plot_residual_map
from pavement_mcmc.posterior import build_problem

REPO = Path(__file__).resolve().parents[2]


def _report():
    meas = build_problem(load_case(REPO / "runs" / "hidden.toml")).meas
    rng = np.random.default_rng(0)
    pred = meas.T_obs + 0.1 * rng.normal(size=meas.T_obs.shape)
    return analyse(meas, pred)


def test_signals_are_named_in_words():
    fig = plot_residual_correlations(_report())
    ticks = [t.get_text() for t in fig.axes[0].get_xticklabels()]
    assert ticks and not set(ticks) & set(SIGNALS)  # no raw key left
    assert "time of day (sine)" in ticks and fig.axes[0].get_ylabel() == "sensor"


def test_the_map_and_the_series_share_the_time_axis_and_width():
    rep = _report()
    fig = plot_residual_map(rep)
    ax_map, ax_series = fig.axes[0], fig.axes[1]
    assert ax_map.get_xlim() == ax_series.get_xlim()
    assert np.isclose(ax_map.get_position().width, ax_series.get_position().width)
    ticks = [float(t) for t in ax_map.get_yticks()]
    assert np.allclose(sorted(ticks), sorted(rep.depths * 100))
