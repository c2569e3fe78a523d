"""Load a case TOML (the CSV, sigma, h(t) discretisation, grid, priors, sampler) into a
:class:`CaseConfig`.

Schema (paths are relative to the TOML file's directory)::

    name = "caseA"                  # default: the file's stem
    description = "..."             # default: ""
    [data]                          # keys: DATA_KEYS
    csv = "../data/reference_case/measurements.csv"   # required
    truth = "../data/reference_case/truth.json"       # optional
    sigma = 0.25                    # required, degC
    input_sigma = 0.25              # optional, degC: noise of the bottom boundary and initial
                                    # temperatures, integrated out (default 0: exact, the paper)
    T_air_sigma = 0.05              # optional, degC: noise of the air temperature (default 0)
    q_net_sigma = 2.0               # optional, W m-2: noise of the net radiation (default 0)
    q_net_rel_sigma = 0.01          # optional: plus this fraction of the reading (default 0)
    window_hours = [0, 28]          # optional, hours after the first row
    observed_cm = [0, 1, 2, 3, 4]   # optional, default: every sensor above the bottom
    bottom_cm = 5                   # optional, default: the deepest sensor
    max_gap_fill = 0                # optional
    [data.columns]                  # optional renames: file column -> contract role
    "Tair" = "T_air"
    [model]                         # free-form; `h` and `extensions` are type-checked
    h = { kind = "pieces", edges_hours = [0, 6, 18, 28] }   # or { kind = "per_interval" }
    extensions = []
    [grid]                          # keys and defaults: GRID_DEFAULTS
    [parameters.<name>]             # keys: PARAMETER_KEYS (value, lower, upper, vary, prior)
    prior = { dist = "truncnormal", mean = 2.27, sd = 0.1135 }
    [sampler]                       # keys and defaults: SAMPLER_DEFAULTS

Parameter names, extension names, prior distributions, h kinds, solver schemes and sampler kinds
are kept but not checked here: the modules that own them check them.
"""

from __future__ import annotations

import copy
import difflib
import json
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pavement_mcmc.data import read_csv_case
from pavement_mcmc.measurements import Measurements

__all__ = [
    "DATA_KEYS",
    "GRID_DEFAULTS",
    "PARAMETER_KEYS",
    "SAMPLER_DEFAULTS",
    "SECTIONS",
    "CaseConfig",
    "ConfigError",
    "dump_config",
    "load_case",
    "merge_overrides",
    "parse_set",
]

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
)
#: Valid keys of [grid] and their defaults (dx in m, dt in s; None = the solver's measured default).
GRID_DEFAULTS: dict[str, Any] = {"dx": None, "dt": None, "scheme": "cn"}
#: Valid keys of [sampler] and their defaults (None: the sampler chooses).
SAMPLER_DEFAULTS: dict[str, Any] = {
    "kind": "emcee",
    "seed": None,
    "n_walkers": None,
    "ess_target": 1000,
    "max_steps": 200_000,
    "max_seconds": None,
    "burn_in": None,
    "thin": 1,
    "proposal_scale": None,
    "move": None,
}
#: Valid keys of each [parameters.<name>] table.
PARAMETER_KEYS = ("value", "lower", "upper", "vary", "prior")

_HOUR_TOL = 1e-6


class ConfigError(ValueError):
    """Invalid case configuration; the message names the file and the key."""


