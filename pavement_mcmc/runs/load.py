"""Reading a run folder back: its problem and kept chain (:func:`load_kept`, :func:`load_run`)
and a point estimate."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..data import RunError, RunNotFound, load_case
from ..posterior import Problem, build_problem
from ..storage import RunData, read_run
from .folder import RunFolder
from .kept import KeptChain, keep


def load_kept(run_dir: str | Path, burn_in: int | None = None) -> tuple[Problem, KeptChain]:
    """Rebuild a stored run's :class:`~pavement_mcmc.posterior.Problem` and read its kept chain.

    The one way a reader gets a run's draws: the burn-in is decided by
    :func:`~pavement_mcmc.runs.kept.keep` (``burn_in``: rows to discard, given by the caller).
    Nothing is optimised and no sampler runs: with noisy inputs the likelihood is linearised
    at the point stored with the run.

    Returns
    -------
    problem : built from the run's ``case.toml`` (the config as run).
    kept : :class:`~pavement_mcmc.runs.kept.KeptChain`; ``kept.run.meta`` additionally holds
        ``"result"`` (the result.json dict, or {} while the run is still being written) and
        ``"burn_in"`` (``kept.burn_in``).
    """
    folder = RunFolder(run_dir)
    if not folder.case.is_file():
        raise RunNotFound(f"{folder.path}: not a run directory (no case.toml); give the --out "
                          "folder of 'pavement-mcmc fit'")
    cfg = load_case(folder.case)
    data = read_run(folder.chain)
    stored = data.meta.get("data_hash")
    if stored and stored != cfg.measurements.data_hash():
        files = " or ".join(str(f) for f in (cfg.csv_path, cfg.extras_path) if f is not None)
        raise RunError(f"{folder.path}: the data changed since this run was fitted ({files} "
                       "is not what was sampled): restore it, or fit the case again")
    problem = build_problem(cfg, input_noise=data.meta.get("input_ref"))
    data.meta["result"] = folder.read_result() or {}
    kept = keep(data, data.meta["result"], cfg.sampler, burn_in)
    data.meta["burn_in"] = kept.burn_in
    return problem, kept


def load_run(run_dir: str | Path) -> tuple[Problem, RunData]:
    """:func:`load_kept`'s problem and the whole stored chain (``data.meta["burn_in"]``: the
    kept chain's burn-in)."""
    problem, kept = load_kept(run_dir)
    return problem, kept.run


def point_estimate(run_dir: str | Path, statistic: str = "mean") -> tuple[object, dict[str, float]]:
    """The problem of a stored run and its posterior mean (or median) over the kept chain.

    Uses :func:`load_kept`. Never re-runs a sampler.
    """
    problem, kept = load_kept(run_dir)
    flat = kept.get_chain(flat=True)
    est = np.median(flat, axis=0) if statistic == "median" else flat.mean(axis=0)
    vals = problem.space.value_dict()
    vals.update({n: float(v) for n, v in zip(kept.param_names, est, strict=True)})
    return problem, vals
