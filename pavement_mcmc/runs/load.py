"""Reading a run folder back: its problem and chain (:func:`load_run`) and a point estimate."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..data import RunNotFound, load_case
from ..posterior import Problem, build_problem
from ..storage import RunData, read_run


def load_run(run_dir: str | Path) -> tuple[Problem, RunData]:
    """Rebuild a stored run's :class:`~pavement_mcmc.posterior.Problem` and read its chain.

    Stable helper for report / diagnose / plots (they must never re-run a sampler). Nothing is
    optimised: with noisy inputs the likelihood is linearised at the point stored with the run.

    Returns
    -------
    problem : built from the run's ``case.toml`` (the config as run).
    data : :class:`~pavement_mcmc.storage.RunData`; ``data.meta`` additionally holds
        ``"burn_in"`` (stored rows to discard, int) and ``"result"`` (the result.json dict, or
        {} while the run is still being written).
    """
    run_dir = Path(run_dir)
    if not (run_dir / "case.toml").is_file():
        raise RunNotFound(f"{run_dir}: not a run directory (no case.toml); give the --out folder "
                          "of 'pavement-mcmc fit'")
    cfg = load_case(run_dir / "case.toml")
    data = read_run(run_dir / "chain.h5")
    problem = build_problem(cfg, input_noise=data.meta.get("input_ref"))
    result = {}
    if (run_dir / "result.json").exists():
        result = json.loads((run_dir / "result.json").read_text())
    data.meta["result"] = result
    if "burn_in" in result:
        data.meta["burn_in"] = int(result["burn_in"])
    else:
        data.meta["burn_in"] = data.n_saved // 2
    return problem, data


def point_estimate(run_dir: str | Path, statistic: str = "mean") -> tuple[object, dict[str, float]]:
    """The problem of a stored run and its posterior mean (or median) after burn-in.

    Uses :func:`load_run`; the burn-in is the one stored with the run (else half the chain).
    Never re-runs a sampler.
    """
    problem, run = load_run(run_dir)
    chain = np.asarray(run.chain)
    burn = None
    for src in (run.meta, getattr(run.state, "extra", None) or {}):
        if isinstance(src, dict) and isinstance(src.get("burn_in"), int | float):
            burn = int(src["burn_in"])
    if burn is None or burn >= chain.shape[0]:
        burn = chain.shape[0] // 2
    flat = chain[burn:].reshape(-1, chain.shape[2])
    est = np.median(flat, axis=0) if statistic == "median" else flat.mean(axis=0)
    vals = problem.space.value_dict()
    vals.update({n: float(v) for n, v in zip(run.param_names, est, strict=True)})
    return problem, vals
