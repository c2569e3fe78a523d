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
    plates = true                   # optional: observe the G_<d>cm heat-flux plates (if any)
    plate_sigma = 2.0               # optional, W m-2: sd of a plate reading's random error
    plate_rel_sigma = 0.1           # optional: plus this share of the reading
    extras = "extras.csv"           # optional: a second CSV merged on time (T_surf_IR, RH,
                                    # SW_in, SW_out, LW_in, LW_out: data/extras.py)
    ir_sigma = 0.5                  # optional, degC: observe T_surf_IR with this sd and an
                                    # offset parameter ir_offset (posterior/surface_ir.py)
    ir_storage_free = false         # optional: under a canopy the IR reads a surface without
                                    # heat storage, leading the canopy node by its relaxation
                                    # time c_canopy / K (posterior/surface_ir.py)
    dew_below_tmin = 0.0            # optional, K: no humidity measured; the dew point T_dew is
                                    # the 24 h minimum air temperature less this (FAO-56;
                                    # 2-4 over arid ground; data/humidity.py)
    preset = "ameriflux"            # optional: an AmeriFlux / FLUXNET file as it is, with
    utc_offset_hours = -7           #   its local standard time, the sample time of an
    timestamp = "middle"            #   interval and the soil columns' depths (data/fluxsite.py)
    depths_cm = { TS_1_1_1 = 5, G_1_1_1 = 8 }
    [data.columns]                  # optional renames: file column -> contract role
    "Tair" = "T_air"
    [model]                         # free-form; `h` and `extensions` are type-checked
    h = { kind = "pieces", edges_hours = [0, 6, 18, 28] }   # or { kind = "per_interval" }
    top = "surface"                 # or "measured": the shallowest sensor is the top boundary
    material = "loam"               # optional: plausibility notes against this material
    extensions = []
    [grid]                          # keys and defaults: GRID_DEFAULTS
    kind = "auto"                   # uniform (dx, dt) down to 10 cm, stretched below (dx_top,
                                    # growth, dx_max, dt; nodes at the sensors and plates)
    [parameters.<name>]             # keys: PARAMETER_KEYS (value, lower, upper, vary, prior)
    prior = { dist = "truncnormal", mean = 2.27, sd = 0.1135 }
    [sampler]                       # keys and defaults: SAMPLER_DEFAULTS
    [sampler.options]               # the sampler's own typed options (checked by the sampler),
    move = "block"                  #   e.g. fast: move; hmc: trajectory_length, metric_at, ...

Parameter names, extension names, prior distributions, h kinds, solver schemes and sampler kinds
are kept but not checked here: the modules that own them check them.
"""

from __future__ import annotations

import copy
import json
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .humidity import with_dew_from_tmin
from .measurements import Measurements
from .reader import read_csv_case
from .record import record_air_temperature, record_stamps
from .schema import GRID_DEFAULTS, SAMPLER_DEFAULTS, ConfigError, _check_h, _validate
from .times import format_time

__all__ = ["CaseConfig", "dump_config", "load_case", "merge_overrides", "parse_set"]


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
    csv_path, truth_path, extras_path : resolved absolute paths of the data files.
    """

    name: str
    path: Path
    raw: dict
    measurements: Measurements
    truth: dict | None
    csv_path: Path
    truth_path: Path | None = None
    extras_path: Path | None = None

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


#: the [data] keys of a flux-site preset's options (data/fluxsite.py)
PRESET_KEYS = ("utc_offset_hours", "depths_cm", "timestamp")


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
    except IsADirectoryError:
        raise ConfigError(f"{path}: a directory, not a case TOML (a run directory is read by "
                          "diagnose, compare and report, not here)") from None
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
    extras_path = _existing(base, data["extras"], where, "extras") if "extras" in data else None
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
            extras=extras_path,
            preset=data.get("preset"),
            preset_options={k: data[k] for k in PRESET_KEYS if k in data},
            forcing_optional=raw.get("model", {}).get("top") == "measured",
        )
        if "dew_below_tmin" in data:  # FAO-56: the dew point from the daily minimum
            meas = with_dew_from_tmin(meas, data["dew_below_tmin"], *record_air_temperature(
                csv_path, data.get("columns"), data.get("preset"),
                {k: data[k] for k in PRESET_KEYS if k in data}, extras_path))
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
        extras_path=extras_path,
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


def record_times(case: str | Path) -> list[str]:
    """The ISO UTC times of every row of the case's CSV (the whole record, whatever its
    window), its time column read as the case reads it (renames, a flux-site preset)."""
    cfg = load_case(case)
    data = cfg.data
    stamps = record_stamps(cfg.csv_path, data.get("columns"), data.get("preset"),
                           {k: data[k] for k in PRESET_KEYS if k in data}, cfg.extras_path)
    return [format_time(float(x)) for x in stamps]


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
