"""Optional named series (``Measurements.extras``): their column convention, checks, and the
merge of a second CSV on time.

=============  ============  ==========================================================
column         unit          meaning
=============  ============  ==========================================================
``T_surf_IR``  degC          infrared surface temperature (a radiometric skin or canopy
                             temperature; observed with ``[data] ir_sigma``)
``RH``         %             relative humidity of the air, 0-100
``T_dew``      degC          dew point of the air (or estimated from the daily minimum
                             air temperature: ``[data] dew_below_tmin``, :mod:`.humidity`)
``SW_in``      W m-2         incoming (downwelling) short-wave radiation, >= 0
``SW_out``     W m-2         reflected (upwelling) short-wave radiation, >= 0
``LW_in``      W m-2         incoming (downwelling) long-wave radiation, > 0
``LW_out``     W m-2         emitted + reflected (upwelling) long-wave radiation, > 0
``LE``, ``H``  W m-2         measured latent and sensible heat flux, upward positive
``SWC``        m3 m-3        water content of the top soil, 0-0.7 (read by
                             ``energy_balance_swc``)
=============  ============  ==========================================================

They may be columns of the case CSV or of a second CSV named by ``[data] extras`` (comma
separated, a ``time`` column, other columns ignored). The second file is merged on time: it
must have a row at every time of the case's window (within 0.5 s; rows between or outside them
are ignored), and a column the case CSV also provides is refused. ``[data.columns]`` renames
apply to both files (a source column belongs to the file that has it). Missing cells follow
``max_gap_fill`` as in the case CSV, but a gap it cannot fill (at the window's edge, or
longer) stays NaN instead of refusing the case: flux-site series (LE, H) have long gaps and
an unused one must not make the data unreadable; a stream that uses the series refuses its
gaps (:class:`~pavement_mcmc.posterior.surface_ir.SurfaceIR`). A heat-flux plate
``G_<depth>cm`` (a column renamed to it, e.g. ``[data.columns] "G_minus_SG" = "G_5cm"``) may
come from the second file too; it is observed at every time, so its gaps refuse the window as
in the case CSV. Errors are
:class:`~pavement_mcmc.data.DataError` naming the file, the column and the row.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .checks import (
    G_MAX,
    PLATE_RE,
    Q_MAX,
    DataError,
    _check_range,
    _check_temperature,
    _numeric_column,
    _parse_times,
    _Table,
)
from .times import format_time

__all__ = ["EXTRA_ROLES", "check_extra", "merge_extras"]

#: the optional named series and their units
EXTRA_ROLES = {"T_surf_IR": "degC", "RH": "%", "T_dew": "degC", "SW_in": "W m-2", "SW_out": "W m-2",
               "LW_in": "W m-2", "LW_out": "W m-2", "LE": "W m-2", "H": "W m-2", "SWC": "m3 m-3"}
#: times of the two files closer than this (s) are the same time
TIME_TOL = 0.5


def check_extra(table: _Table, col: int, arr: np.ndarray, idx: np.ndarray, role: str) -> None:
    """Plausibility of one extra series (range, kelvin, a fraction given for a percentage) where
    it has values (its unfillable gaps are NaN)."""
    known = np.isfinite(arr)
    if not known.any():
        return
    arr, idx = arr[known], idx[known]
    if role in ("T_surf_IR", "T_dew"):
        _check_temperature(table, col, arr, idx)
    elif role == "RH":
        if arr.size and float(np.max(arr)) <= 1.5:
            raise table.error(f"largest value {float(np.max(arr)):g}: looks like a fraction, "
                              "RH is in % (0-100)", table.header[col], int(idx[0]))
        _check_range(table, col, arr, idx, 0.0, 105.0, "%")
    elif role == "SWC":
        # judged on the whole column: a dry window in % (0.2 % read as 0.2 m3 m-3) looks valid
        top, row = _largest(table, col)
        if top > 1.5:
            raise table.error(f"largest value in the file {top:g}: looks like a percentage, "
                              "SWC is in m3 m-3 (0-0.7)", table.header[col], row)
        _check_range(table, col, arr, idx, 0.0, 0.7, "m3 m-3")
    elif role in ("LE", "H"):
        _check_range(table, col, arr, idx, -Q_MAX, Q_MAX, "W m-2")
    else:  # radiation components: night-time offsets of a few W m-2 below 0 are allowed
        _check_range(table, col, arr, idx, -50.0, Q_MAX, "W m-2")


def _largest(table: _Table, col: int) -> tuple[float, int]:
    """The largest finite number in column ``col`` of the whole file, and its row (cells that
    are not numbers are left to the window's own checks)."""
    top, row = -np.inf, 0
    for i, r in enumerate(table.rows):
        try:
            v = float(r[col])
        except (ValueError, IndexError):
            continue
        if np.isfinite(v) and v > top:
            top, row = v, i
    return top, row


def merge_extras(table: _Table, stamps: np.ndarray, t: np.ndarray, columns: Mapping[str, str],
                 max_gap_fill: int, fills: list, taken: set[str], case_path: str
                 ) -> dict[str, np.ndarray]:
    """The extra series of a second CSV at the case's window times.

    ``stamps``: the window's times (s since the epoch); ``t``: the same from the window start;
    ``columns``: renames, file column -> role; ``taken``: roles the case CSV already provides.
    """
    path, header = table.path, table.header
    names = [columns.get(h, h) for h in header]
    if "time" not in names:
        raise DataError(f"{path}, column 'time': the extras file has no time column. "
                        f"Columns in the file: {', '.join(header)}")
    found = {role: k for k, role in enumerate(names) if role in EXTRA_ROLES or PLATE_RE.match(role)}
    if not found:
        raise DataError(f"{path}: no extras column in the file (expected any of "
                        f"{', '.join(EXTRA_ROLES)}). Columns in the file: {', '.join(header)}")
    for role in found:
        if role in taken:
            raise DataError(f"{path}, column {header[found[role]]!r}: {role!r} is also a column "
                            f"of {case_path}; keep one")
    times = _parse_times(table, names.index("time"))
    idx = _match(table, times, stamps, case_path)
    out = {}
    for role, col in found.items():
        if PLATE_RE.match(role):  # a plate is observed at every time: a gap refuses the window
            arr = _numeric_column(table, col, idx, t, max_gap_fill, fills)
            _check_range(table, col, arr, idx, -G_MAX, G_MAX, "W m-2")
        else:
            arr = _numeric_column(table, col, idx, t, max_gap_fill, fills, keep_gaps=True)
            check_extra(table, col, arr, idx, role)
        out[role] = arr
    return out


def _match(table: _Table, times: np.ndarray, stamps: np.ndarray, case_path: str) -> np.ndarray:
    """Row of ``table`` at each of ``stamps`` (a DataError naming the first time it lacks)."""
    hi = np.minimum(np.searchsorted(times, stamps), times.size - 1)
    lo = np.maximum(hi - 1, 0)
    j = np.where(np.abs(times[lo] - stamps) <= np.abs(times[hi] - stamps), lo, hi)
    miss = np.flatnonzero(np.abs(times[j] - stamps) > TIME_TOL)
    if miss.size:
        k = int(miss[0])
        more = f" ({miss.size} of the window's {stamps.size} times in all)" if miss.size > 1 else ""
        raise DataError(
            f"{table.path}, column 'time': no row at {format_time(stamps[k])}, a time of "
            f"{case_path}'s window{more}; the nearest is {format_time(times[j[k]])}. The extras "
            "file must have a row at every time of the case (same clock, UTC)")
    return j