@dataclass(frozen=True)
class CaseConfig:
    """A loaded, validated case.

    Attributes
    ----------
    name : case name.
    path : the TOML file (absolute).
    raw : the parsed TOML after overrides (JSON-serialisable, paths as written).
    measurements : the validated data.
    truth : the parsed truth JSON, or None.
    csv_path, truth_path : resolved absolute paths of the data files.
    """

    name: str
    path: Path
    raw: dict
    measurements: Measurements
    truth: dict | None
    csv_path: Path
    truth_path: Path | None = None

    @property
    def description(self) -> str:
        return str(self.raw.get("description", ""))

    @property
    def data(self) -> dict:
        """The [data] section as written (a copy)."""
        return copy.deepcopy(self.raw["data"])

    @property
    def model(self) -> dict:
        """[model] with defaults: ``extensions = []``, ``h`` one piece over the whole window."""
        out = copy.deepcopy(self.raw.get("model", {}))
        out.setdefault("extensions", [])
        out.setdefault("h", {"kind": "pieces", "edges_hours": [0.0, float(self.measurements.t[-1]) / 3600.0]})
        return out

    @property
    def grid(self) -> dict:
        """[grid] with defaults from :data:`GRID_DEFAULTS`."""
        return {**GRID_DEFAULTS, **copy.deepcopy(self.raw.get("grid", {}))}

    @property
    def parameters(self) -> dict:
        """[parameters]: ``{name: {value?, lower?, upper?, vary?, prior?}}`` (a copy)."""
        return copy.deepcopy(self.raw.get("parameters", {}))

    @property
    def sampler(self) -> dict:
        """[sampler] with defaults from :data:`SAMPLER_DEFAULTS`."""
        return {**SAMPLER_DEFAULTS, **copy.deepcopy(self.raw.get("sampler", {}))}


def load_case(
    path: str | Path,
    overrides: Mapping[str, Any] | None = None,
    *,
    additions: Mapping[str, Any] | None = None,
) -> CaseConfig:
    """Load, validate and read a case TOML.

    Parameters
    ----------
    path : str or Path
        The TOML file.
    overrides : mapping, optional
        Nested dict merged over the TOML (``--set``): tables merge, other values replace.
    additions : mapping, optional
        Nested dict merged after `overrides` with lists appended instead of replaced (``--add``,
        e.g. ``{"model": {"extensions": ["two_layer"]}}``).

    Returns
    -------
    CaseConfig

    Raises
    ------
    ConfigError
        For a missing or malformed TOML, unknown keys, wrong types or missing data files.
    DataError
        From :func:`~pavement_mcmc.data.read_csv_case` when the CSV is invalid (with a note
        naming the TOML).
    """
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            raw = tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{path}: case file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: invalid TOML: {exc}") from None
    if overrides:
        raw = merge_overrides(raw, overrides)
    if additions:
        raw = merge_overrides(raw, additions, append=True)
    where = f"{path}" + (" (after overrides)" if overrides or additions else "")
    _validate(raw, where)

    base = path.resolve().parent
    data = raw["data"]
    csv_path = _existing(base, data["csv"], where, "csv")
    truth_path = _existing(base, data["truth"], where, "truth") if "truth" in data else None
    truth = _read_truth(truth_path, where) if truth_path else None
    window = data.get("window_hours")
    try:
        meas = read_csv_case(
            csv_path,
            sigma=data["sigma"],
            columns=data.get("columns"),
            observed=data.get("observed_cm"),
            bottom=data.get("bottom_cm"),
            window_hours=tuple(window) if window is not None else None,
            max_gap_fill=data.get("max_gap_fill", 0),
        )
    except ValueError as exc:
        exc.add_note(f"while loading the [data] section of {where}")
        raise
    _check_h(raw.get("model", {}).get("h"), meas, where)
    return CaseConfig(
        name=raw.get("name", path.stem),
        path=path.resolve(),
        raw=raw,
        measurements=meas,
        truth=truth,
        csv_path=csv_path,
        truth_path=truth_path,
    )


def merge_overrides(base: Mapping[str, Any], overrides: Mapping[str, Any], *, append: bool = False) -> dict:
    """Return a deep copy of `base` with `overrides` merged in.

    Parameters
    ----------
    base, overrides : mapping
        Nested dicts. Where both hold a dict, they merge recursively; otherwise the override
        replaces the base value.
    append : bool, default False
        If True, where both hold a list the override's items are appended (items already present
        are not repeated).

    Returns
    -------
    dict
    """
    out = copy.deepcopy(dict(base))
    for key, value in overrides.items():
        old = out.get(key)
        if isinstance(old, Mapping) and isinstance(value, Mapping):
            out[key] = merge_overrides(old, value, append=append)
        elif append and isinstance(old, list) and isinstance(value, list):
            out[key] = old + [copy.deepcopy(v) for v in value if v not in old]
        else:
            out[key] = copy.deepcopy(value)
    return out


