"""Fit and resume orchestration: config -> problem -> sampler -> store, and the statistics table.

A run directory holds::

    chain.h5      the chain, log-posterior, RMSE blobs, acceptance and resume state (the storage package)
    case.toml     the case as run (overrides applied, data paths absolute): rebuilds the problem
    config.json   the config record (:func:`pavement_mcmc.config.dump_config`) + overrides
    result.json   the outcome: converged, reason, burn-in, ESS, R-hat, timings
    summary.csv   the statistics table (paper Tables 1-2 layout); summary.md the same in Markdown

Other modules read a finished run with :func:`load_run`; they never re-run a sampler.
"""

from __future__ import annotations

import csv
import json
import math
import secrets
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from . import diagnostics as dg
from .config import dump_config, load_case, merge_overrides
from .map import find_map
from .physics import LITERATURE
from .problem import Problem, build_problem
from .samplers import get_sampler
from .samplers.loop import RunResult, run_sampler
from .storage import HDF5Store, RunData, read_run

__all__ = ["FitOutput", "fit", "load_run", "resume", "statistics_table", "truth_values"]

#: [sampler] keys that may change between a run and its resume (budgets, not the chain)
BUDGET_KEYS = ("max_steps", "max_seconds", "ess_target")


@dataclass
class FitOutput:
    """What :func:`fit` and :func:`resume` return."""

    run_dir: Path
    result: RunResult
    table: list[dict]
    problem: Problem


# ----------------------------------------------------------------------------- config I/O


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


def _identity(cfg) -> dict:
    """The part of the config a resume must not change (budgets removed)."""
    raw = json.loads(json.dumps(cfg.raw))
    for k in BUDGET_KEYS:
        raw.get("sampler", {}).pop(k, None)
    raw.get("data", {}).pop("csv", None)
    raw.get("data", {}).pop("truth", None)
    return raw


def _meta(cfg, problem: Problem, kind: str) -> dict:
    return {"config_json": json.dumps(_identity(cfg)), "data_hash": cfg.measurements.data_hash(),
            "sampler": kind}


def _store_case(cfg, run_dir: Path, overrides: dict, additions: dict) -> None:
    raw = json.loads(json.dumps(cfg.raw))
    raw["data"]["csv"] = str(cfg.csv_path)
    if cfg.truth_path is not None:
        raw["data"]["truth"] = str(cfg.truth_path)
    (run_dir / "case.toml").write_text(
        f"# case as run, from {cfg.path}; data paths made absolute\n" + to_toml(raw))
    rec = json.loads(dump_config(cfg))
    rec["overrides"], rec["additions"] = overrides, additions
    (run_dir / "config.json").write_text(json.dumps(rec, indent=2))


# ----------------------------------------------------------------------------- fit / resume


def _sampler_for(problem: Problem, scfg: dict, laplace=None):
    kind = scfg["kind"]
    opts = {}
    if scfg.get("proposal_scale") is not None:
        opts["proposal_scale"] = float(scfg["proposal_scale"])
    if scfg.get("move") is not None:
        opts["move"] = str(scfg["move"])
    if laplace is not None:
        opts["laplace"] = laplace
    return get_sampler(kind, problem.posterior, n_chains=scfg.get("n_walkers"),
                       seed=scfg.get("seed"), **opts)


def _run(problem, sampler, store, scfg, progress, callback, max_seconds) -> RunResult:
    return run_sampler(
        sampler, store,
        ess_target=float(scfg["ess_target"]), max_steps=int(scfg["max_steps"]),
        max_seconds=max_seconds if max_seconds is not None else scfg.get("max_seconds"),
        burn_in=scfg.get("burn_in"), thin=int(scfg.get("thin") or 1),
        progress=progress, callback=callback,
    )


