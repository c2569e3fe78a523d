"""Read and validate a case CSV into :class:`~pavement_mcmc.data.Measurements`.

The column contract (see ``data/reference_case/README.md``):

=============  ============  ==============================================
column         unit          meaning
=============  ============  ==============================================
``time``       ISO 8601 UTC  sample time (any, possibly irregular, step)
``T_air``      degC          air temperature
``q_net``      W m-2         net radiation, positive into the ground
``wind``       m s-1         wind speed (optional)
``rain``       mm per step   precipitation (optional)
``T_<d>cm``    degC          ground temperature at depth ``d`` cm (``T_2.5cm``)
``G_<d>cm``    W m-2         heat-flux plate at depth ``d`` cm, positive downward
                             (optional; a second kind of observation)
``T_surf_IR``  degC          infrared surface temperature (optional; with ``RH`` and the
                             radiation components ``SW_in`` ...: the extras,
                             :mod:`pavement_mcmc.data.extras`, also from a second CSV)
=============  ============  ==============================================

Every problem with the input raises :class:`DataError` naming the file, the column and the row
("data row N" is the 1-based row after the header, "line L" the line in the file). Nothing is
returned unless every check passes. Soft issues (very large time gaps, ignored columns) are
reported through :mod:`warnings`. The row-level checks (times, window, cells, ranges) live
in :mod:`pavement_mcmc.data.checks`; every name there is re-exported here.
"""

from __future__ import annotations

import difflib
import math
import re
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import MappingProxyType

import numpy as np

from .checks import (
    _TOL,
    G_MAX,
    PLATE_RE,
    Q_MAX,
    DataError,
    _check_range,
    _check_temperature,
    _numeric_column,
    _parse_times,
    _Table,
    _warn_time_gaps,
    _window,
)
from .extras import EXTRA_ROLES, check_extra, merge_extras
from .fluxsite import apply_preset
from .measurements import Measurements
from .table import read_table
from .times import daily_peak_hour, format_time

__all__ = ["DataError", "read_csv_case"]

_ROLES = ("time", "T_air", "q_net", "wind", "rain")
_FORCING = ("T_air", "q_net")  # required unless the top boundary is a measured sensor
_DEPTH_RE = re.compile(r"^T_(\d+(?:\.\d*)?|\.\d+)cm$")