def parse_set(assignment: str) -> dict:
    """Parse a ``--set`` assignment such as ``grid.dx=0.0025`` into a nested dict.

    The key is a TOML dotted key (quote parts holding dots: ``data.columns."T_2.5cm"``); the
    value is a TOML value (``3``, ``0.1``, ``true``, ``[0, 28]``, ``{dist = "normal", ...}``),
    or a bare string when it does not parse as one (``sampler.kind=mh``).

    Raises
    ------
    ConfigError
        If there is no ``=`` or the key is not a valid TOML key.
    """
    if "=" not in assignment:
        raise ConfigError(f"--set {assignment!r}: expected KEY=VALUE, e.g. grid.dx=0.0025")
    key, value = (s.strip() for s in assignment.split("=", 1))
    for text in (f"{key} = {value}", f"{key} = {json.dumps(value)}"):
        try:
            return tomllib.loads(text)
        except tomllib.TOMLDecodeError:
            continue
    raise ConfigError(f"--set {assignment!r}: {key!r} is not a valid dotted key")


def dump_config(cfg: CaseConfig) -> str:
    """JSON record of a loaded case, to store with a run.

    Holds the case name, the TOML path, the resolved data paths, the data hash, the config as
    written (``config``) and every section with its defaults filled (``resolved``).
    """
    record = {
        "name": cfg.name,
        "toml_path": str(cfg.path),
        "csv_path": str(cfg.csv_path),
        "truth_path": None if cfg.truth_path is None else str(cfg.truth_path),
        "data_hash": cfg.measurements.data_hash(),
        "config": cfg.raw,
        "resolved": {
            "model": cfg.model,
            "grid": cfg.grid,
            "parameters": cfg.parameters,
            "sampler": cfg.sampler,
        },
    }
    return json.dumps(record, indent=2)


# --------------------------------------------------------------------------- validation


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
    "columns": "table",
}
_GRID_TYPES = {"dx": "number>0", "dt": "number>0", "scheme": "str"}
_SAMPLER_TYPES = {
    "kind": "str",
    "seed": "int>=0",
    "n_walkers": "int>0",
    "ess_target": "number>0",
    "max_steps": "int>0",
    "max_seconds": "number>0",
    "burn_in": "int>=0",
    "thin": "int>0",
    "proposal_scale": "number>0",
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

    grid = raw.get("grid", {})
    _unknown(where, "[grid] ", grid, tuple(GRID_DEFAULTS))
    for key, kind in _GRID_TYPES.items():
        if key in grid:
            _check(where, f"grid.{key}", grid[key], kind)

    sampler = raw.get("sampler", {})
    _unknown(where, "[sampler] ", sampler, tuple(SAMPLER_DEFAULTS))
    for key, kind in _SAMPLER_TYPES.items():
        if key in sampler:
            _check(where, f"sampler.{key}", sampler[key], kind)

    model = raw.get("model", {})
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


def _existing(base: Path, rel: str, where: str, key: str) -> Path:
    p = (base / Path(rel).expanduser()).resolve()
    if not p.is_file():
        raise ConfigError(f"{where}: data.{key} = {rel!r}: file not found (tried {p})")
    return p


def _read_truth(path: Path, where: str) -> dict:
    try:
        truth = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ConfigError(f"{where}: data.truth: cannot read {path} as JSON ({exc})") from None
    if not isinstance(truth, dict):
        raise ConfigError(f"{where}: data.truth: {path} must hold a JSON object")
    return truth


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
