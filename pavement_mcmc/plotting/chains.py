"""Figures of the Markov chain itself: traces, histograms, log-posterior, acceptance,
autocovariance norm, Geweke and early-versus-late segment box plots.

Chains are ``(n_steps, n_chains, n_params)`` arrays (emcee's ``get_chain()`` layout); every
function returns the :class:`~matplotlib.figure.Figure` it drew on.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from .. import diagnostics as dg
from ._base import display, new_figure, select

__all__ = [
    "plot_acceptance",
    "plot_autocovariance",
    "plot_chains",
    "plot_geweke",
    "plot_logp",
    "plot_segments",
]

_MAX_LINES = 16  # walkers drawn individually in a trace


def _walkers(n_chains: int) -> np.ndarray:
    return np.unique(np.linspace(0, n_chains - 1, min(n_chains, _MAX_LINES)).astype(int))


def plot_chains(
    chain: np.ndarray,
    names: list[str],
    burn_in: int = 0,
    subset: list[str] | None = None,
    truths: dict[str, float] | None = None,
    fig: Figure | None = None,
) -> Figure:
    """Markov chain of each parameter (left) and its histogram after burn-in (right).

    Parameters
    ----------
    chain : (n_steps, n_chains, n_params) stored states.
    names : parameter names (columns of ``chain``).
    burn_in : steps discarded before the histograms (marked by a dashed line).
    subset : names to draw (default all).
    truths : optional true values, drawn as horizontal / vertical lines.
    fig : figure to draw on (cleared), or None for a new one.
    """
    chain = np.asarray(chain, float)
    idx = select(names, subset)
    k = len(idx)
    fig = new_figure(fig, (11, 1.9 * k + 0.6))
    axes = fig.subplots(k, 2, squeeze=False, width_ratios=[3, 1])
    steps = np.arange(chain.shape[0])
    w = _walkers(chain.shape[1])
    for row, j in enumerate(idx):
        f, label = display(names[j])
        ax, axh = axes[row]
        ax.plot(steps, chain[:, w, j] * f, lw=0.5, alpha=0.5, color="0.35")
        ax.plot(steps, chain[:, :, j].mean(axis=1) * f, lw=1.0, color="C0", label="walker mean")
        ax.axvline(burn_in, color="C3", ls="--", lw=1, label=f"burn-in ({burn_in} steps)")
        ax.set_ylabel(label)
        kept = chain[burn_in:, :, j].ravel() * f
        axh.hist(kept, bins=40, density=True, color="C0", alpha=0.7, label="after burn-in")
        axh.set_xlabel(label)
        axh.set_ylabel("density")
        if truths and names[j] in truths:
            ax.axhline(truths[names[j]] * f, color="k", lw=1, label="truth")
            axh.axvline(truths[names[j]] * f, color="k", lw=1, label="truth")
        if row == 0:
            ax.legend(loc="upper right", fontsize=7)
            axh.legend(loc="upper right", fontsize=7)
        ax.set_xlabel("step")
    fig.suptitle(f"Markov chains ({chain.shape[1]} walkers, {min(len(w), chain.shape[1])} drawn)")
    return fig


def plot_logp(log_prob: np.ndarray, burn_in: int = 0, fig: Figure | None = None) -> Figure:
    """Log-posterior trace of every walker, with the burn-in marked.

    Parameters
    ----------
    log_prob : (n_steps, n_chains) or (n_steps,) log-posterior of the stored states.
    burn_in : steps discarded (dashed line).
    """
    lp = np.asarray(log_prob, float)
    lp = lp[:, None] if lp.ndim == 1 else lp
    fig = new_figure(fig, (9, 3.6))
    ax = fig.subplots()
    steps = np.arange(lp.shape[0])
    w = _walkers(lp.shape[1])
    finite = np.where(np.isfinite(lp), lp, np.nan)
    ax.plot(steps, finite[:, w], lw=0.5, alpha=0.4, color="0.4")
    ax.plot(steps, np.nanmean(finite, axis=1), color="C0", lw=1.2, label="walker mean")
    ax.axvline(burn_in, color="C3", ls="--", label=f"burn-in ({burn_in} steps)")
    kept = finite[burn_in:]
    if kept.size and np.isfinite(kept).any():
        lo, hi = np.nanpercentile(kept, [0.5, 100])
        span = max(hi - lo, 1e-9)
        start = np.nanpercentile(finite[: max(burn_in, 1)], 5)
        ax.set_ylim(min(lo - 0.3 * span, start if np.isfinite(start) else lo), hi + 0.1 * span)
    ax.set_xlabel("step")
    ax.set_ylabel("log posterior (nats)")
    ax.set_title("Log-posterior trace")
    ax.legend(loc="lower right")
    return fig


def plot_acceptance(
    accepted: np.ndarray, burn_in: int = 0, window: int | None = None, fig: Figure | None = None
) -> Figure:
    """Acceptance fraction over steps (trailing window, all walkers pooled).

    Parameters
    ----------
    accepted : (n_steps, n_chains) booleans.
    burn_in : steps discarded (dashed line).
    window : trailing window in steps (default ``max(10, n_steps // 50)``).
    """
    acc = np.asarray(accepted, float)
    acc = acc[:, None] if acc.ndim == 1 else acc
    n = acc.shape[0]
    window = window or max(10, n // 50)
    rate = dg.acceptance_over_time(acc, min(window, n))
    fig = new_figure(fig, (9, 3.2))
    ax = fig.subplots()
    ax.plot(np.arange(n), rate, color="C0", label=f"trailing {window}-step window")
    overall = float(acc[burn_in:].mean()) if n > burn_in else float("nan")
    ax.axhline(overall, color="C2", ls=":", label=f"after burn-in: {overall:.2f}")
    ax.axvline(burn_in, color="C3", ls="--", label="burn-in")
    ax.set_ylim(0, 1)
    ax.set_xlabel("step")
    ax.set_ylabel("acceptance fraction")
    ax.set_title("Acceptance over steps")
    ax.legend(loc="upper right", fontsize=8)
    return fig


def plot_autocovariance(
    chain: np.ndarray, max_lag: int | None = None, tau: float | None = None, fig: Figure | None = None,
    thin: int = 1,
) -> Figure:
    """Norm of the posterior's autocovariance (standardised parameters) against lag.

    Parameters
    ----------
    chain : (n_steps, n_chains, n_params) kept (post burn-in) chain.
    max_lag : largest lag (default ``n_steps // 3``).
    tau : an integrated autocorrelation time to mark (e.g. the largest over parameters), steps.
    thin : the chain was thinned by this factor; lags are drawn in original steps.
    """
    chain = np.asarray(chain, float)
    n = chain.shape[0]
    max_lag = min(max_lag or max(1, n // 3), n - 1)
    g = dg.autocovariance_norm(chain, max_lag)
    fig = new_figure(fig, (7, 3.6))
    ax = fig.subplots()
    ax.plot(np.arange(max_lag + 1) * thin, g, color="C0", label="‖Γ(k)‖ / ‖Γ(0)‖ (Frobenius)")
    ax.axhline(0, color="0.5", lw=0.8)
    if tau is not None and np.isfinite(tau):
        ax.axvline(tau, color="C3", ls="--", label=f"max IACT = {tau:.1f} steps")
    ax.set_xlabel("lag (steps)")
    ax.set_ylabel("normalised autocovariance norm")
    ax.set_title("Autocovariance norm of the kept chain")
    ax.legend(loc="upper right")
    return fig


def plot_geweke(
    chain: np.ndarray,
    names: list[str],
    subset: list[str] | None = None,
    n_starts: int = 10,
    fig: Figure | None = None,
) -> Figure:
    """Geweke diagnostics of the kept chain.

    Left: the z-score of the first 10 % against the last 50 % after discarding successively
    more of the start (0 to 45 %; like R coda's ``geweke.plot``), ±1.96 band. Right: the paper's
    relative difference of means ``|mean_first - mean_last| / |mean_last|`` per parameter.
    """
    chain = np.asarray(chain, float)
    idx = select(names, subset)
    n = chain.shape[0]
    fracs = np.linspace(0, 0.45, n_starts)
    zs = np.full((n_starts, len(idx)), np.nan)
    for i, f in enumerate(fracs):
        start = int(f * n)
        try:
            zs[i] = dg.geweke(chain[start:, :, idx]).z
        except ValueError:
            break
    g = dg.geweke(chain[:, :, idx])
    fig = new_figure(fig, (11, 3.8))
    ax, axr = fig.subplots(1, 2, width_ratios=[3, 2])
    for k, j in enumerate(idx):
        ax.plot(100 * fracs, zs[:, k], marker="o", ms=3, lw=1, label=names[j])
    ax.axhspan(-1.96, 1.96, color="C2", alpha=0.15, label="|z| < 1.96")
    ax.set_xlabel("start of the kept chain discarded (%)")
    ax.set_ylabel("Geweke z (first 10 % vs last 50 %)")
    ax.set_title("Geweke z-scores")
    ax.legend(fontsize=7, ncol=2, loc="upper right")
    labels = [names[j] for j in idx]
    colours = ["C2" if p else "C3" for p in g.passed]
    axr.barh(np.arange(len(idx)), 100 * g.rel_diff, color=colours)
    axr.set_yticks(np.arange(len(idx)), labels)
    axr.invert_yaxis()
    axr.set_xlabel("relative difference of means (%)")
    axr.set_title("Paper's Geweke relative difference")
    from matplotlib.patches import Patch

    axr.legend(handles=[Patch(color="C2", label="|z| < 1.96"), Patch(color="C3", label="|z| ≥ 1.96")],
               fontsize=7, loc="lower right")
    return fig


def plot_segments(
    chain: np.ndarray,
    names: list[str],
    subset: list[str] | None = None,
    n_segments: int = 5,
    fig: Figure | None = None,
) -> Figure:
    """Box plots of consecutive segments of the kept chain, early to late, per parameter.

    The boxes span the 25-75 % quantiles with whiskers at 2.5 and 97.5 %; a converged chain has
    boxes at the same level.
    """
    chain = np.asarray(chain, float)
    idx = select(names, subset)
    seg = dg.segment_summary(chain[:, :, idx], n_segments)
    k = len(idx)
    ncol = k if k <= 5 else 4
    nrow = int(np.ceil(k / ncol))
    fig = new_figure(fig, (3.0 * ncol + 1, 2.6 * nrow + 0.5))
    axes = np.atleast_1d(fig.subplots(nrow, ncol, squeeze=False)).ravel()
    for a, j in enumerate(idx):
        f, label = display(names[j])
        ax = axes[a]
        stats = []
        for s in range(n_segments):
            q = seg.quantiles[s, :, a] * f
            stats.append({"whislo": q[0], "q1": q[1], "med": q[2], "q3": q[3], "whishi": q[4],
                          "label": f"{s + 1}", "fliers": []})
        ax.bxp(stats, showfliers=False)
        ax.plot(np.arange(1, n_segments + 1), seg.mean[:, a] * f, "o", color="C3", ms=3,
                label="segment mean")
        ax.set_xlabel("segment (early → late)")
        ax.set_ylabel(label)
        if a == 0:
            ax.legend(fontsize=7)
    for ax in axes[k:]:
        ax.set_visible(False)
    fig.suptitle(f"Kept chain cut into {n_segments} segments (box 25-75 %, whiskers 2.5-97.5 %)")
    return fig