def read_csv_case(
    csv_path: str | Path,
    *,
    sigma: float,
    columns: Mapping[str, str] | None = None,
    observed: Sequence[float] | None = None,
    bottom: float | None = None,
    window_hours: Sequence[float | None] | None = None,
    max_gap_fill: int = 0,
    extras: str | Path | None = None,
    preset: str | None = None,
    preset_options: Mapping | None = None,
    forcing_optional: bool = False,
) -> Measurements:
    """Read a case CSV, validate it and return its :class:`Measurements`.

    Parameters
    ----------
    csv_path : str or Path
        The CSV file (comma separated, one header line, UTF-8).
    sigma : float
        Measurement noise standard deviation, degC; must be > 0.
    columns : mapping of str to str, optional
        Renames from the file's column names to contract roles, e.g.
        ``{"Tair_C": "T_air", "TC3": "T_3cm", "stamp": "time"}``.
    observed : sequence of float, optional
        Depths (cm) of the observed sensors. Default: every ``T_<d>cm`` shallower than `bottom`.
    bottom : float, optional
        Depth (cm) of the sensor used as the Dirichlet boundary. Default: the deepest sensor.
    window_hours : (start, end), optional
        Time window in hours after the file's first row, both ends inclusive; ``None`` for an
        open end. ``t = 0`` is the first row inside the window. Default: every row.
    max_gap_fill : int, default 0
        Longest run of consecutive missing cells (per column, inside the window) that is filled
        by linear interpolation in time. Filled gaps are listed in ``Measurements.fill_report``
        as ``(column, first_data_row, last_data_row)`` with 1-based data-row numbers of the file.
    extras : str or Path, optional
        A second CSV whose extras columns (``T_surf_IR``, ``RH``, ``SW_in``, ...) are merged on
        time into ``Measurements.extras`` (:mod:`pavement_mcmc.data.extras`).
    preset : str, optional
        ``"ameriflux"`` or ``"fluxnet"``: read a flux-site file as it is
        (:mod:`pavement_mcmc.data.fluxsite`); ``preset_options``: ``utc_offset_hours``,
        ``depths_cm``, ``timestamp``.
    forcing_optional : bool, default False
        ``True`` for a case whose top boundary is its shallowest sensor (``model.top =
        "measured"``): the air temperature and net radiation do not enter the model, so their
        columns may be absent (all NaN) and their unfillable gaps stay NaN instead of refusing
        the window. Values present are still checked.

    Returns
    -------
    Measurements
        Arrays in SI units (seconds, metres) and degC, read-only.

    Raises
    ------
    DataError
        For any invalid input; the message names the file, column and row where they apply.

    Notes
    -----
    Times are parsed for every row (the window is defined from the first row); numeric cells
    are parsed and checked only for the used columns and the rows inside the window. Times with
    a UTC offset are converted to UTC; naive times are taken as UTC.
    """
    path = str(csv_path)
    sigma = _check_sigma(sigma, path)
    if isinstance(max_gap_fill, bool) or not isinstance(max_gap_fill, int) or max_gap_fill < 0:
        raise DataError(f"{path}: max_gap_fill must be an integer >= 0, got {max_gap_fill!r}")

    table, columns, etable, emap = _tables(path, columns, extras, preset, preset_options)
    roles, sensors = _resolve_columns(table, columns, () if forcing_optional else _FORCING)
    depth_obs, depth_bot = _select_sensors(table, sensors, observed, bottom)

    stamps = _parse_times(table, roles["time"])
    hours = (stamps - stamps[0]) / 3600.0
    idx = _window(table, hours, window_hours, table.header[roles["time"]])
    t = stamps[idx] - stamps[idx[0]]
    _warn_time_gaps(table, t, idx)

    fills: list[tuple[str, int, int]] = []

    def column(col: int) -> np.ndarray:
        return _numeric_column(table, col, idx, t, max_gap_fill, fills)

    def forcing(role: str) -> np.ndarray:
        if not forcing_optional:
            return column(roles[role])
        if role not in roles:
            return np.full(idx.size, np.nan)
        return _numeric_column(table, roles[role], idx, t, max_gap_fill, fills, keep_gaps=True)

    T_air = forcing("T_air")
    q_net = forcing("q_net")
    wind = forcing("wind") if "wind" in roles else None
    rain = forcing("rain") if "rain" in roles else None
    T_obs = np.column_stack([column(sensors[d]) for d in depth_obs])
    T_bottom = column(sensors[depth_bot])
    plates = {k: column(roles[k]) for k in roles if k.startswith("G_")}
    for k, arr in plates.items():
        _check_range(table, roles[k], arr, idx, -G_MAX, G_MAX, "W m-2")

    for col, arr in [(sensors[depth_bot], T_bottom)] + [
        (sensors[d], T_obs[:, k]) for k, d in enumerate(depth_obs)
    ]:
        _check_temperature(table, col, arr, idx)
    known_air, known_q = np.isfinite(T_air), np.isfinite(q_net)
    if known_air.any():
        _check_temperature(table, roles["T_air"], T_air[known_air], idx[known_air])
    if known_q.any():
        _check_range(table, roles["q_net"], q_net[known_q], idx[known_q], -Q_MAX, Q_MAX, "W m-2")
    for role, arr in (("wind", wind), ("rain", rain)):
        if arr is not None:
            known = np.isfinite(arr)
            _check_range(table, roles[role], arr[known], idx[known], 0.0, math.inf, f"negative {role}")

    named = {}
    for role in EXTRA_ROLES:
        if role in roles:
            named[role] = _numeric_column(table, roles[role], idx, t, max_gap_fill, fills,
                                          keep_gaps=True)  # unfillable gaps: NaN
            check_extra(table, roles[role], named[role], idx, role)
    if etable is not None:
        named.update(merge_extras(etable, stamps[idx], t, emap, max_gap_fill, fills,
                                  set(named) | set(plates), path))
        plates.update({k: named.pop(k) for k in list(named) if k.startswith("G_")})
    flux_depths, G_obs = _plate_block(plates, depth_bot, table, roles)
    for arr in named.values():
        arr.flags.writeable = False
    time0 = format_time(stamps[idx[0]])
    midday = _file_midday(table, roles.get("q_net"), stamps)
    arrays = dict(
        t=t,
        T_air=T_air,
        q_net=q_net,
        wind=wind,
        rain=rain,
        depths=np.asarray(depth_obs, float) / 100.0,
        T_obs=T_obs,
        T_bottom=T_bottom,
        flux_depths=flux_depths,
        G_obs=G_obs,
    )
    for arr in arrays.values():
        if arr is not None:
            arr.flags.writeable = False
    return Measurements(
        time0=time0,
        bottom_depth=depth_bot / 100.0,
        sigma=sigma,
        source=path,
        fill_report=tuple(fills),
        extras=MappingProxyType(named),
        midday=midday,
        **arrays,
    )


