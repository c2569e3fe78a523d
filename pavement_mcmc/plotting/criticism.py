"""Figures of the model criticism: residual depth x time map, residual correlations, the
missing-effect ranking and the side-by-side residuals of compared runs.

Every function takes result objects of :mod:`pavement_mcmc.criticism` (plain attributes, no
recomputation) plus an optional ``fig`` and returns the :class:`~matplotlib.figure.Figure`.
"""

from __future__ import annotations

import numpy as np
from matplotlib.colors import TwoSlopeNorm
from matplotlib.figure import Figure

from ..criticism.residuals import SIGNAL_LABELS
from ._base import SENSOR_COLOURS, new_figure


def plot_residual_map(report, fig: Figure | None = None, title: str = "") -> Figure:
    """Residuals (predicted - measured) as a depth x time map, above the per-sensor series.

    Parameters
    ----------
    report : a :class:`~pavement_mcmc.criticism.residuals.ResidualReport`.
    fig : figure to draw into (cleared), default a new one.
    title : optional title.
    """
    fig = new_figure(fig, (9.0, 6.0))
    ax1, ax2, ax3 = fig.subplots(3, 1, sharex=False, height_ratios=[2.2, 2.0, 1.6])
    ax2.sharex(ax1)  # the map and the series on one time axis
    th = report.t / 3600.0
    r = report.residuals
    lim = max(float(np.max(np.abs(r))), 1e-6)
    z = report.depths * 100
    # cell edges in depth for pcolormesh
    ze = (
        np.concatenate(([z[0] - 0.5], 0.5 * (z[1:] + z[:-1]), [z[-1] + 0.5]))
        if z.size > 1
        else np.array([z[0] - 0.5, z[0] + 0.5])
    )
    te = np.concatenate(([th[0]], 0.5 * (th[1:] + th[:-1]), [th[-1]]))
    m = ax1.pcolormesh(te, ze, r.T, cmap="RdBu_r", norm=TwoSlopeNorm(0.0, -lim, lim))
    ax1.invert_yaxis()
    ax1.set_ylabel("sensor depth (cm)")
    ax1.set_yticks(z, [f"{d:g}" for d in z])
    # one width for every panel (the colour bar beside the map, at the top)
    fig.colorbar(m, ax=[ax1, ax2, ax3], label="pred − meas (°C)", shrink=0.38, anchor=(0.0, 1.0))
    ax1.set_title(
        title or f"residuals: RMSE {report.rmse:.3f} °C = {report.rmse_sigma:.2f} σ, lag-1 {report.rho:.2f}"
    )
    for s, lab in enumerate(report.labels):
        ax2.plot(th, r[:, s], lw=0.9, color=SENSOR_COLOURS[s % len(SENSOR_COLOURS)], label=lab)
    ax2.axhspan(-report.sigma, report.sigma, color="0.85", zorder=0, label="±σ")
    ax2.set_ylabel("pred − meas (°C)")
    ax2.set_xlabel("time (h)")
    ax2.legend(ncol=len(report.labels) + 1, fontsize=7, loc="upper left")
    rm = [s.rmse for s in report.sensors]
    bi = [s.bias for s in report.sensors]
    ax3.plot(rm, z, "o-", label="RMSE")
    ax3.plot(bi, z, "s--", label="mean (bias)")
    ax3.axvline(report.sigma, color="0.5", lw=0.8, ls=":", label="σ")
    ax3.axvline(0, color="0.3", lw=0.5)
    ax3.invert_yaxis()
    ax3.set_xlabel("residual over the window, per sensor (°C)")
    ax3.set_ylabel("depth (cm)")
    ax3.legend(fontsize=7)
    return fig


def plot_residual_correlations(report, fig: Figure | None = None) -> Figure:
    """z-scores of the correlation of each sensor's residuals with forcing and derived signals
    (Bartlett-corrected for autocorrelation; |z| > 3 is marked)."""
    fig = new_figure(fig, (8.5, 4.2))
    ax = fig.subplots()
    names = list(report.sensors[0].correlations)
    Z = np.array([[s.correlations[n][1] for n in names] for s in report.sensors])
    lim = max(3.0, float(np.max(np.abs(Z))))
    m = ax.imshow(Z, cmap="PuOr_r", vmin=-lim, vmax=lim, aspect="auto")
    ax.set_xticks(range(len(names)), [SIGNAL_LABELS.get(n, n) for n in names], rotation=30,
                  ha="right", fontsize=8)
    ax.set_yticks(range(len(report.labels)), report.labels)
    for i in range(Z.shape[0]):
        for j in range(Z.shape[1]):
            if abs(Z[i, j]) >= 3:
                ax.text(j, i, f"{Z[i, j]:.0f}", ha="center", va="center", fontsize=7)
    fig.colorbar(m, ax=ax, label="z of the correlation (|z| ≥ 3 written)")
    ax.set_ylabel("sensor")
    ax.set_title("residuals (predicted − measured) against the forcing and derived signals")
    return fig


