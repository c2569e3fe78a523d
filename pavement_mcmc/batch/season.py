"""The season table: a batch's window rows beside a flux the record measured itself.

Daily windows of a measured-top fit say nothing about the surface energy balance; the record's
own surface heat flux (e.g. ``G_surface`` of the SoilVUE ``extras.csv``, a plate reading already
corrected for the storage above it) and net radiation do. :func:`season_rows` adds to each
batch row the measured midday share of the net radiation that enters the ground in its window
(:func:`midday_ratio`), independent of the fit, so that a figure can put the fitted soil
properties and the measured partition side by side (:func:`~pavement_mcmc.plotting.plot_season`).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from ..data import DataError
from ..data.times import seconds_between

#: the column added to each row: measured midday G / Rn in the row's window (dimensionless)
G_RN = "G_Rn_midday"


def midday_ratio(G: np.ndarray, q_net: np.ndarray) -> float:
    """``sum G / sum Rn`` over the midday rows, where ``Rn`` exceeds half its maximum (the rule
    of :meth:`~pavement_mcmc.physics.catalogue.energy.EnergyPartition.midday`).

    ``G`` and ``q_net`` (W m-2, positive into the ground) are the rows of one window. Returns
    nan when ``Rn`` is never positive or a midday row lacks either value (a gap is not filled).
    """
    G, q = np.asarray(G, float), np.asarray(q_net, float)
    if G.shape != q.shape:
        raise ValueError(f"G and q_net differ in shape: {G.shape} against {q.shape}")
    if not np.isfinite(q).any() or np.nanmax(q) <= 0.0:
        return float("nan")
    with np.errstate(invalid="ignore"):
        rows = q > 0.5 * np.nanmax(q)
    if np.isnan(q).any() or not np.isfinite(G[rows]).all():
        return float("nan")
    return float(G[rows].sum() / q[rows].sum())


def read_series(path: str | Path, columns: tuple[str, ...]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Hours from the first row (n,) and the named columns (n,) of a CSV with a ``time``
    column; empty cells are nan. A missing column raises :class:`DataError` naming it."""
    path = Path(path)
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
    if not rows:
        raise DataError(f"{path}: no rows")
    for col in ("time", *columns):
        if col not in rows[0]:
            raise DataError(f"{path}: no column {col!r} (has {', '.join(rows[0])})")
    hours = seconds_between([r["time"] for r in rows]) / 3600.0
    values = {c: np.array([float(r[c]) if r[c].strip() else math.nan for r in rows]) for c in columns}
    return hours, values


def season_rows(rows: list[dict], q_net_csv: str | Path, flux_csv: str | Path,
                flux: str = "G_surface") -> list[dict]:
    """Each batch row (``start_h``, ``end_h``: hours from the record's first row, both ends
    included) with :data:`G_RN`, the measured ``flux`` column of ``flux_csv`` over ``q_net`` of
    ``q_net_csv`` at midday in its window (nan for a row without a window or with a gap at
    midday). The two files must share their times."""
    tq, q = read_series(q_net_csv, ("q_net",))
    tg, g = read_series(flux_csv, (flux,))
    if tq.shape != tg.shape or np.max(np.abs(tq - tg)) > 1e-6:
        raise DataError(f"{flux_csv} and {q_net_csv} do not have the same times")
    out = []
    for r in rows:
        a, b = r.get("start_h", math.nan), r.get("end_h", math.nan)
        ratio = math.nan
        if not (math.isnan(a) or math.isnan(b)):
            inside = (tq >= a - 1e-6) & (tq <= b + 1e-6)
            ratio = midday_ratio(g[flux][inside], q["q_net"][inside])
        out.append({**r, G_RN: ratio})
    return out