def _file_midday(table: _Table, col: int | None, stamps: np.ndarray) -> float | None:
    """The daily peak hour of ``q_net`` over every row of the file (unparsable or missing cells
    left out): one reference for every window cut from the record."""
    if col is None:
        return None
    q = np.full(len(table.rows), np.nan)
    for i, row in enumerate(table.rows):
        try:
            q[i] = float(row[col])
        except (ValueError, IndexError):
            pass
    return daily_peak_hour(np.mod(stamps / 3600.0, 24.0), q)


def _plate_block(plates: dict[str, np.ndarray], depth_bot: float, table: _Table, roles):
    """Plate depths (m) and readings (n_obs, n_plates), shallowest first, or (None, None)."""
    if not plates:
        return None, None
    order = sorted(plates, key=lambda k: float(k[2:-2]))
    for k in order:
        if float(k[2:-2]) >= depth_bot:
            msg = (f"heat-flux plate at {k[2:-2]} cm is not above the bottom boundary at "
                   f"{depth_bot:g} cm")
            raise table.error(msg, k) if k in roles else DataError(f"{table.path}: {msg}")
    return (np.asarray([float(k[2:-2]) for k in order]) / 100.0,
            np.column_stack([plates[k] for k in order]))


def _tables(path: str, columns, extras, preset, preset_options):
    """The case table (as the contract, through a preset), its renames, and the extras table
    with its renames (None, {} without one)."""
    table = read_table(path)
    columns = dict(columns or {})
    etable = read_table(str(extras)) if extras is not None else None
    emap = {}
    if etable is not None:  # renames of the second file's columns
        emap = {k: v for k, v in columns.items() if k in etable.header}
        columns = {k: v for k, v in columns.items() if k not in emap or k in table.header}
    if preset is not None:  # the preset applies the case file's renames itself
        table = apply_preset(table, preset, columns=columns, **dict(preset_options or {}))
        columns = {}
    return table, columns, etable, emap


def _check_sigma(sigma: object, path: str) -> float:
    if isinstance(sigma, bool) or not isinstance(sigma, int | float | np.floating | np.integer):
        raise DataError(f"{path}: sigma must be a number (degC), got {sigma!r}")
    if not math.isfinite(sigma) or sigma <= 0:
        raise DataError(f"{path}: sigma must be finite and > 0 (degC), got {sigma!r}")
    return float(sigma)


def _role_of(name: str) -> str | float | None:
    """Contract role of a column name: a role string (``G_<d>cm`` for a heat-flux plate, in its
    canonical spelling), a sensor depth in cm, or None."""
    if name in _ROLES or name in EXTRA_ROLES:
        return name
    m = _DEPTH_RE.match(name)
    if m:
        return float(m.group(1))
    m = PLATE_RE.match(name)
    return f"G_{float(m.group(1)):g}cm" if m else None


