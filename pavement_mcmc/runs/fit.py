"""Fit: case config -> problem -> sampler -> store -> result and statistics table, written to
a run folder (:class:`~pavement_mcmc.runs.folder.RunFolder` lists its files).

Other modules read a run with :func:`pavement_mcmc.runs.load_kept` (or ``load_view``); they
never re-run a sampler.
"""

from __future__ import annotations

import secrets
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..data import ConfigError, RunExists, load_case, merge_overrides
from ..posterior import Problem, build_problem, find_map
from ..samplers import get_sampler
from ..storage import DISK_FULL, HDF5Store, StoreWriteFailed, read_run
from .casefile import store_meta, write_case_record
from .folder import RunFolder, case_rule
from .kept import keep
from .loop import RunResult, run_sampler
from .start import map_start, resolve_finer_h
from .tables import plausibility, statistics_table, write_table
from .threads import single_blas_thread


@dataclass
class FitOutput:
    """What :func:`fit` and :func:`resume` return."""

    run_dir: Path
    result: RunResult
    table: list[dict]
    problem: Problem
    findings: list = field(default_factory=list)
    #: False when :func:`~pavement_mcmc.runs.resume` found a finished run and sampled nothing
    ran: bool = True
    #: a report.html of the old chain was removed (the command line writes it anew)
    report_removed: bool = False
    #: the sampler's options it chose from the problem (``"auto"`` ones) and why; {} if none
    chosen: dict = field(default_factory=dict)
    #: the solver grid ``[grid] kind = "auto"`` chose from the case and why; {} if set by hand
    grid_chosen: dict = field(default_factory=dict)


def _sampler_for(problem: Problem, cfg):
    """The case's sampler with its typed ``[sampler.options]``; a bad option is a config error
    naming the case file."""
    scfg = cfg.sampler
    try:
        return get_sampler(scfg["kind"], problem.posterior, n_chains=scfg.get("n_walkers"),
                           seed=scfg.get("seed"), options=scfg.get("options") or None)
    except ValueError as err:
        raise ConfigError(f"{cfg.path}: {err}") from None


def _run(problem, sampler, store, scfg, callback, max_seconds,
         min_steps: int = 0, base_rule=None, check_due: bool = True) -> RunResult:
    """Run the loop; ``base_rule``: the rule stored with a resumed run (its ESS target is the
    case's as resumed), default :class:`~pavement_mcmc.diagnostics.StoppingRule`'s defaults."""
    return run_sampler(
        sampler, store,
        rule=case_rule(scfg, base_rule), max_steps=int(scfg["max_steps"]),
        max_seconds=max_seconds if max_seconds is not None else scfg.get("max_seconds"),
        burn_in=scfg.get("burn_in"), thin=int(scfg.get("thin") or 1),
        callback=callback, min_steps=min_steps, check_due=check_due,
    )


