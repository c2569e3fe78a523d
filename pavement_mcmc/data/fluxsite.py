"""Flux-site presets: read an AmeriFlux BASE or FLUXNET file as it is, no conversion script.

A case TOML names the preset and what the file does not say::

    [data]
    csv = "US-Xyz_HH_202001010000_202101010000.csv"
    preset = "ameriflux"           # or "fluxnet" (FLUXNET2015 / ONEFlux: TA_F, G_F_MDS, ...)
    utc_offset_hours = -7          # the file's local standard time (no daylight saving)
    timestamp = "middle"           # the sample time of an interval mean: "start", "middle", "end"
    sigma = 0.1
    [data.depths_cm]               # depth (cm) of each soil temperature and heat-flux column
    TS_1_1_1 = 5
    TS_1_2_1 = 10
    TS_1_3_1 = 30
    G_1_1_1 = 8

Column names (AmeriFlux variable names, optionally with a ``_<H>_<V>_<R>`` position qualifier
or FLUXNET's gap-filled suffixes ``_F``, ``_F_MDS``) -> the case contract:

=============  ===========  =====================================================
file           contract     note
=============  ===========  =====================================================
TIMESTAMP_*    ``time``     ``YYYYMMDDHHMM`` local standard time -> UTC
TA             ``T_air``    degC
NETRAD         ``q_net``    W m-2, positive into the ground
WS             ``wind``     m s-1
P              ``rain``     mm per interval
RH             ``RH``       %
SW_IN, SW_OUT  ``SW_in``,   W m-2
LW_IN, LW_OUT  ``LW_in``,   W m-2 (``SW_out``, ``LW_out``)
T_CANOPY       ``T_surf_IR``  degC, an infrared canopy (surface) temperature
LE, H          ``LE``, ``H``  W m-2, latent and sensible heat flux (upward positive)
TS_*           ``T_<d>cm``  degC, depth ``d`` from ``[data.depths_cm]``
G_*, G         ``G_<d>cm``  W m-2, positive downward, depth from ``[data.depths_cm]``
=============  ===========  =====================================================

``-9999`` is a missing value (filled only as ``max_gap_fill`` allows). Of one variable's
columns the preset takes FLUXNET's consolidated ``_F`` before ``_F_MDS`` before the raw one
(``fluxnet``), or the raw one first (``ameriflux``); two equally preferred columns for one role
(``TA_1_1_1`` and ``TA_1_2_1``) are refused with their names: pick one with ``[data.columns]``
(``TA_1_2_1 = "T_air"``), which overrides the preset. A soil column without a depth is left out
(and named in the error when no soil temperature is left). Other columns are ignored.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from datetime import datetime, timedelta, timezone

from .checks import DataError, _Table
from .times import format_time

__all__ = ["PRESETS", "VARIABLES", "apply_preset"]

PRESETS = ("ameriflux", "fluxnet")
#: AmeriFlux variable -> contract role (soil profiles TS_* and G_* take their depth from TOML)
VARIABLES = {"TA": "T_air", "NETRAD": "q_net", "WS": "wind", "P": "rain", "RH": "RH",
             "SW_IN": "SW_in", "SW_OUT": "SW_out", "LW_IN": "LW_in", "LW_OUT": "LW_out",
             "T_CANOPY": "T_surf_IR", "LE": "LE", "H": "H"}
TIMESTAMPS = ("start", "middle", "end")
MISSING_VALUE = -9999.0
_NAME = re.compile(r"^(?P<var>[A-Z]+(?:_[A-Z]+)*?)(?P<suffix>_F_MDS|_F)?(?P<pos>(?:_\d+)*)$")


def _variable(name: str) -> str | None:
    """The AmeriFlux variable of a column name (``TA_1_2_1`` -> ``TA``, ``TA_F`` -> ``TA``)."""
    m = _NAME.match(name)
    return m.group("var") if m else None


def _missing(text: str) -> bool:
    """``-9999`` however it is written (``-9999.0`` after a re-save)."""
    try:
        return float(text) == MISSING_VALUE
    except ValueError:
        return False


def _stamp(table: _Table, col: int, i: int, tz: timezone) -> float:
    text = table.rows[i][col]
    try:
        return datetime.strptime(text, "%Y%m%d%H%M").replace(tzinfo=tz).timestamp()
    except ValueError:
        raise table.error(f"cannot parse {text!r} as YYYYMMDDHHMM", table.header[col], i) from None


def _times(table: _Table, utc_offset_hours: float, timestamp: str) -> list[str]:
    """ISO UTC sample times of every row from TIMESTAMP_START / TIMESTAMP_END."""
    if timestamp not in TIMESTAMPS:
        raise DataError(f"{table.path}: timestamp = {timestamp!r}; valid: {', '.join(TIMESTAMPS)}")
    tz = timezone(timedelta(hours=float(utc_offset_hours)))
    ends = [n for n in ("TIMESTAMP_START", "TIMESTAMP_END") if n in table.header]
    need = {"start": ["TIMESTAMP_START"], "end": ["TIMESTAMP_END"],
            "middle": ["TIMESTAMP_START", "TIMESTAMP_END"]}[timestamp]
    if any(n not in ends for n in need):
        raise DataError(f"{table.path}: timestamp = {timestamp!r} needs the column(s) "
                        f"{', '.join(need)}; columns in the file: {', '.join(table.header)}")
    cols = [table.header.index(n) for n in need]
    out = []
    for i, row in enumerate(table.rows):
        if _missing(row[cols[0]]):
            raise table.error("missing time", need[0], i)
        s = [_stamp(table, c, i, tz) for c in cols]
        out.append(format_time(sum(s) / len(s)))
    return out


def _rank(name: str, preset: str) -> int:
    """Preference among columns of one variable: FLUXNET's consolidated ``_F`` first, then
    ``_F_MDS``, then the raw one; AmeriFlux BASE the raw one first."""
    suffix = _NAME.match(name).group("suffix") or ""
    order = ("_F", "_F_MDS", "") if preset == "fluxnet" else ("", "_F", "_F_MDS")
    return order.index(suffix)


def _roles(table: _Table, preset: str, depths_cm: Mapping[str, float],
           columns: Mapping[str, str]) -> dict:
    """Column index -> contract name; refuses two equally preferred columns for one role."""
    out: dict[int, str] = {}
    seen: dict[str, tuple[int, int]] = {}  # role -> (column, rank)
    for k, name in enumerate(table.header):
        rank = -1  # a rename or a depth given in the TOML: always taken
        if name in columns:
            role = columns[name]
        elif name in depths_cm:
            kind = "G" if _variable(name) == "G" else "T"
            role = f"{kind}_{float(depths_cm[name]):g}cm"
        else:
            var = _variable(name)
            role = VARIABLES.get(var) if var is not None else None
            if role is None or role in columns.values():
                continue
            rank = _rank(name, preset)
        if role in seen:
            j, other = seen[role]
            if other == rank:
                raise DataError(f"{table.path}, column {name!r}: {table.header[j]!r} and {name!r} "
                                f"both give {role!r}; choose one in [data.columns], e.g. "
                                f"{{{name!r} = {role!r}}}")
            if other < rank:
                continue
            del out[j]
        seen[role] = (k, rank)
        out[k] = role
    if not any(r.startswith("T_") and r.endswith("cm") for r in out.values()):
        soil = [n for n in table.header if _variable(n) == "TS"]
        raise DataError(f"{table.path}: no soil temperature with a depth; give the depth (cm) of "
                        f"each in [data.depths_cm], e.g. {soil[0] if soil else 'TS_1_1_1'} = 5. "
                        f"Soil temperature columns in the file: {', '.join(soil) or 'none'}")
    return out


def apply_preset(table: _Table, preset: str, *, utc_offset_hours: float | None = None,
                 depths_cm: Mapping[str, float] | None = None, timestamp: str = "middle",
                 columns: Mapping[str, str] | None = None) -> _Table:
    """``table`` as the case contract: renamed columns, ISO UTC ``time``, ``-9999`` missing."""
    if preset not in PRESETS:
        raise DataError(f"{table.path}: preset = {preset!r}; valid: {', '.join(PRESETS)}")
    if utc_offset_hours is None:
        raise DataError(f"{table.path}: preset {preset!r} needs utc_offset_hours (the file's "
                        "local standard time, e.g. -7 for MST)")
    if not -12.0 <= float(utc_offset_hours) <= 14.0:  # also NaN
        raise DataError(f"{table.path}: utc_offset_hours = {utc_offset_hours!r}; a time zone's "
                        "offset from UTC is between -12 and +14 hours")
    columns = dict(columns or {})
    unknown = sorted(set(depths_cm or {}) - set(table.header))
    if unknown:
        raise DataError(f"{table.path}: depths_cm names {', '.join(unknown)}, not in the file. "
                        f"Columns in the file: {', '.join(table.header)}")
    times = _times(table, utc_offset_hours, timestamp)
    roles = _roles(table, preset, depths_cm or {}, columns)
    keep = sorted(roles)
    rows = [[t] + ["" if _missing(r[k]) else r[k] for k in keep]
            for t, r in zip(times, table.rows, strict=True)]
    return _Table(table.path, ["time"] + [roles[k] for k in keep], rows, table.lines)
