"""The batch figure: kappa, C, kappa/C and the window-mean h against time, with 95 % bands."""

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
    fig = new_figure(fig, (8.0, 9.0))
    axes = fig.subplots(len(PANELS), 1, sharex=True)
    sites = list(dict.fromkeys(r["site"] for r in rows))
    colours = [f"C{i}" for i in range(10)]
    for ax, (col, scale, label) in zip(axes, PANELS):
        drawn = False
        for i, site in enumerate(sites):
            rs = [r for r in rows if r["site"] == site and r["status"] != "failed"
                  and not math.isnan(r[col])]
            if not rs:
                continue
            x = [_when(r) for r in rs]
            y = np.array([r[col] for r in rs]) * scale
            lo = np.array([r[f"{col}_lo"] for r in rs]) * scale
            hi = np.array([r[f"{col}_hi"] for r in rs]) * scale
            c = colours[i % len(colours)]
            ax.fill_between(x, lo, hi, color=c, alpha=0.25, lw=0,
                            label=f"{site}: 95 % interval" if len(sites) < 6 else None)
            ax.plot(x, y, "-", color=c, lw=1.2, label=f"{site}: posterior mean")
            ok = np.array([bool(r["converged"]) for r in rs])
            xs = np.array(x, dtype=object)
            ax.plot(list(xs[ok]), y[ok], "o", color=c, ms=4)
            if (~ok).any():
                ax.plot(list(xs[~ok]), y[~ok], "o", mfc="none", color=c, ms=5,
                        label="not converged" if i == 0 else None)
            drawn = True
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
    fig.suptitle((title or "Batch estimates per window")
                 + (f" ({n_fail} failed, not shown)" if n_fail else ""))
    return fig