@single_blas_thread()
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
    callback=None,
) -> FitOutput:
    """Fit a case TOML and write the run directory ``out``.

    Parameters
    ----------
    case : the case TOML.
    out : the run directory (created).
    overwrite : replace an existing run in ``out`` (else :class:`~pavement_mcmc.data.RunExists`).
    add : extension names to add to ``model.extensions``.
    set_values : ``{name: value}`` parameter values (``parameters.NAME.value``).
    overrides : further nested config overrides (as ``--set``-style dicts).
    sampler, seed, max_seconds, ess_target : override ``sampler.kind``, ``.seed``,
        ``.max_seconds``, ``.ess_target``.
    callback : called with a dict after every block (steps, min ESS / target, phase; the
        command line draws its progress from it).

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
    ov, add = resolve_finer_h(case, ov, list(add or []))
    adds = {"model": {"extensions": list(add)}} if add else {}
    cfg = load_case(case, ov or None, additions=adds or None)
    if cfg.sampler.get("seed") is None:  # record a seed so the run can be reproduced
        ov = merge_overrides(ov, {"sampler": {"seed": secrets.randbelow(2**31)}})
        cfg = load_case(case, ov, additions=adds or None)
    scfg = cfg.sampler
    folder = RunFolder(out)
    out = folder.path
    if folder.chain.exists() and not overwrite:
        raise RunExists(f"{out} already holds a run; pass --overwrite to replace it or "
                              f"'pavement-mcmc resume {out}' to continue it")
    if out.is_dir() and any(out.iterdir()) and not (folder.chain.exists() or folder.config.exists()):
        raise RunExists(f"{out} is a folder of other files, not a run: give a new or empty "
                        "folder to --out (a run writes chain.h5, summary.md, ... into it)")
    problem = build_problem(cfg)
    smp = _sampler_for(problem, cfg)
    laplace = map_start(problem, cfg, list(add or []))  # new parameters start from a MAP
    theta0 = None if laplace is None else laplace.theta
    if laplace is None and smp.needs_laplace():
        laplace = find_map(problem.posterior)
    if laplace is not None:
        smp.n_prep_evals += laplace.n_evals
    smp.prepare(theta0=theta0, laplace=laplace if smp.needs_laplace() else None)
    out.mkdir(parents=True, exist_ok=True)
    write_case_record(cfg, out, ov, adds, case_rule(scfg))
    for stale in folder.outputs():
        stale.unlink(missing_ok=True)
    meta = {**store_meta(cfg, scfg["kind"]), "input_ref": problem.input_ref}
    store = HDF5Store.create(folder.chain, problem.space.free, problem.posterior.blob_names, smp.n_chains,
                             meta, overwrite=True)
    with store:
        try:
            res = _run(problem, smp, store, scfg, callback, None)
        except Exception as err:  # the run says it failed (KeyboardInterrupt: resumable)
            _failed(out, err)
            if isinstance(err, StoreWriteFailed):
                raise resume_hint(err, out) from None
            raise
    return _finish(out, problem, res, getattr(smp, "chosen", {}))


def _failed(run_dir: Path, err: BaseException) -> None:
    """Mark a run that stopped on an error: result.json says ``failed`` and why (unless the
    disk is too full for that too: the chain's last commit is what counts)."""
    rec = {"failed": True, "converged": False, "reason": f"failed: {type(err).__name__}: {err}"}
    folder = RunFolder(run_dir)
    try:
        folder.write_result(rec)
    except OSError:
        folder.result.unlink(missing_ok=True)


def resume_hint(err: StoreWriteFailed, run_dir: Path) -> StoreWriteFailed:
    """``err`` with what to do next: free space, then resume the run folder (or start it again
    when not one block was committed)."""
    todo = (f"free space, then 'pavement-mcmc resume {run_dir}'" if err.n_saved else
            f"free space, then start it again ('pavement-mcmc fit ... --out {run_dir} --overwrite')")
    return StoreWriteFailed(f"{err}; {todo}",
                            path=err.path, reason=err.reason, n_saved=err.n_saved,
                            n_steps=err.n_steps, bytes_per_step=err.bytes_per_step)


def _finish(run_dir: Path, problem: Problem, res: RunResult, chosen: dict | None = None) -> FitOutput:
    folder = RunFolder(run_dir)
    data = read_run(folder.chain)
    rec = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in asdict(res).items()}
    rec["param_names"] = data.param_names
    if chosen:
        rec["sampler_chosen"] = chosen
    if problem.grid_chosen:
        rec["grid_chosen"] = problem.grid_chosen
    table = statistics_table(problem, keep(data, rec, problem.cfg.sampler))
    findings = plausibility(problem, table)
    try:  # the summaries first: a run with result.json is finished, one without is resumed
        write_table(table, run_dir, findings, problem.model.boundary_note())
        folder.write_result(rec)
    except OSError as err:
        if err.errno not in DISK_FULL:
            raise
        raise StoreWriteFailed(f"{run_dir}: the chain is whole ({data.n_saved} rows), but writing "
                               f"{Path(err.filename).name if err.filename else 'a file'}"
                               f" failed ({err.strerror}); free space, then 'pavement-mcmc "
                               f"resume {run_dir}'", path=str(folder.chain), reason=err.strerror,
                               n_saved=data.n_saved) from None
    return FitOutput(run_dir, res, table, problem, findings, chosen=dict(chosen or {}),
                     grid_chosen=dict(problem.grid_chosen or {}))