#: bar colours of :func:`plot_ranking` by the candidate's standing in the verdict
RANKING_STYLE = {"claimed": ("C3", "missing effect (claimed)"),
                 "lookalike": ("C1", "look-alike (detected, not claimed)"),
                 "prior": ("0.85", "prior-driven (not claimed)"),
                 "unpredicted": ("C4", "misses a sensor out of sensor (not claimed)"),
                 "other": ("0.6", "not claimed (data part below the threshold, or at a bound)")}


def ranking_status(ranking, entry) -> str:
    """'claimed', 'lookalike', 'prior' (above the threshold thanks to the priors),
    'unpredicted' (stopped by the out-of-sensor check) or 'other'."""
    best = getattr(ranking, "best", None)
    if best is not None and entry.name == best.name:
        return "claimed"
    if getattr(entry, "unpredicted", None) is not None:
        return "unpredicted"
    if entry.prior_driven:
        return "prior"
    return "lookalike" if entry.detected else "other"


def plot_ranking(ranking, fig: Figure | None = None) -> Figure:
    """Each candidate's evidence (bars) against the claim rule's threshold: under the forecast
    rule its forecast gain F (threshold :data:`~pavement_mcmc.criticism.entries.FORECAST_THRESHOLD`)
    beside the in-sample penalised misfit drop S (supporting), else S alone. Red only for the
    claimed missing effect, orange for detected look-alikes, a hatched light grey for the
    prior-driven candidates the verdict does not claim, purple for those the out-of-sensor
    check stopped, grey for the rest (legend below)."""
    from ..criticism.entries import FORECAST_THRESHOLD

    entries = ranking.entries[::-1]
    forecast = any(e.forecast_gain is not None for e in entries)
    panels = [("S", [e.score for e in entries], ranking.threshold,
               "in-sample misfit drop S (penalised)" + (", supporting" if forecast else ""))]
    if forecast:
        gains = [getattr(e, "claim_gain", e.forecast_gain) for e in entries]
        panels.insert(0, ("F", [np.nan if g is None else g for g in gains], FORECAST_THRESHOLD,
                          "forecast gain on the held-out period, the larger of F and the "
                          "ground forecast's G (the claim rule)"))
    height = 0.45 * len(entries) + 2.2
    fig = new_figure(fig, (4.2 * len(panels) + 2.2, height))
    axes = np.atleast_1d(fig.subplots(1, len(panels), sharey=True))
    status = [ranking_status(ranking, e) for e in entries]
    for ax, (name, values, threshold, what) in zip(axes, panels, strict=True):
        sc = np.asarray(values, float)
        shown = np.sign(sc) * np.log10(1 + np.abs(sc))
        for k, st in sorted(RANKING_STYLE.items()):
            rows = [i for i, s in enumerate(status) if s == k]
            if rows:
                ax.barh(rows, shown[rows], color=st[0], label=st[1],
                        hatch="//" if k == "prior" else None,
                        edgecolor="0.4" if k == "prior" else None)
        ax.axvline(np.log10(1 + threshold), color="k", ls="--", lw=0.8)
        ax.axvline(0.0, color="k", lw=0.5)
        ax.set_title(f"{what}\n(dashed: {name} = {threshold:g})", fontsize=8)
        ax.set_xlabel(f"sign({name}) log10(1 + |{name}|)", fontsize=8)
    axes[0].set_yticks(range(len(entries)), [e.name for e in entries])
    handles, texts = axes[0].get_legend_handles_labels()
    fig.legend(handles, texts, fontsize=7, loc="outside lower center", ncol=2, frameon=False)
    fig.suptitle("which effect is missing?")
    return fig