def _resolve_columns(
    table: _Table, columns: Mapping[str, str] | None, forcing: tuple[str, ...] = _FORCING
) -> tuple[dict[str, int], dict[float, int]]:
    """Map roles to column indices: ({role: index}, {depth_cm: index}); ``time`` and the
    ``forcing`` roles are required."""
    path, header = table.path, table.header
    index = {name: k for k, name in enumerate(header)}
    mapping = dict(columns or {})
    for src, role in mapping.items():
        if src not in index:
            hint = ""
            if role in index and isinstance(src, str) and _role_of(src) is not None:
                hint = f"; the mapping goes file column -> role: use {{{role!r}: {src!r}}}"
            else:
                close = difflib.get_close_matches(str(src), header, n=1, cutoff=0.5)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise DataError(
                f"{path}, column {src!r} named in the column mapping is not in the file{hint}. "
                f"Columns in the file: {', '.join(header)}"
            )
        if not isinstance(role, str) or _role_of(role) is None:
            raise DataError(
                f"{path}, column {src!r} is mapped to {role!r}, which is not a role; valid roles "
                f"are {', '.join(_ROLES)}, T_<depth>cm (e.g. T_2.5cm), G_<depth>cm (a heat-flux plate) "
                f"and the extras {', '.join(EXTRA_ROLES)}"
            )
    roles: dict[str, int] = {}
    sensors: dict[float, int] = {}
    ignored: list[str] = []
    for k, name in enumerate(header):
        target = mapping.get(name, name)
        role = _role_of(target)
        if role is None:
            ignored.append(name)
            continue
        key = f"T_{role:g}cm" if isinstance(role, float) else role
        store: dict = sensors if isinstance(role, float) else roles
        if role in store:
            other = header[store[role]]
            raise DataError(f"{path}, column {name!r}: columns {other!r} and {name!r} both provide {key!r}")
        store[role] = k
    for role in ("time", *forcing):
        if role not in roles:
            close = difflib.get_close_matches(role, ignored, n=1, cutoff=0.5)
            if not close:
                close = [n for n in ignored if n.lower() == role.lower()][:1]
            hint = (f" (did you mean {close[0]!r}? map it with columns={{{close[0]!r}: {role!r}}})"
                    if close else "")
            raise DataError(
                f"{path}, column {role!r}: required column is missing{hint}. "
                f"Columns in the file: {', '.join(header)}"
            )
    if ignored:
        warnings.warn(
            f"{path}: columns not in the contract are ignored: {', '.join(ignored)}",
            stacklevel=3,
        )
    return roles, sensors


def _select_sensors(
    table: _Table,
    sensors: dict[float, int],
    observed: Sequence[float] | None,
    bottom: float | None,
) -> tuple[list[float], float]:
    path = table.path
    have = sorted(sensors)
    listing = ", ".join(f"{d:g}" for d in have) or "none"

    def find(depth: object, what: str) -> float:
        if isinstance(depth, bool) or not isinstance(depth, int | float | np.number):
            raise DataError(f"{path}: {what} depth must be a number (cm), got {depth!r}")
        for d in have:
            if abs(d - float(depth)) < _TOL:
                return d
        raise DataError(
            f"{path}, column 'T_{float(depth):g}cm': no column for the {what} sensor at "
            f"{float(depth):g} cm; sensor depths in the file (cm): {listing}"
        )

    if not have:
        raise DataError(f"{path}: no sensor columns T_<depth>cm in the file")
    depth_bot = have[-1] if bottom is None else find(bottom, "bottom")
    if observed is None:
        depth_obs = [d for d in have if d < depth_bot]
    else:
        depth_obs = sorted(find(d, "observed") for d in observed)
        for a, b in zip(depth_obs, depth_obs[1:], strict=False):
            if a == b:
                raise DataError(f"{path}, column 'T_{a:g}cm': observed depth listed twice")
        for d in depth_obs:
            if d >= depth_bot:
                raise DataError(
                    f"{path}, column 'T_{d:g}cm': observed sensor at {d:g} cm is not shallower "
                    f"than the bottom boundary at {depth_bot:g} cm"
                )
    if observed is not None and not depth_obs:
        raise DataError(f"{path}: no observed sensor: `observed` is empty")
    if not depth_obs:
        raise DataError(
            f"{path}: no observed sensor: no T_<depth>cm column is shallower than the bottom "
            f"boundary at {depth_bot:g} cm; sensor depths in the file (cm): {listing}"
        )
    return depth_obs, depth_bot
