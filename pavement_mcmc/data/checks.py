"""Row-level checks of a case table: the table and its error, times, window, cells, ranges.

Used by :mod:`pavement_mcmc.data` (which re-exports every name here): :class:`DataError` and the
parsed table, parsing the time column (strictly increasing, ISO 8601), selecting the time window,
warning on large time gaps, parsing numeric cells with linear gap filling, and the plausibility
checks of temperatures (kelvin, range) and other columns. Every problem raises
:class:`DataError` naming the file, the column and the row.
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .errors import UserError
from .times import parse_time

#: Cell contents read as "missing" (case-insensitive, after stripping blanks).
MISSING_TOKENS = frozenset({"", "nan", "na", "n/a", "null", "none", "-"})
#: Temperatures outside this range (degC) are rejected as physically implausible.
T_RANGE = (-60.0, 90.0)
#: A column whose median exceeds this (degC) is taken to be in kelvin.
KELVIN_MEDIAN = 150.0
#: a heat-flux plate's column name, ``G_<depth>cm``; |G| above G_MAX (W m-2) is rejected as
#: physically implausible for a ground heat flux
PLATE_RE = re.compile(r"^G_(\d+(?:\.\d*)?|\.\d+)cm$")
G_MAX = 1000.0
#: |q_net| above this (W m-2) is rejected as physically implausible.
Q_MAX = 2000.0
#: A time step longer than this multiple of the median step triggers a warning.
GAP_WARN_FACTOR = 4.0

_TOL = 1e-9


class DataError(UserError, ValueError):
    """Invalid case data; the message names the file, the column and the row."""


@dataclass(frozen=True)
class _Table:
    path: str
    header: list[str]
    rows: list[list[str]]
    lines: list[int]  # line in the file where each data row ends

    def where(self, i: int) -> str:
        """Human-readable position of data row index ``i`` (0-based)."""
        return f"data row {i + 1} (line {self.lines[i]})"

    def error(self, problem: str, column: str | None = None, row: int | None = None) -> DataError:
        parts = [self.path]
        if column is not None:
            parts.append(f"column {column!r}")
        if row is not None:
            parts.append(self.where(row))
        return DataError(", ".join(parts) + ": " + problem)


def _parse_times(table: _Table, col: int) -> np.ndarray:
    """Seconds since the Unix epoch (UTC) of every row; strictly increasing."""
    name = table.header[col]
    out = np.empty(len(table.rows))
    for i, row in enumerate(table.rows):
        text = row[col]
        try:
            stamp = parse_time(text)
        except ValueError:
            raise table.error(
                f"cannot parse time {text!r} (expected ISO 8601, e.g. 2004-06-06T00:15:00Z)",
                name,
                i,
            ) from None
        out[i] = stamp.timestamp()
        if i and out[i] <= out[i - 1]:
            kind = "repeats" if out[i] == out[i - 1] else "goes back before"
            raise table.error(
                f"time {text!r} {kind} the previous row's {table.rows[i - 1][col]!r} "
                "(times must be strictly increasing)",
                name,
                i,
            )
    return out


def _window(
    table: _Table, hours: np.ndarray, window: Sequence[float | None] | None, time_col: str
) -> np.ndarray:
    """Indices of the rows inside the window (at least 3)."""
    path, span = f"{table.path}, column {time_col!r}", float(hours[-1])
    if window is None:
        start, end = 0.0, span
    else:
        try:
            start, end = window
            start = 0.0 if start is None else float(start)
            end = span if end is None else float(end)
        except (TypeError, ValueError):
            raise DataError(f"{path}: window_hours must be (start, end) in hours, got {window!r}") from None
        if not (math.isfinite(start) and math.isfinite(end)) or start >= end:
            raise DataError(f"{path}: window_hours must have start < end, got {window!r}")
        if start < -_TOL or end > span + 1e-6:
            raise DataError(
                f"{path}: window_hours ({start:g}, {end:g}) h lies outside the data, which covers "
                f"0 to {span:g} h after the first row, {table.where(0)}"
            )
    idx = np.flatnonzero((hours >= start - 1e-6) & (hours <= end + 1e-6))
    if idx.size < 3:
        raise DataError(
            f"{path}: window_hours ({start:g}, {end:g}) h holds {idx.size} rows; at least 3 needed"
        )
    return idx


def _warn_time_gaps(table: _Table, t: np.ndarray, idx: np.ndarray) -> None:
    steps = np.diff(t)
    med = float(np.median(steps))
    for j in np.flatnonzero(steps > GAP_WARN_FACTOR * med):
        warnings.warn(
            f"{table.path}: large time gap of {steps[j] / 3600:.3g} h (median step "
            f"{med / 60:.3g} min) between {table.where(idx[j])} and {table.where(idx[j + 1])}",
            stacklevel=3,
        )


def _numeric_column(
    table: _Table,
    col: int,
    idx: np.ndarray,
    t: np.ndarray,
    max_gap_fill: int,
    fills: list[tuple[str, int, int]],
    keep_gaps: bool = False,
) -> np.ndarray:
    """Parse one column over the window rows; fill interior gaps up to ``max_gap_fill``.
    A gap that cannot be filled is a DataError, or with ``keep_gaps`` stays NaN (an optional
    series: its user refuses it)."""
    name = table.header[col]
    out = np.empty(idx.size)
    for j, i in enumerate(idx):
        text = table.rows[i][col]
        if text.lower() in MISSING_TOKENS:
            out[j] = np.nan
            continue
        try:
            out[j] = float(text)
        except ValueError:
            raise table.error(f"non-numeric value {text!r}", name, i) from None
        if not math.isfinite(out[j]):
            raise table.error(f"non-finite value {text!r}", name, i)
    missing = np.isnan(out)
    if not missing.any():
        return out
    # runs of consecutive missing cells: [first, last] window indices
    edges = np.diff(np.concatenate(([0], missing.astype(np.int8), [0])))
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1, strict=True):
        rows = f"{table.where(idx[a])}" + (f" to {table.where(idx[b])}" if b > a else "")
        n = b - a + 1
        what = f"{n} consecutive missing values" if n > 1 else "missing value"
        edge = a == 0 or b == idx.size - 1
        if keep_gaps and (edge or n > max_gap_fill):
            missing[a : b + 1] = False  # left as NaN
            continue
        if edge:
            raise table.error(
                f"{what} at the edge of the time window, {rows}; edge gaps cannot be "
                "interpolated (narrow window_hours instead)",
                name,
            )
        if n > max_gap_fill:
            raise table.error(
                f"{what}, {rows}; max_gap_fill = {max_gap_fill}",
                name,
            )
        fills.append((name, int(idx[a]) + 1, int(idx[b]) + 1))
    if missing.any():
        known = np.isfinite(out)
        out[missing] = np.interp(t[missing], t[known], out[known])
    return out


def _check_temperature(table: _Table, col: int, arr: np.ndarray, idx: np.ndarray) -> None:
    name = table.header[col]
    med = float(np.median(arr))
    if med > KELVIN_MEDIAN:
        raise table.error(
            f"value {arr[0]:g}, median {med:.1f}: looks like kelvin, convert to °C (subtract 273.15)",
            name,
            int(idx[0]),
        )
    _check_range(table, col, arr, idx, *T_RANGE, "degC, physically implausible")


def _check_range(
    table: _Table,
    col: int,
    arr: np.ndarray,
    idx: np.ndarray,
    lo: float,
    hi: float,
    what: str,
) -> None:
    bad = np.flatnonzero((arr < lo) | (arr > hi))
    if bad.size:
        j = int(bad[0])
        more = f" ({bad.size} rows in all)" if bad.size > 1 else ""
        raise table.error(
            f"value {arr[j]:g} outside [{lo:g}, {hi:g}] ({what}){more}",
            table.header[col],
            int(idx[j]),
        )