def plot_compare(ledger, fig: Figure | None = None) -> Figure:
    """Residuals of each compared run side by side (same scale), per sensor, with the RMSE."""
    rows = ledger.rows
    fig = new_figure(fig, (3.6 * len(rows) + 0.5, 3.6))
    axes = np.atleast_1d(fig.subplots(1, len(rows), sharey=True))
    lim = max(float(np.max(np.abs(r.residuals))) for r in rows)
    for ax, row in zip(axes, rows, strict=True):
        th = row.t / 3600.0
        for s, lab in enumerate(row.labels):
            ax.plot(th, row.residuals[:, s], lw=0.8, label=lab, color=SENSOR_COLOURS[s % len(SENSOR_COLOURS)])
        ax.set_ylim(-1.05 * lim, 1.05 * lim)
        ax.set_title(f"{row.label}\nRMSE {row.rmse:.3f} °C, lag-1 {row.lag1:.2f}", fontsize=9)
        ax.set_xlabel("time (h)")
        ax.axhline(0, color="k", lw=0.5)
    axes[0].set_ylabel("pred − meas (°C)")
    axes[-1].legend(fontsize=7)
    return fig


def plot_forecast(base, best=None, fig: Figure | None = None, labels=("base", ""),
                  sensors=None) -> Figure:
    """Measured vs predicted temperatures over the held-out period of a forecast
    (:class:`~pavement_mcmc.criticism.forecast.Forecast`): one panel per model (the base and,
    if given, the best candidate), sensors in colour (``sensors``: their labels, for the
    legend), measured as dots, predicted as lines."""
    shown = [(base, labels[0] or "base")] + ([(best, labels[1] or "candidate")] if best else [])
    fig = new_figure(fig, (4.6 * len(shown) + 0.5, 3.8))
    axes = np.atleast_1d(fig.subplots(1, len(shown), sharey=True))
    for ax, (fc, name) in zip(axes, shown, strict=True):
        th = fc.t / 3600.0
        for s in range(fc.observed.shape[1]):
            c = SENSOR_COLOURS[s % len(SENSOR_COLOURS)]
            ax.plot(th, fc.observed[:, s], ".", ms=2.5, color=c)
            ax.plot(th, fc.predicted[:, s], "-", lw=1.0, color=c,
                    label=None if sensors is None else sensors[s])
        ax.set_title(f"{name}: forecast RMSE {fc.rmse:.3f} °C = {fc.rmse_sigma:.2f} σ", fontsize=9)
        ax.set_xlabel("time (h)")
    axes[0].set_ylabel("temperature (°C): dots measured, lines predicted")
    if sensors is not None:
        axes[-1].legend(fontsize=7, title="sensor", title_fontsize=7)
    fig.suptitle(f"held-out {base.horizon:g} h after a fit to the first {base.origins[-1]:g} h "
                 f"({base.future})", fontsize=9)
    return fig


def plot_rolling(rolling, fig: Figure | None = None) -> Figure:
    """Rolling next-day forecasts (:class:`~pavement_mcmc.criticism.rolling.Rolling`): each
    day's forecast RMSE of the base and the law (above) and the day's forecast gain F (below,
    positive: the law forecasts better)."""
    fig = new_figure(fig, (9.0, 5.2))
    ax1, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=[2.0, 1.2])
    x = np.arange(rolling.n)
    base = [d.base_rmse for d in rolling.days]
    law = [d.law_rmse for d in rolling.days]
    ax1.plot(x, base, "o-", color="#7f7f7f", lw=1.0, ms=4, label=f"{rolling.base} (base)")
    ax1.plot(x, law, "s-", color="#d62728", lw=1.0, ms=4, label=f"{rolling.law} (law)")
    ax1.set_ylabel(f"next {rolling.horizon_h:g} h forecast RMSE (°C)")
    ax1.set_ylim(bottom=0)
    ax1.legend(fontsize=8)
    ax1.set_title(f"{rolling.law} better on {rolling.wins} of {rolling.n} days (sign test "
                  f"p = {rolling.p_value:.3f}; {'named' if rolling.named else 'not named'}); "
                  f"each fit to the {rolling.window_h:g} h before the day", fontsize=9)
    F = np.array([d.F for d in rolling.days])
    ax2.bar(x, F, color=np.where(F > 0, "#d62728", "#7f7f7f"))
    ax2.axhline(0, color="k", lw=0.5)
    ax2.set_ylabel("forecast gain F")
    ax2.set_xticks(x, [d.time[:10] for d in rolling.days], rotation=60, fontsize=7)
    ax2.set_xlabel("first day of the fitted window (UTC)")
    return fig
