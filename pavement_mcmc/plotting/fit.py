"""Measured versus predicted temperatures at every sensor, with residuals beneath."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ._base import SENSOR_COLOURS, hours, new_figure, time_label

__all__ = ["plot_fit"]


def plot_fit(
    meas,
    predicted: np.ndarray,
    band: tuple[np.ndarray, np.ndarray] | None = None,
    literature: np.ndarray | None = None,
    label: str = "predicted",
    band_label: str = "95 % posterior predictive",
    literature_label: str = "the paper's literature values (κ 2.27, C 2.10 MJ, h 10)",
    ncol: int = 3,
    fig: Figure | None = None,
) -> Figure:
    """One panel per sensor: measured and predicted temperatures, residuals beneath.

    Parameters
    ----------
    meas : :class:`~pavement_mcmc.data.Measurements` (times, sensors, sigma).
    predicted : (n_obs, n_sensors) predicted temperatures, degC (e.g. the posterior predictive
        median, or one parameter set).
    band : optional ``(lower, upper)``, each (n_obs, n_sensors): a posterior predictive band of
        the model temperature, degC.
    literature : optional (n_obs, n_sensors) prediction at the literature values, degC.
    label, band_label, literature_label : legend entries.
    ncol : panels per row.
    fig : figure to draw on (cleared) or None.

    Notes
    -----
    The grey band is ``predicted ± sigma``: where measurements should fall about 68 % of the
    time if the model and ``sigma`` are right. Residuals are predicted minus measured (as in the
    criticism), with the ``± sigma`` band; the first row is the initial condition (zero residual
    by construction).
    """
    t = hours(meas.t)
    obs = np.asarray(meas.T_obs, float)
    pred = np.asarray(predicted, float)
    n_s = obs.shape[1]
    sigma = float(meas.sigma)
    ncol = max(1, min(ncol, n_s))
    nblk = int(np.ceil(n_s / ncol))
    fig = new_figure(fig, (4.6 * ncol, 4.4 * nblk + 0.4))
    gs = fig.add_gridspec(2 * nblk, ncol, height_ratios=[3, 1.4] * nblk)
    handles = None
    for s in range(n_s):
        r, c = divmod(s, ncol)
        ax = fig.add_subplot(gs[2 * r, c])
        axr = fig.add_subplot(gs[2 * r + 1, c], sharex=ax)
        col = SENSOR_COLOURS[s % len(SENSOR_COLOURS)]
        ax.fill_between(t, pred[:, s] - sigma, pred[:, s] + sigma, color="0.8", lw=0,
                        label=f"predicted ± σ ({sigma:g} °C)")
        if band is not None:
            ax.fill_between(t, band[0][:, s], band[1][:, s], color=col, alpha=0.35, lw=0,
                            label=band_label)
        ax.plot(t, obs[:, s], ".", ms=3, color="k", label="measured")
        ax.plot(t, pred[:, s], color=col, lw=1.4, label=label)
        if literature is not None:
            ax.plot(t, literature[:, s], color="0.3", ls="--", lw=1.0, label=literature_label)
        ax.set_title(f"sensor at {meas.depths[s] * 100:g} cm")
        ax.set_ylabel("temperature (°C)")
        ax.tick_params(labelbottom=False)
        res = pred[:, s] - obs[:, s]
        axr.axhspan(-sigma, sigma, color="0.85", lw=0, label="± σ")
        axr.axhline(0, color="0.5", lw=0.8)
        axr.plot(t, res, ".", ms=3, color=col, label=f"RMSE {_rmse(res):.3f} °C")
        if literature is not None:
            lres = literature[:, s] - obs[:, s]
            axr.plot(t, lres, color="0.3", ls="--", lw=0.8,
                     label=f"literature, RMSE {_rmse(lres):.3f} °C")
        axr.set_xlabel(time_label())
        axr.set_ylabel("pred − meas (°C)")
        axr.legend(fontsize=6.5, loc="upper right", framealpha=0.6)
        if handles is None:
            handles = ax.get_legend_handles_labels()
    if n_s < nblk * ncol:  # a free slot: put the legend there
        r, c = divmod(n_s, ncol)
        lax = fig.add_subplot(gs[2 * r : 2 * r + 2, c])
        lax.axis("off")
        lax.legend(*handles, loc="center", fontsize=9, title=f"{meas.n_sensors} sensors")
    else:
        fig.axes[0].legend(*handles, fontsize=7, loc="upper left")
    return fig


def plot_streams(
    t_obs: np.ndarray,
    panels: list[tuple[str, str, np.ndarray, np.ndarray]],
    level: float = 95.0,
    fig: Figure | None = None,
) -> Figure:
    """Observations other than the buried sensors (heat-flux plates, an infrared surface
    temperature): measured against the posterior predictive, one column per quantity,
    residuals (predicted minus measured, as in :func:`plot_fit`) beneath.

    Parameters
    ----------
    t_obs : (n_obs,) observation times, s.
    panels : ``(title, unit, observed, predicted)`` per quantity: ``observed`` (n_obs - 1,) after
        the initial row, ``predicted`` (n_draws, n_obs) posterior draws of the model's value.
    level : credible level of the band, %.
    """
    t = hours(t_obs)
    n = len(panels)
    fig = new_figure(fig, (4.8 * n, 5.0))
    gs = fig.add_gridspec(2, n, height_ratios=[3, 1.4])
    q = [50 - level / 2, 50, 50 + level / 2]
    for j, (title, unit, obs, pred) in enumerate(panels):
        col = f"C{j + 1}"
        lo, med, hi = np.percentile(np.atleast_2d(pred), q, axis=0)
        ax = fig.add_subplot(gs[0, j])
        axr = fig.add_subplot(gs[1, j], sharex=ax)
        ax.fill_between(t, lo, hi, color=col, alpha=0.35, lw=0,
                        label=f"{level:g} % posterior predictive")
        ax.plot(t[1:], obs, ".", ms=3, color="k", label="measured")
        ax.plot(t, med, color=col, lw=1.4, label="posterior predictive median")
        ax.set_title(title)
        ax.set_ylabel(f"{title} ({unit})")
        ax.tick_params(labelbottom=False)
        ax.legend(fontsize=7, loc="upper left", framealpha=0.6)
        res = med[1:] - obs
        axr.axhline(0, color="0.5", lw=0.8)
        axr.plot(t[1:], res, ".", ms=3, color=col,
                 label=f"RMSE {float(np.sqrt(np.mean(res * res))):.3g} {unit}")
        axr.set_xlabel(time_label())
        axr.set_ylabel(f"pred − meas ({unit})")
        axr.legend(fontsize=6.5, loc="upper right", framealpha=0.6)
    return fig


def _rmse(r: np.ndarray) -> float:
    r = np.asarray(r)[1:]
    return float(np.sqrt(np.mean(r * r))) if r.size else float("nan")
