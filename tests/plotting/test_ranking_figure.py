"""Issue 11, item 8: missing_effects.png colours only the claimed missing effect red; a
prior-driven candidate above the threshold, which the verdict does not claim, is not red."""

from __future__ import annotations

from types import SimpleNamespace

from matplotlib.colors import to_rgba

from pavement_mcmc.plotting.criticism import RANKING_STYLE, plot_ranking


def _entry(name, score, detected, prior_driven, forecast_gain=None):
    return SimpleNamespace(name=name, score=score, detected=detected, prior_driven=prior_driven,
                           forecast_gain=forecast_gain)


def _colours(fig):
    ax = fig.axes[0]
    names = [t.get_text() for t in ax.get_yticklabels()]
    out = {}
    for patch in ax.patches:
        y = patch.get_y() + patch.get_height() / 2
        out[names[round(y)]] = patch.get_facecolor()
    return out, ax.get_legend_handles_labels()[1]


def test_prior_driven_candidate_is_not_red():
    best = _entry("two_layer", 400.0, True, False)
    entries = [best, _entry("sensor_bias", 380.0, True, False),
               _entry("radiation_factor", 60.0, False, True), _entry("evaporation", 2.0, False, False)]
    ranking = SimpleNamespace(entries=entries, best=best, threshold=10.0)
    colours, labels = _colours(plot_ranking(ranking))
    red = to_rgba(RANKING_STYLE["claimed"][0])
    assert colours["two_layer"] == red
    assert colours["radiation_factor"] != red and colours["sensor_bias"] != red
    assert colours["evaporation"] != red
    assert any("prior-driven" in lab for lab in labels)


def test_no_claim_no_red():
    entries = [_entry("radiation_factor", 60.0, False, True), _entry("evaporation", 2.0, False, False)]
    ranking = SimpleNamespace(entries=entries, best=None, threshold=10.0)
    colours, _ = _colours(plot_ranking(ranking))
    assert to_rgba(RANKING_STYLE["claimed"][0]) not in colours.values()


def test_under_the_forecast_rule_the_figure_shows_the_claim_rules_gain_first():
    """The figure drew only the in-sample S with its threshold 10 while the verdict claims by
    the forecast gain F > 15: a claimed candidate could sit left of the drawn threshold. The
    first panel is now F with its threshold, S beside it."""
    import numpy as np

    from pavement_mcmc.criticism.entries import FORECAST_THRESHOLD

    best = _entry("two_layer", 8.0, True, False, forecast_gain=65.0)  # S below 10, F above 15
    entries = [best, _entry("evaporation", 30.0, False, False, forecast_gain=-4.0)]
    fig = plot_ranking(SimpleNamespace(entries=entries, best=best, threshold=10.0))
    f_ax, s_ax = fig.axes[:2]
    assert "forecast gain" in f_ax.get_title() and "S" in s_ax.get_title()
    f_line = [ln.get_xdata()[0] for ln in f_ax.lines if ln.get_linestyle() == "--"]
    assert np.allclose(f_line, np.log10(1 + FORECAST_THRESHOLD))
    widths = {round(p.get_y() + p.get_height() / 2): p.get_width() for p in f_ax.patches}
    assert widths[1] > f_line[0] and widths[0] < 0  # two_layer (top row) past it, evaporation < 0


def test_a_candidate_stopped_out_of_sensor_has_its_own_colour():
    """A candidate that forecasts better but misses a sensor out of sensor (not claimed) was
    drawn grey as 'data part below the threshold, or at a bound', past the dashed line."""
    stopped = _entry("two_layer", 146.0, False, False, forecast_gain=21.0)
    stopped.unpredicted = ("0cm", 2.6)
    other = _entry("evaporation", 2.0, False, False, forecast_gain=-0.6)
    colours, labels = _colours(plot_ranking(SimpleNamespace(entries=[stopped, other], best=None,
                                                            threshold=10.0)))
    assert colours["two_layer"] != colours["evaporation"]
    assert any("out of sensor" in lab for lab in labels), labels
