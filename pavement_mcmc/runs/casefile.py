"""The run folder's record of its case: ``case.toml`` (the case as run) and ``config.json`` (with
the stopping rule), and what a resume must find unchanged (:func:`identity`, :func:`store_meta`)."""

from __future__ import annotations

import json
from pathlib import Path

from ..data import dump_config
from ..data.toml_writer import to_toml
from ..storage import write_atomic
from .folder import RunFolder

#: [sampler] keys that may change between a run and its resume (budgets, not the chain)
BUDGET_KEYS = ("max_steps", "max_seconds", "ess_target")


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
    write_atomic(
        folder.case, f"# case as run, from {cfg.path}; data paths made absolute\n" + to_toml(raw))
    rec = json.loads(dump_config(cfg))
    rec["overrides"], rec["additions"], rec["rule"] = overrides, additions, rule.to_dict()
    folder.write_config(rec)
