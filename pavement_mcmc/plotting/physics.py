"""Physical quantities over time: h(t) against the wind, the surface fluxes, sensitivity
coefficients and identifiability, and the urban-scale comparison."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ._base import default_selection, display, hours, new_figure, time_label

__all__ = ["plot_fluxes", "plot_h", "plot_identifiability", "plot_sensitivity", "plot_urban"]


def _steps(edges_h: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Piecewise-constant values on ``edges`` as a drawable step line."""
    x = np.repeat(edges_h, 2)[1:-1]
    y = np.repeat(values, 2)
    return x, y


def plot_h(
    t_obs: np.ndarray,
    h_draws: np.ndarray,
    wind: np.ndarray | None = None,
    truth: np.ndarray | None = None,
    level: float = 95.0,
    fig: Figure | None = None,
) -> Figure:
    """The surface heat transfer coefficient h(t) with its credible band, and the wind.

    Parameters
    ----------
    t_obs : (n_obs,) observation times, s.
    h_draws : (n_draws, n_obs - 1) h on each observation interval for posterior draws,
        W m-2 K-1 (``HBasis.evaluate`` of the draws).
    wind : optional (n_obs,) measured wind speed, m s-1 (right axis).
    truth : optional true h at the observation times (n_obs,) or intervals (n_obs - 1,).
    level : credible level of the band, %.
    """
    t = hours(t_obs)
    h = np.atleast_2d(np.asarray(h_draws, float))
    lo, med, hi = np.percentile(h, [50 - level / 2, 50, 50 + level / 2], axis=0)
    mean = h.mean(axis=0)
    fig = new_figure(fig, (9, 4))
    ax = fig.subplots()
    xs, ylo = _steps(t, lo)
    _, yhi = _steps(t, hi)
    ax.fill_between(xs, ylo, yhi, color="C0", alpha=0.3, lw=0, label=f"{level:g} % credible band")
    ax.plot(*_steps(t, mean), color="C0", lw=1.6, label="posterior mean")
    if truth is not None:
        tr = np.asarray(truth, float)
        tt = t if tr.size == t.size else 0.5 * (t[1:] + t[:-1])
        ax.plot(tt, tr, color="k", lw=1.2, ls="--", label="truth")
    ax.set_xlabel(time_label())
    ax.set_ylabel("h (W m⁻² K⁻¹)")
    ax.set_ylim(bottom=0)
    handles, labels = ax.get_legend_handles_labels()
    if wind is not None:
        ax2 = ax.twinx()
        ax2.plot(t, wind, color="C2", lw=1, alpha=0.8, label="measured wind")
        ax2.set_ylabel("wind speed (m s⁻¹)", color="C2")
        ax2.set_ylim(bottom=0)
        h2, l2 = ax2.get_legend_handles_labels()
        handles, labels = handles + h2, labels + l2
    ax.legend(handles, labels, loc="upper right", fontsize=8)
    ax.set_title("Surface heat transfer coefficient h(t)")
    return fig


def plot_fluxes(
    t_obs: np.ndarray,
    convective: np.ndarray,
    q_net: np.ndarray,
    dT: np.ndarray,
    level: float = 95.0,
    fig: Figure | None = None,
) -> Figure:
    """Surface fluxes into the ground: convective ``h (T_air - T_s)`` and radiative ``q_net``,
    and the driving difference ``T_air - T_s``.

    Parameters
    ----------
    t_obs : (n_obs,) s.
    convective : (n_draws, n_obs) or (n_obs,) convective flux into the ground, W m-2 (``h`` of an
        interval applied at its end; row 0 uses the first interval).
    q_net : (n_obs,) net radiation into the ground, W m-2.
    dT : (n_draws, n_obs) or (n_obs,) ``T_air - T_s``, degC.
    level : credible level of the bands, %.
    """
    t = hours(t_obs)
    conv = np.atleast_2d(np.asarray(convective, float))
    d = np.atleast_2d(np.asarray(dT, float))
    fig = new_figure(fig, (9, 5.6))
    ax, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=[3, 2])
    q = [50 - level / 2, 50 + level / 2]
    if conv.shape[0] > 1:
        lo, hi = np.percentile(conv, q, axis=0)
        ax.fill_between(t, lo, hi, color="C1", alpha=0.3, lw=0, label=f"{level:g} % band")
    ax.plot(t, conv.mean(axis=0), color="C1", label="convective h (T_air − T_s)")
    ax.plot(t, q_net, color="C0", label="radiative q_net (measured)")
    ax.plot(t, conv.mean(axis=0) + q_net, color="k", lw=0.8, ls=":", label="total into the ground")
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_ylabel("flux into the ground (W m⁻²)")
    ax.legend(fontsize=8, loc="upper left")
    ax.set_title("Surface heat fluxes")
    if d.shape[0] > 1:
        lo, hi = np.percentile(d, q, axis=0)
        ax2.fill_between(t, lo, hi, color="C4", alpha=0.3, lw=0, label=f"{level:g} % band")
    ax2.plot(t, d.mean(axis=0), color="C4", label="T_air − T_s (modelled surface)")
    ax2.axhline(0, color="0.5", lw=0.8)
    ax2.set_ylabel("T_air − T_s (°C)")
    ax2.set_xlabel(time_label())
    ax2.legend(fontsize=8, loc="lower left")
    return fig


