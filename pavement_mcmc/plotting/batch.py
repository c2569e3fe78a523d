"""The batch figures: kappa, C, kappa/C and the window-mean h (or, for a season, the measured
midday G/Rn) against time, with 95 % bands."""

from __future__ import annotations

import math
from datetime import UTC, datetime

import numpy as np
from matplotlib.figure import Figure

from ._base import new_figure

#: (column, scale, axis label) of the four panels
PANELS = (("kappa", 1.0, "κ (W m⁻¹ K⁻¹)"), ("C", 1e-6, "C (MJ m⁻³ K⁻¹)"),
          ("diffusivity", 1e6, "κ/C (mm² s⁻¹)"), ("h_mean", 1.0, "mean h (W m⁻² K⁻¹)"))


def _when(row: dict):
    """The window's middle: a datetime if the row has a start time, else the start in hours."""
    span = (row["end_h"] - row["start_h"]) / 2 if not math.isnan(row["end_h"]) else 0.0
    if row.get("start_time"):
        t0 = datetime.strptime(row["start_time"], "%Y-%m-%dT%H:%M:%SZ").replace(tzinfo=UTC)
        return datetime.fromtimestamp(t0.timestamp() + span * 3600.0, tz=UTC)
    return row["start_h"] + span if not math.isnan(row["start_h"]) else 0.0


def plot_batch(rows: list[dict], fig: Figure | None = None, title: str | None = None) -> Figure:
    """Four panels against time (the windows' middles), one line and 95 % band per site.

    ``rows``: the batch table (:func:`pavement_mcmc.batch.read_table`). Failed units are left
    out; units that did not converge are drawn with hollow markers. A panel whose column is
    empty for every unit (no h with a measured top) says so.
    """
    fig, _ = _panels(rows, PANELS, fig, title or "Batch estimates per window")
    return fig


def plot_season(rows: list[dict], fig: Figure | None = None, title: str | None = None,
                flux_label: str = "measured surface flux", note: str | None = None) -> Figure:
    """κ, C and κ/C of daily windows through a season, with the measured midday G/Rn below.

    ``rows``: the batch table with the column ``G_Rn_midday``
    (:func:`pavement_mcmc.batch.season_rows`: the record's own flux, not the fit's).
    ``flux_label`` names that flux in the last panel's legend; ``note`` is written in the
    first panel (e.g. that kappa and C rest on their priors). Failed units are left out of the
    fitted panels and break their lines (the count is in the title); hollow markers: not
    converged.
    """
    fig, ax = _panels(rows, PANELS[:3], fig, title or "A season of daily windows", (8.0, 9.5),
                      extra="midday G/Rn (–)")
    if note:
        fig.axes[0].set_title(note, fontsize=8, loc="left", color="0.3")
    y = np.array([r.get("G_Rn_midday", math.nan) for r in rows], float)  # nan: a break
    ax.plot([_when(r) for r in rows], y, ".-", color="0.25", lw=0.8, ms=4,
            label=f"{flux_label} / net radiation, midday (Rn > half its daily maximum)")
    if np.isfinite(y).any():
        med = float(np.nanmedian(y))
        ax.axhline(med, color="C3", lw=0.8, ls="--", label=f"median over the season {med:.2f}")
        ax.set_ylim(top=float(np.nanmax(y)) + 0.45 * float(np.nanmax(y) - np.nanmin(y)))
        ax.legend(fontsize=8, loc="upper right")  # above the data: the headroom just made
    else:
        ax.text(0.5, 0.5, "no measured flux in these windows", transform=ax.transAxes,
                ha="center", va="center", color="0.4")
    return fig


def _panels(rows: list[dict], panels, fig: Figure | None, title: str,
            size: tuple[float, float] = (8.0, 9.0), extra: str | None = None):
    """The fitted ``panels`` (column, scale, label) one above the other; with ``extra`` (its
    y label) one more axis below, left for the caller. Returns the figure and the last axis."""
    fig = new_figure(fig, size)
    axes = fig.subplots(len(panels) + (extra is not None), 1, sharex=True)
    if extra is not None:
        axes[-1].set_ylabel(extra)
        axes[-1].grid(alpha=0.3)
    sites = list(dict.fromkeys(r["site"] for r in rows))
    for ax, (col, scale, label) in zip(axes, panels):
        drawn = any([_draw_site(ax, rows, site, col, scale, f"C{i % 10}", i == 0, len(sites))
                     for i, site in enumerate(sites)])
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        if not drawn:
            ax.text(0.5, 0.5, "not estimated in these fits", transform=ax.transAxes,
                    ha="center", va="center", color="0.4")
    axes[0].legend(fontsize=8, loc="best")
    with_dates = any(r.get("start_time") for r in rows)
    axes[-1].set_xlabel("window middle (UTC)" if with_dates else "window middle (h)")
    if with_dates:
        for lab in axes[-1].get_xticklabels():
            lab.set_rotation(30)
            lab.set_ha("right")
    n_fail = sum(r["status"] == "failed" for r in rows)
    fig.suptitle(title + (f" ({n_fail} failed, not shown)" if n_fail else ""))
    return fig, axes[-1]


def _draw_site(ax, rows: list[dict], site: str, col: str, scale: float, c: str, first: bool,
               n_sites: int) -> bool:
    """One site's estimates of ``col`` with their 95 % band, the line broken where a unit failed
    (a gap in a record is not bridged); False if it has none."""
    rs = [r for r in rows if r["site"] == site]
    ok = np.array([r["status"] != "failed" and not math.isnan(r.get(col, math.nan)) for r in rs])
    if not ok.any():
        return False
    x = np.array([_when(r) for r in rs], dtype=object)

    def col_of(name):
        return np.array([r[name] if k else math.nan for r, k in zip(rs, ok)], float) * scale

    y, lo, hi = col_of(col), col_of(f"{col}_lo"), col_of(f"{col}_hi")
    ax.fill_between(list(x), lo, hi, color=c, alpha=0.25, lw=0,
                    label=f"{site}: 95 % interval" if n_sites < 6 else None)
    ax.plot(list(x), y, "-", color=c, lw=1.2, label=f"{site}: posterior mean")
    conv = ok & np.array([bool(r["converged"]) for r in rs])
    ax.plot(list(x[conv]), y[conv], "o", color=c, ms=4 if len(rs) < 60 else 2)
    if (ok & ~conv).any():
        ax.plot(list(x[ok & ~conv]), y[ok & ~conv], "o", mfc="none", color=c, ms=5,
                label="not converged" if first else None)
    return True