def fit(
    case: str | Path,
    out: str | Path,
    *,
    overwrite: bool = False,
    add: list[str] | None = None,
    set_values: dict[str, float] | None = None,
    overrides: dict | None = None,
    sampler: str | None = None,
    seed: int | None = None,
    max_seconds: float | None = None,
    ess_target: float | None = None,
    progress: bool = False,
    callback=None,
) -> FitOutput:
    """Fit a case TOML and write the run directory ``out``.

    Parameters
    ----------
    case : the case TOML.
    out : the run directory (created).
    overwrite : replace an existing run in ``out`` (else ``FileExistsError``).
    add : extension names to add to ``model.extensions``.
    set_values : ``{name: value}`` parameter values (``parameters.NAME.value``).
    overrides : further nested config overrides (as ``--set``-style dicts).
    sampler, seed, max_seconds, ess_target : override ``sampler.kind``, ``.seed``,
        ``.max_seconds``, ``.ess_target``.
    progress : tqdm progress bar on stderr. callback : called with a dict after every block.

    Returns
    -------
    FitOutput
    """
    ov: dict = dict(overrides or {})
    for name, value in (set_values or {}).items():
        ov = merge_overrides(ov, {"parameters": {name: {"value": float(value)}}})
    samp = {k: v for k, v in (("kind", sampler), ("seed", seed), ("max_seconds", max_seconds),
                                ("ess_target", ess_target)) if v is not None}
    if samp:
        ov = merge_overrides(ov, {"sampler": samp})
    adds = {"model": {"extensions": list(add)}} if add else {}
    cfg = load_case(case, ov or None, additions=adds or None)
    if cfg.sampler.get("seed") is None:  # record a seed so the run can be reproduced
        ov = merge_overrides(ov, {"sampler": {"seed": secrets.randbelow(2**31)}})
        cfg = load_case(case, ov, additions=adds or None)
    scfg = cfg.sampler
    out = Path(out)
    h5 = out / "chain.h5"
    if h5.exists() and not overwrite:
        raise FileExistsError(f"{out} already holds a run; pass --overwrite to replace it or "
                              f"'pavement-mcmc resume {out}' to continue it")
    problem = build_problem(cfg)
    smp = _sampler_for(problem, scfg)
    if smp.needs_laplace():
        smp.options["laplace"] = find_map(problem.posterior)
        smp.n_prep_evals += smp.options["laplace"].n_evals
    smp.prepare()
    out.mkdir(parents=True, exist_ok=True)
    _store_case(cfg, out, ov, adds)
    for stale in ("result.json", "summary.csv", "summary.md"):
        (out / stale).unlink(missing_ok=True)
    store = HDF5Store.create(h5, problem.space.free, problem.posterior.blob_names, smp.n_chains,
                             _meta(cfg, problem, scfg["kind"]), overwrite=True)
    with store:
        res = _run(problem, smp, store, scfg, progress, callback, None)
    return _finish(out, problem, res)


def resume(run_dir: str | Path, *, max_seconds: float | None = None, progress: bool = False,
           callback=None) -> FitOutput:
    """Continue a stored run from its last saved block, bit for bit.

    The case is re-read from its original TOML (with the run's overrides); if that file is gone
    the run's own ``case.toml`` is used. A changed config (other than the budgets
    :data:`BUDGET_KEYS`) or changed data is refused with
    :class:`~pavement_mcmc.storage.StoreMismatch` naming what changed.
    """
    run_dir = Path(run_dir)
    rec = json.loads((run_dir / "config.json").read_text())
    orig = Path(rec["toml_path"])
    src = orig if orig.exists() else run_dir / "case.toml"
    cfg = load_case(src, rec.get("overrides") or None, additions=rec.get("additions") or None)
    problem = build_problem(cfg)
    scfg = cfg.sampler
    store = HDF5Store.open_append(run_dir / "chain.h5")
    with store:
        store.check_compatible(_meta(cfg, problem, scfg["kind"]))
        state = store.state
        if state is None:
            raise ValueError(f"{run_dir}: the run has no saved block to resume from; fit it again")
        smp = _sampler_for(problem, scfg)
        smp.set_state(state)
        res = _run(problem, smp, store, scfg, progress, callback, max_seconds)
    return _finish(run_dir, problem, res)


def _finish(run_dir: Path, problem: Problem, res: RunResult) -> FitOutput:
    data = read_run(run_dir / "chain.h5")
    rec = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in asdict(res).items()}
    rec["param_names"] = data.param_names
    (run_dir / "result.json").write_text(json.dumps(rec, indent=2, default=float))
    table = statistics_table(problem, data, res.burn_in)
    write_table(table, run_dir)
    return FitOutput(run_dir, res, table, problem)


# ----------------------------------------------------------------------------- loading