def plot_sensitivity(
    sens, subset: list[str] | None = None, sigma: float | None = None, fig: Figure | None = None
) -> Figure:
    """Reduced sensitivity coefficients ``p_j dT/dp_j`` over time, one panel per sensor.

    Parameters
    ----------
    sens : :class:`~pavement_mcmc.analysis.sensitivity.Sensitivity`.
    subset : parameter names to draw (default: non-h parameters and four h pieces).
    sigma : optional noise sd, degC, drawn as a ``± sigma`` band for scale.
    """
    names = list(sens.names)
    subset = default_selection(names) if subset is None else subset
    idx = [names.index(n) for n in subset]
    t = hours(sens.t)
    n_s = len(sens.sensors)
    ncol = min(n_s, 3)
    nrow = int(np.ceil(n_s / ncol))
    fig = new_figure(fig, (4.6 * ncol, 3.3 * nrow + 0.5))
    axes = np.atleast_1d(fig.subplots(nrow, ncol, squeeze=False, sharex=True)).ravel()
    for s in range(n_s):
        ax = axes[s]
        if sigma:
            ax.axhspan(-sigma, sigma, color="0.88", lw=0, label=f"± σ ({sigma:g} °C)")
        for k, j in enumerate(idx):
            ax.plot(t, sens.coefficients[:, s, j], color=f"C{k % 10}", lw=1.2,
                    label=display(names[j])[1].split(" (")[0])
        ax.axhline(0, color="0.5", lw=0.8)
        ax.set_title(f"sensor at {sens.sensors[s]}")
        ax.set_ylabel("p ∂T/∂p (°C)")
        ax.set_xlabel(time_label())
    handles, labels = axes[0].get_legend_handles_labels()
    for ax in axes[n_s:]:
        ax.axis("off")
    if n_s < len(axes):
        axes[n_s].legend(handles, labels, loc="center", title="parameter")
    else:
        axes[0].legend(handles, labels, fontsize=7)
    fig.suptitle(f"Reduced sensitivity coefficients (central differences, Δp = {sens.rel_step:g} p)")
    return fig


