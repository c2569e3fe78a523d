"""The case TOML's schema and its validation (the schema itself is written out in
:mod:`pavement_mcmc.data`).

The key tables (:data:`SECTIONS`, :data:`DATA_KEYS`, :data:`GRID_DEFAULTS`,
:data:`SAMPLER_DEFAULTS`, :data:`PARAMETER_KEYS`), :class:`ConfigError`, and the checks that
refuse unknown keys (with a close-match hint), wrong types, values JSON cannot store and an h(t)
discretisation that does not cover the data window. Everything public here is re-exported by
:mod:`pavement_mcmc.data`.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from typing import Any

from .errors import UserError
from .measurements import Measurements

#: Valid top-level keys.
SECTIONS = ("name", "description", "data", "model", "grid", "parameters", "sampler")
#: Valid keys of [data].
DATA_KEYS = (
    "csv",
    "truth",
    "sigma",
    "input_sigma",
    "T_air_sigma",
    "q_net_sigma",
    "q_net_rel_sigma",
    "window_hours",
    "observed_cm",
    "bottom_cm",
    "max_gap_fill",
    "columns",
    "plates",
    "plate_sigma",
    "plate_rel_sigma",
    "extras",
    "ir_sigma",
    "ir_storage_free",
    "dew_below_tmin",
    "preset",
    "utc_offset_hours",
    "timestamp",
    "depths_cm",
)
#: valid values of [model] top: the surface energy balance, or the shallowest sensor measured
TOPS = ("surface", "measured")
#: Valid keys of [grid] and their defaults (dx in m, dt in s; None = the solver's measured default).
GRID_DEFAULTS: dict[str, Any] = {"kind": "auto", "dx": None, "dt": None, "dx_top": None,
                                  "growth": None, "dx_max": None, "scheme": "cn"}
#: valid values of [grid] kind: "auto" is uniform down to 10 cm, stretched below
GRID_KINDS = ("auto", "uniform", "stretched")
#: Valid keys of [sampler] and their defaults (None: the sampler chooses).
SAMPLER_DEFAULTS: dict[str, Any] = {
    "kind": "emcee",
    "seed": None,
    "n_walkers": None,
    "ess_target": None,  # None: the stopping rule's own (diagnostics.StoppingRule)
    "max_steps": 200_000,
    "max_seconds": None,
    "burn_in": None,
    "thin": 1,
    "options": {},
}
#: [sampler] keys of earlier versions and where they went
_MOVED_SAMPLER_KEYS = {"proposal_scale": "[sampler.options] proposal_scale (mh) or "
                                         "move = {kind = ..., proposal_scale = ...} (fast)",
                       "move": "[sampler.options] move"}
#: Valid keys of each [parameters.<name>] table.
PARAMETER_KEYS = ("value", "lower", "upper", "vary", "prior")

_HOUR_TOL = 1e-6


class ConfigError(UserError, ValueError):
    """Invalid case configuration; the message names the file and the key."""


def _unknown(where: str, section: str, keys: Mapping, valid: tuple | list) -> None:
    for key in keys:
        if key not in valid:
            close = difflib.get_close_matches(str(key), list(valid), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise ConfigError(f"{where}: {section}unknown key {key!r}{hint}. Valid keys: {', '.join(valid)}")


def _is_number(x: object) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def _type_error(where: str, key: str, expected: str, value: object) -> ConfigError:
    return ConfigError(f"{where}: {key} must be {expected}, got {value!r}")


def _check(where: str, key: str, value: object, kind: str) -> None:
    ok = {
        "str": lambda v: isinstance(v, str),
        "bool": lambda v: isinstance(v, bool),
        "table": lambda v: isinstance(v, dict),
        "number": _is_number,
        "number>0": lambda v: _is_number(v) and math.isfinite(v) and v > 0,
        "number>=0": lambda v: _is_number(v) and math.isfinite(v) and v >= 0,
        "int>=0": lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 0,
        "int>0": lambda v: isinstance(v, int) and not isinstance(v, bool) and v > 0,
        "numbers": lambda v: isinstance(v, list) and all(_is_number(x) for x in v),
        "strs": lambda v: isinstance(v, list) and all(isinstance(x, str) for x in v),
    }[kind]
    expected = {
        "str": "a string",
        "bool": "true or false",
        "table": "a table",
        "number": "a number",
        "number>0": "a number > 0",
        "number>=0": "a number >= 0",
        "int>=0": "an integer >= 0",
        "int>0": "an integer > 0",
        "numbers": "a list of numbers",
        "strs": "a list of strings",
    }[kind]
    if not ok(value):
        raise _type_error(where, key, expected, value)


_DATA_TYPES = {
    "csv": "str",
    "truth": "str",
    "sigma": "number>0",
    "input_sigma": "number>=0",
    "T_air_sigma": "number>=0",
    "q_net_sigma": "number>=0",
    "q_net_rel_sigma": "number>=0",
    "observed_cm": "numbers",
    "bottom_cm": "number",
    "max_gap_fill": "int>=0",
    "plates": "bool",
    "plate_sigma": "number>0",
    "plate_rel_sigma": "number>=0",
    "columns": "table",
    "extras": "str",
    "ir_sigma": "number>0",
    "ir_storage_free": "bool",
    "dew_below_tmin": "number>=0",
    "preset": "str",
    "utc_offset_hours": "number",
    "timestamp": "str",
    "depths_cm": "table",
}
_GRID_TYPES = {"kind": "str", "dx": "number>0", "dt": "number>0", "dx_top": "number>0",
               "growth": "number>0", "dx_max": "number>0", "scheme": "str"}
_SAMPLER_TYPES = {
    "kind": "str",
    "seed": "int>=0",
    "n_walkers": "int>0",
    "ess_target": "number>0",
    "max_steps": "int>0",
    "max_seconds": "number>0",
    "burn_in": "int>=0",
    "thin": "int>0",
    "options": "table",
}


def _validate(raw: dict, where: str) -> None:
    _unknown(where, "", raw, SECTIONS)
    for key in ("name", "description"):
        if key in raw:
            _check(where, key, raw[key], "str")
    for key in ("data", "model", "grid", "parameters", "sampler"):
        if key in raw:
            _check(where, f"[{key}]", raw[key], "table")
    if "data" not in raw:
        raise ConfigError(f"{where}: missing [data] section (needs at least csv and sigma)")
    data = raw["data"]
    _unknown(where, "[data] ", data, DATA_KEYS)
    for key in ("csv", "sigma"):
        if key not in data:
            raise ConfigError(f"{where}: [data] is missing the required key {key!r}")
    for key, kind in _DATA_TYPES.items():
        if key in data:
            _check(where, f"data.{key}", data[key], kind)
    if "window_hours" in data:
        w = data["window_hours"]
        if not (isinstance(w, list) and len(w) == 2 and all(_is_number(x) for x in w)):
            raise _type_error(where, "data.window_hours", "[start, end] in hours", w)
    for src, role in data.get("columns", {}).items():
        _check(where, f"data.columns.{src}", role, "str")
    for src, depth in data.get("depths_cm", {}).items():
        _check(where, f"data.depths_cm.{src}", depth, "number")
    if ("utc_offset_hours" in data or "depths_cm" in data or "timestamp" in data) and "preset" not in data:
        raise ConfigError(f"{where}: data.utc_offset_hours, depths_cm and timestamp belong to a "
                          "flux-site preset: set data.preset (ameriflux or fluxnet)")

    grid = raw.get("grid", {})
    _unknown(where, "[grid] ", grid, tuple(GRID_DEFAULTS))
    if grid.get("kind", "auto") not in GRID_KINDS:
        raise ConfigError(f"{where}: grid.kind = {grid['kind']!r}; valid: {', '.join(GRID_KINDS)}")
    for key, kind in _GRID_TYPES.items():
        if key in grid:
            _check(where, f"grid.{key}", grid[key], kind)

    sampler = raw.get("sampler", {})
    for key, new in _MOVED_SAMPLER_KEYS.items():
        if key in sampler:
            raise ConfigError(f"{where}: [sampler] {key} is now set in {new}; the sampler "
                              "checks its own options")
    _unknown(where, "[sampler] ", sampler, tuple(SAMPLER_DEFAULTS))
    for key, kind in _SAMPLER_TYPES.items():
        if key in sampler:
            _check(where, f"sampler.{key}", sampler[key], kind)

    model = raw.get("model", {})
    if "top" in model and model["top"] not in TOPS:
        raise ConfigError(f"{where}: model.top = {model['top']!r}; valid: {', '.join(TOPS)}")
    if "material" in model:
        _check(where, "model.material", model["material"], "str")
    if "extensions" in model:
        _check(where, "model.extensions", model["extensions"], "strs")
    if "h" in model:
        h = model["h"]
        _check(where, "model.h", h, "table")
        _check(where, "model.h.kind", h.get("kind"), "str")
        if h["kind"] == "pieces":
            edges = h.get("edges_hours")
            if not (
                isinstance(edges, list)
                and len(edges) >= 2
                and all(_is_number(e) for e in edges)
                and all(b > a for a, b in zip(edges, edges[1:], strict=False))
            ):
                raise _type_error(
                    where, "model.h.edges_hours", "a strictly increasing list of >= 2 hours", edges
                )

    for name, par in raw.get("parameters", {}).items():
        key = f"parameters.{name}"
        _check(where, key, par, "table")
        _unknown(where, f"[{key}] ", par, PARAMETER_KEYS)
        for k in ("value", "lower", "upper"):
            if k in par:
                _check(where, f"{key}.{k}", par[k], "number")
        if "vary" in par:
            _check(where, f"{key}.vary", par["vary"], "bool")
        if "lower" in par and "upper" in par and not par["lower"] < par["upper"]:
            raise ConfigError(f"{where}: {key}: lower must be < upper, got {par}")
        if "prior" in par:
            _check(where, f"{key}.prior", par["prior"], "table")
            _check(where, f"{key}.prior.dist", par["prior"].get("dist"), "str")
    _check_json(raw, where, "")


def _check_json(value: object, where: str, key: str) -> None:
    """Refuse values JSON cannot store (TOML dates and times)."""
    if isinstance(value, dict):
        for k, v in value.items():
            _check_json(v, where, f"{key}.{k}" if key else str(k))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _check_json(v, where, f"{key}[{i}]")
    elif not (value is None or isinstance(value, str | int | float | bool)):
        raise ConfigError(f"{where}: {key} = {value!r}: dates and times are not supported in a case file")


def _check_h(h: dict | None, meas: Measurements, where: str) -> None:
    """Piecewise-constant h must cover the whole window."""
    if not h or h.get("kind") != "pieces":
        return
    edges = h["edges_hours"]
    span = float(meas.t[-1]) / 3600.0
    if edges[0] > _HOUR_TOL or edges[-1] < span - _HOUR_TOL:
        raise ConfigError(
            f"{where}: model.h.edges_hours {edges} does not cover the data window, 0 to {span:g} h"
        )
