"""Issue 11, item 8: missing_effects.png colours only the claimed missing effect red; a
prior-driven candidate above the threshold, which the verdict does not claim, is not red."""

from __future__ import annotations

from types import SimpleNamespace

from matplotlib.colors import to_rgba

from pavement_mcmc.plotting.criticism import RANKING_STYLE, plot_ranking


def _entry(name, score, detected, prior_driven):
    return SimpleNamespace(name=name, score=score, detected=detected, prior_driven=prior_driven)


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
