"""The run folder's record of its case: ``case.toml`` (the case as run) and ``config.json`` (with
the stopping rule), and what a resume must find unchanged (:func:`identity`, :func:`store_meta`)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from ..data import dump_config
from .folder import RunFolder

#: [sampler] keys that may change between a run and its resume (budgets, not the chain)
BUDGET_KEYS = ("max_steps", "max_seconds", "ess_target")


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"cannot write {v!r} to TOML")


def _toml_key(k: str) -> str:
    bare = k.replace("_", "").replace("-", "").isalnum()
    return k if bare else json.dumps(k)


def to_toml(raw: dict) -> str:
    """A JSON-like config dict as TOML (top-level tables as sections, deeper ones inline)."""
    lines = [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in raw.items() if not isinstance(v, dict)]
    for k, v in raw.items():
        if isinstance(v, dict):
            lines += ["", f"[{_toml_key(k)}]"]
            lines += [f"{_toml_key(kk)} = {_toml_value(vv)}" for kk, vv in v.items()]
    return "\n".join(lines) + "\n"


def identity(cfg) -> dict:
    """The part of the config a resume must not change (budgets removed)."""
    raw = json.loads(json.dumps(cfg.raw))
    for k in BUDGET_KEYS:
        raw.get("sampler", {}).pop(k, None)
    raw.get("data", {}).pop("csv", None)
    raw.get("data", {}).pop("truth", None)
    raw.get("data", {}).pop("extras", None)
    return raw


def store_meta(cfg, kind: str) -> dict:
    return {"config_json": json.dumps(identity(cfg)), "data_hash": cfg.measurements.data_hash(),
            "sampler": kind}


def write_case_record(cfg, run_dir: Path, overrides: dict, additions: dict, rule) -> None:
    """The run folder's ``case.toml`` and ``config.json`` (with the overrides, additions and
    the :class:`~pavement_mcmc.diagnostics.StoppingRule` ``rule`` the run is held to)."""
    folder = RunFolder(run_dir)
    raw = json.loads(json.dumps(cfg.raw))
    raw["data"]["csv"] = str(cfg.csv_path)
    if cfg.truth_path is not None:
        raw["data"]["truth"] = str(cfg.truth_path)
    if getattr(cfg, "extras_path", None) is not None:
        raw["data"]["extras"] = str(cfg.extras_path)
    folder.case.write_text(
        f"# case as run, from {cfg.path}; data paths made absolute\n" + to_toml(raw))
    rec = json.loads(dump_config(cfg))
    rec["overrides"], rec["additions"], rec["rule"] = overrides, additions, rule.to_dict()
    folder.write_config(rec)
