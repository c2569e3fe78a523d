"""Does an estimate drift across a batch's windows by more than its intervals?"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Drift:
    """The windows' estimates of one quantity against time (windows that did not fail).

    Attributes
    ----------
    column : the batch-table column.
    n : windows used. t_days : their middles, days from the first window's start.
    first, last, lo, hi : first and last window's estimate, smallest and largest estimate.
    slope, slope_se : weighted least-squares trend per day and its standard error (weights
        1/sd², sd = the 95 % interval's width / 3.92).
    chi2_dof : scatter about the weighted mean in units of the intervals (≈ 1 when the windows
        agree within their intervals; ≫ 1 when the quantity changes by more than they allow).
    half_width : median half-width of the 95 % intervals.
    """

    column: str
    n: int
    t_days: np.ndarray
    first: float
    last: float
    lo: float
    hi: float
    slope: float
    slope_se: float
    chi2_dof: float
    half_width: float

    def text(self, scale: float = 1.0, unit: str = "") -> str:
        s = scale
        return (f"{self.column}: {self.n} windows, {self.first * s:.3g} -> {self.last * s:.3g} {unit} "
                f"(range {self.lo * s:.3g}-{self.hi * s:.3g}); trend {self.slope * s:+.3g} "
                f"± {self.slope_se * s:.2g} {unit}/day; scatter chi2/dof {self.chi2_dof:.1f} "
                f"about the mean; median 95 % half-width {self.half_width * s:.2g} {unit}")


def drift(rows: list[dict], column: str = "diffusivity") -> Drift:
    """Trend and scatter of ``column`` over the windows of a batch table (failed units and
    units without the column left out)."""
    use = [r for r in rows if r["status"] != "failed" and not math.isnan(r[column])
           and not math.isnan(r["start_h"])]
    if len(use) < 3:
        raise ValueError(f"drift of {column}: needs at least 3 windows with estimates, got {len(use)}")
    use.sort(key=lambda r: r["start_h"])
    t = np.array([(r["start_h"] + r["end_h"]) / 2 for r in use]) / 24.0
    t = t - use[0]["start_h"] / 24.0
    y = np.array([r[column] for r in use])
    sd = np.array([(r[f"{column}_hi"] - r[f"{column}_lo"]) / 3.92 for r in use])
    w = 1.0 / np.maximum(sd, 1e-300) ** 2
    mean = float(np.sum(w * y) / np.sum(w))
    chi2 = float(np.sum(w * (y - mean) ** 2)) / (len(y) - 1)
    X = np.stack([np.ones_like(t), t], axis=1)
    cov = np.linalg.inv(X.T @ (w[:, None] * X))
    beta = cov @ (X.T @ (w * y))
    return Drift(column, len(y), t, float(y[0]), float(y[-1]), float(y.min()), float(y.max()),
                 float(beta[1]), float(math.sqrt(cov[1, 1])), chi2, float(np.median(sd * 1.96)))
