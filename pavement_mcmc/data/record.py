"""The whole record of a case file, whatever its window: the times of every row (a batch or a
rolling forecast cuts windows from them) and the air temperature (the dew point's running
minimum looks 12 h past a window's edges: :mod:`.humidity`). Columns are found as
:func:`~.reader.read_csv_case` finds them: renamed by ``columns`` (renames of the ``extras``
file's columns are left to it), or made by a flux-site ``preset``."""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .checks import MISSING_TOKENS, T_RANGE, DataError, _parse_times
from .reader import _resolve_columns, _tables

__all__ = ["record_air_temperature", "record_stamps"]


def _record(csv_path, columns, extras, preset, preset_options):
    table, columns, _, _ = _tables(str(csv_path), columns, extras, preset, preset_options)
    roles, _ = _resolve_columns(table, columns, ())
    return table, roles


def record_stamps(csv_path: str | Path, columns: Mapping[str, str] | None = None,
                  preset: str | None = None, preset_options: Mapping | None = None,
                  extras: str | Path | None = None) -> np.ndarray:
    """Seconds since the Unix epoch (UTC) of every row of a case file."""
    table, roles = _record(csv_path, columns, extras, preset, preset_options)
    return _parse_times(table, roles["time"])


def record_air_temperature(csv_path: str | Path, columns: Mapping[str, str] | None = None,
                           preset: str | None = None, preset_options: Mapping | None = None,
                           extras: str | Path | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(stamps, T_air)`` of every row: seconds since the Unix epoch and the air temperature,
    degC. A cell that is missing, not a number, or outside the plausible range (the window's
    own cells are checked, and refused, by the case's reader) is NaN, with one warning naming
    how many and the first."""
    table, roles = _record(csv_path, columns, extras, preset, preset_options)
    stamps = _parse_times(table, roles["time"])
    if "T_air" not in roles:
        raise DataError(f"{csv_path}: no air temperature column (T_air)")
    col = roles["T_air"]
    out = np.full(stamps.size, np.nan)
    bad = []
    for i, row in enumerate(table.rows):
        text = row[col]
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if T_RANGE[0] <= value <= T_RANGE[1]:
            out[i] = value
        elif text.lower() not in MISSING_TOKENS:
            bad.append(i)
    if bad:
        warnings.warn(f"{table.path}, column {table.header[col]!r}: {len(bad)} air temperatures "
                      f"outside {T_RANGE[0]:g} to {T_RANGE[1]:g} degC or not numbers, first "
                      f"{table.where(bad[0])}, left out of the dew point's running minimum",
                      stacklevel=2)
    return stamps, out