def plot_identifiability(ident, max_params: int = 30, fig: Figure | None = None) -> Figure:
    """Correlation matrix of the scaled sensitivity columns (and the relative sds).

    Parameters
    ----------
    ident : :class:`~pavement_mcmc.analysis.sensitivity.Identifiability`.
    max_params : at most this many parameters are shown (non-h first, then evenly spaced h).
    """
    names = list(ident.names)
    subset = names if len(names) <= max_params else default_selection(names, max_params - 4)
    idx = [names.index(n) for n in subset]
    corr = ident.correlation[np.ix_(idx, idx)]
    k = len(idx)
    fig = new_figure(fig, (max(10, 0.45 * k + 7), max(4.2, 0.4 * k + 1.8)))
    ax, axb = fig.subplots(1, 2, width_ratios=[1.3, 1])
    im = ax.imshow(corr, vmin=-1, vmax=1, cmap="RdBu_r")
    ax.set_xticks(range(k), subset, rotation=90, fontsize=8)
    ax.set_yticks(range(k), subset, fontsize=8)
    if k <= 12:
        for i in range(k):
            for j in range(k):
                ax.text(j, i, f"{corr[i, j]:.2f}", ha="center", va="center", fontsize=7,
                        color="w" if abs(corr[i, j]) > 0.7 else "k")
    fig.colorbar(im, ax=ax, label="correlation of scaled sensitivities", shrink=0.8)
    ax.set_title(f"condition number {ident.condition_number:.3g}")
    ax.set_xlabel("parameter")
    ax.set_ylabel("parameter")
    y = np.arange(k)
    alone = 100 * np.asarray(ident.rel_sd_alone)[idx]
    joint = 100 * np.asarray(ident.rel_sd_joint)[idx]
    axb.barh(y - 0.2, joint, height=0.4, color="C3", label="all parameters free")
    axb.barh(y + 0.2, alone, height=0.4, color="C0", label="others known")
    axb.set_yticks(y, subset, fontsize=8)
    axb.invert_yaxis()
    axb.set_xscale("log")
    axb.set_xlabel("relative sd from the data alone (%)")
    axb.legend(fontsize=7, loc="lower right")
    axb.set_title("Precision from the data alone (linearised)")
    return fig


def plot_urban(comparison, fig: Figure | None = None) -> Figure:
    """Urban-scale comparison: surface temperature and emitted long-wave radiation with the
    standard ``h(v) = 4 + 4 v`` against the estimated h(t).

    Parameters
    ----------
    comparison : :class:`~pavement_mcmc.analysis.urban.UrbanComparison`.
    """
    c = comparison
    t = hours(c.t)
    fig = new_figure(fig, (9, 10))
    axh, ax0, ax1, ax2 = fig.subplots(4, 1, sharex=True, height_ratios=[1.5, 2, 1.5, 1.5])
    axh.plot(*_steps(t, c.h_standard), color="C1", label="standard h = 4 + 4 v")
    axh.plot(*_steps(t, c.h_estimated), color="C0", label="estimated h(t) (posterior mean)")
    axh.set_ylabel("h (W m⁻² K⁻¹)")
    axh.set_ylim(bottom=0)
    axh.set_title("Urban-scale comparison: standard vs estimated h")
    axw = axh.twinx()
    axw.plot(t, c.wind, color="C2", lw=0.8, alpha=0.7, label="wind used in 4 + 4 v")
    axw.set_ylabel("wind (m s⁻¹)", color="C2")
    axw.set_ylim(bottom=0)
    h1, l1 = axh.get_legend_handles_labels()
    h2, l2 = axw.get_legend_handles_labels()
    axh.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper left")
    ax0.plot(t, c.Ts_standard, color="C1", label="with standard h = 4 + 4 v")
    ax0.plot(t, c.Ts_estimated, color="C0", label="with estimated h(t)")
    if c.Ts_band is not None:
        ax0.fill_between(t, *c.Ts_band, color="C0", alpha=0.25, lw=0, label="95 % band (draws)")
    ax0.plot(t, c.T_air, color="0.5", lw=0.8, ls=":", label="air")
    ax0.set_ylabel("surface temperature (°C)")
    ax0.legend(fontsize=8, loc="upper left")
    ax1.plot(t, c.dTs, color="C3", label="ΔT_s = T_s(standard) − T_s(estimated)")
    if c.dTs_band is not None:
        ax1.fill_between(t, *c.dTs_band, color="C3", alpha=0.25, lw=0, label="95 % band")
    ax1.axhline(0, color="0.5", lw=0.8)
    ax1.set_ylabel("ΔT_s (°C)")
    ax1.legend(fontsize=8, loc="lower left")
    ax2.plot(t, c.dq_lw, color="C4", label=f"Δ(ε σ T_s⁴), ε = {c.emissivity:g}")
    if c.dq_lw_band is not None:
        ax2.fill_between(t, *c.dq_lw_band, color="C4", alpha=0.25, lw=0, label="95 % band")
    ax2.axhline(0, color="0.5", lw=0.8)
    ax2.set_ylabel("Δ long-wave emission (W m⁻²)")
    ax2.set_xlabel(time_label())
    ax2.legend(fontsize=8, loc="lower left")
    return fig
