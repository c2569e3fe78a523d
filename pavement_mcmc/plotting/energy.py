"""The surface energy balance a fit implies: net radiation, sensible, latent and ground heat."""

from __future__ import annotations

import textwrap

import numpy as np
from matplotlib.figure import Figure

from ..data.times import hour_of_day
from ._base import hours, new_figure, time_label

__all__ = ["plot_energy_balance"]

_FLUXES = (("H", "sensible heat H", "C3"), ("LE", "latent heat LE", "C0"),
           ("G", "ground heat G", "C5"), ("off", "other surface terms (a shadow, ...)", "0.55"))


def _band(ax, x, draws, colour, label, level):
    lo, med, hi = np.percentile(draws, [50 - level / 2, 50, 50 + level / 2], axis=0)
    if draws.shape[0] > 1:
        ax.fill_between(x, lo, hi, color=colour, alpha=0.25, lw=0)
    ax.plot(x, med, color=colour, lw=1.5, label=label)


def _diurnal(hod: np.ndarray, values: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Mean over the days of each clock-hour bin of width ``step`` h: (bin centres, (n_sets,
    n_bins))."""
    edges = np.arange(0.0, 24.0 + 1e-9, step)
    k = np.clip(np.digitize(hod, edges) - 1, 0, edges.size - 2)
    out = np.full((values.shape[0], edges.size - 1), np.nan)
    for j in range(edges.size - 1):
        if np.any(k == j):
            out[:, j] = values[:, k == j].mean(axis=1)
    return 0.5 * (edges[1:] + edges[:-1]), out


def _diurnal_nan(hod: np.ndarray, values: np.ndarray, step: float) -> np.ndarray:
    """:func:`_diurnal` of one series with gaps (NaN): the mean of each bin's known values."""
    known = np.isfinite(values)
    return _diurnal(hod[known], values[known][None, :], step)[1][0]


def plot_energy_balance(
    t_obs: np.ndarray,
    Rn: np.ndarray,
    H: np.ndarray,
    LE: np.ndarray,
    G: np.ndarray,
    time0: str | None = None,
    summary: str = "",
    level: float = 95.0,
    fig: Figure | None = None,
    off: np.ndarray | None = None,
    measured: dict | None = None,
) -> Figure:
    """H, LE and G through the window and through the mean day, beside the net radiation.

    Parameters
    ----------
    t_obs : (n_obs,) observation times, s from the window start.
    Rn : (n_obs,) measured net radiation, W m-2, positive downward.
    H, LE, G : (n_draws, n_obs) sensible and latent heat leaving the surface and heat flux into
        the ground, W m-2, for posterior (or Laplace) draws
        (:func:`~pavement_mcmc.physics.catalogue.energy.energy_partition`).
    time0 : ISO 8601 UTC time of ``t = 0``: the right panel then averages by UTC clock hour.
    summary : a line printed above the panels (e.g. the midday Bowen ratio and G/Rn), wrapped.
    level : credible level of the bands, %.
    off : (n_draws, n_obs) the net radiation other surface terms keep off the spot (a
        ``shading`` shadow), drawn when given: then Rn = H + LE + G + off.
    measured : a flux tower's ``{"H": (n_obs,), "LE": (n_obs,)}`` (W m-2, NaN where missing),
        drawn as dots in each flux's colour.
    """
    t = hours(t_obs)
    draws = {k: np.atleast_2d(np.asarray(v, float)) for k, v in (("H", H), ("LE", LE), ("G", G))}
    if off is not None:
        draws["off"] = np.atleast_2d(np.asarray(off, float))
    fluxes = [f for f in _FLUXES if f[0] in draws]
    fig = new_figure(fig, (12, 4.6))
    ax, ax2 = fig.subplots(1, 2, width_ratios=[2.2, 1])
    ax.plot(t, Rn, color="k", lw=1.2, label="net radiation Rn (measured)")
    for key, label, colour in fluxes:
        _band(ax, t, draws[key], colour, label, level)
    tower = {k: np.asarray(v, float) for k, v in (measured or {}).items()}
    for key, _label, colour in fluxes:
        if key in tower:
            ax.plot(t, tower[key], ".", color=colour, ms=3, label=f"{key} measured (flux tower)")
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_xlabel(time_label(time0))
    ax.set_ylabel("flux (W m⁻²): Rn = H + LE + G" + (" + off" if "off" in draws else ""))
    ax.set_title(f"Through the window ({level:g} % bands)")
    top = 1.5 * float(np.nanmax(Rn)) if np.nanmax(Rn) > 0 else None  # room for the legends
    ax.set_ylim(top=top)
    ax.legend(fontsize=8, loc="upper left", ncol=2)
    hod = hour_of_day(time0, t_obs) if time0 else np.mod(t, 24.0)
    step = max(float(np.median(np.diff(t))), 0.5)
    x, rn = _diurnal(hod, np.asarray(Rn, float)[None, :], step)
    ax2.plot(x, rn[0], color="k", lw=1.2, label="Rn")
    for key, _label, colour in fluxes:
        _band(ax2, x, _diurnal(hod, draws[key], step)[1], colour, key, level)
        if key in tower:
            with np.errstate(invalid="ignore"):
                ax2.plot(x, _diurnal_nan(hod, tower[key], step), "o", color=colour, ms=3)
    ax2.axhline(0, color="0.5", lw=0.8)
    ax2.set_xlim(0, 24)
    ax2.set_xticks(range(0, 25, 6))
    ax2.set_xlabel("hour of the day (UTC)" if time0 else "hour of the day")
    ax2.set_title("Mean day")
    ax2.set_ylim(top=top)
    ax2.legend(fontsize=8, loc="upper left", ncol=3)
    wrapped = "\n".join(textwrap.wrap(summary, 150)) if summary else ""
    fig.suptitle("Surface energy balance implied by the fit" + (f"\n{wrapped}" if wrapped else ""),
                 fontsize=9)
    return fig