def load_run(run_dir: str | Path) -> tuple[Problem, RunData]:
    """Rebuild a stored run's :class:`~pavement_mcmc.problem.Problem` and read its chain.

    Stable helper for report / diagnose / plots (they must never re-run a sampler).

    Returns
    -------
    problem : built from the run's ``case.toml`` (the config as run).
    data : :class:`~pavement_mcmc.storage.RunData`; ``data.meta`` additionally holds
        ``"burn_in"`` (stored rows to discard, int) and ``"result"`` (the result.json dict, or
        {} while the run is still being written).
    """
    run_dir = Path(run_dir)
    cfg = load_case(run_dir / "case.toml")
    problem = build_problem(cfg)
    data = read_run(run_dir / "chain.h5")
    result = {}
    if (run_dir / "result.json").exists():
        result = json.loads((run_dir / "result.json").read_text())
    data.meta["result"] = result
    if "burn_in" in result:
        data.meta["burn_in"] = int(result["burn_in"])
    else:
        data.meta["burn_in"] = data.n_saved // 2
    return problem, data


# ----------------------------------------------------------------------------- table


def truth_values(problem: Problem) -> dict[str, float]:
    """True parameter values of a twin case (kappa, C, and h pieces averaged from
    ``h_true_obs`` with the basis' overlap weights); {} without a truth file."""
    truth = getattr(problem.cfg, "truth", None)
    if not truth:
        return {}
    out = {k: float(truth[k]) for k in ("kappa", "C") if truth.get(k) is not None}
    h_obs = truth.get("h_true_obs")
    basis = problem.model.h_basis
    if h_obs is not None and not problem.model.replaces_h and len(h_obs) == problem.meas.n_obs:
        h_obs = np.asarray(h_obs, float)
        dt = np.diff(problem.meas.t)
        h_int = 0.5 * (h_obs[1:] + h_obs[:-1])
        w = basis.W * dt[:, None]
        pieces = (w.T @ h_int) / w.sum(axis=0)
        out.update({n: float(v) for n, v in zip(basis.names, pieces)})
    return out


def statistics_table(problem: Problem, data: RunData, burn_in: int) -> list[dict]:
    """One row per free parameter: unit, literature value, prior mean/sd, posterior mean, sd,
    2.5 % and 97.5 % quantiles, ESS, split-R-hat and the truth (twin data)."""
    kept = data.chain[burn_in:]
    if kept.shape[0] < 4:
        kept = data.chain[data.n_saved // 2:]
    try:
        summ = dg.summary(kept, data.param_names)
    except ValueError:  # too short for Geweke / R-hat: moments and quantiles only
        flat = kept.reshape(-1, kept.shape[2])
        q = np.percentile(flat, [2.5, 97.5], axis=0) if flat.size else np.full((2, flat.shape[1]), np.nan)
        summ = {n: {"mean": float(flat[:, i].mean()), "sd": float(flat[:, i].std(ddof=1)),
                    "q2.5": float(q[0, i]), "q97.5": float(q[1, i]), "ess": float("nan"),
                    "rhat": float("nan")} for i, n in enumerate(data.param_names)}
    truth = truth_values(problem)
    rows = []
    for name in data.param_names:
        p = problem.space[name]
        lit = LITERATURE.get("h" if p.group == "h" else name, float("nan"))
        try:
            pm, ps = float(p.prior.mean), float(p.prior.sd)
        except (NotImplementedError, TypeError):
            pm = ps = float("nan")
        s = summ[name]
        rows.append({
            "parameter": name, "unit": p.unit, "literature": lit, "prior_mean": pm,
            "prior_sd": ps, "mean": s["mean"], "sd": s["sd"], "q2.5": s["q2.5"],
            "q97.5": s["q97.5"], "ess": s["ess"], "rhat": s["rhat"],
            "truth": truth.get(name, float("nan")),
        })
    return rows


def write_table(rows: list[dict], run_dir: Path) -> None:
    """``summary.csv`` and ``summary.md`` in ``run_dir``."""
    if not rows:
        return
    keys = list(rows[0])
    with open(run_dir / "summary.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    (run_dir / "summary.md").write_text(format_table(rows) + "\n")


def format_table(rows: list[dict]) -> str:
    """The statistics table as Markdown (4 significant digits)."""
    keys = list(rows[0])

    def fmt(v):
        if isinstance(v, float):
            return "" if math.isnan(v) else f"{v:.4g}"
        return str(v)

    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(fmt(r[k]) for k in keys) + " |" for r in rows]
    return "\n".join(lines)
