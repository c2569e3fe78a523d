"""Resume a stored run: continue an unfinished one bit for bit; leave a finished one alone
unless asked for more (``more_steps``, ``ess_target``)."""

from __future__ import annotations

import json
from dataclasses import fields, replace
from pathlib import Path

import numpy as np

from ..data import RunError, RunNotFound, load_case, merge_overrides
from ..posterior import build_problem
from ..storage import HDF5Store, StoreWriteFailed
from .casefile import store_meta
from .fit import FitOutput, _finish, _run, _sampler_for, resume_hint
from .folder import RunFolder, case_rule
from .kept import keep
from .loop import RunResult
from .tables import plausibility, statistics_table, write_table
from .threads import single_blas_thread


def _record(folder: RunFolder) -> dict:
    """The run's config.json, or a :class:`~pavement_mcmc.data.RunNotFound` saying why not."""
    run_dir = folder.path
    if not run_dir.is_dir():
        what = "is a file, not a run directory" if run_dir.exists() else "no such run directory"
        raise RunNotFound(f"{run_dir}: {what} (a run directory is the --out of "
                          "'pavement-mcmc fit')")
    if not folder.started:
        raise RunNotFound(f"{run_dir}: nothing was written to this run directory yet (no "
                          f"{folder.config.name} or {folder.chain.name}); start it again with "
                          "'pavement-mcmc fit'")
    return folder.read_config()


def stored_result(run_dir: Path) -> RunResult | None:
    """The :class:`RunResult` recorded in ``result.json`` with the rule the run was held to
    (None while the run is unfinished or after it failed)."""
    folder = RunFolder(run_dir)
    rec = folder.read_result()
    if rec is None or rec.get("failed"):
        return None
    kw = {fl.name: rec[fl.name] for fl in fields(RunResult) if fl.name in rec}
    for k in ("ess", "tau", "rhat"):
        if k in kw:
            kw[k] = np.asarray(kw[k], float)
    kw["rule"] = folder.rule()
    return RunResult(**kw)


def _data_meta(cfg, stored_meta: dict) -> dict:
    """The store meta to compare with the stored run. The data hash covers sigma: a sigma
    change alone is a config change (listed as such), not a data change."""
    meta = {**store_meta(cfg, cfg.sampler["kind"]), "data_source": str(cfg.csv_path)}
    if meta["data_hash"] != stored_meta.get("data_hash"):
        old = json.loads(stored_meta.get("config_json", "{}")).get("data", {}).get("sigma")
        if old is not None:
            same = replace(cfg.measurements, sigma=float(old)).data_hash()
            if same == stored_meta.get("data_hash"):
                meta.pop("data_hash")
    return meta


@single_blas_thread()
def resume(run_dir: str | Path, *, max_seconds: float | None = None, callback=None,
           more_steps: int | None = None, ess_target: float | None = None) -> FitOutput:
    """Continue a stored run from its last saved block, bit for bit.

    The case is re-read from its original TOML (with the run's overrides); if that file is gone
    the run's own ``case.toml`` is used. A changed config (other than the budgets
    :data:`~pavement_mcmc.runs.casefile.BUDGET_KEYS`) or changed data is refused with
    :class:`~pavement_mcmc.storage.StoreMismatch` naming what changed (the data file by name).

    A finished run (``result.json`` says converged) is left alone and returned with
    ``ran=False``, unless ``more_steps`` (sample that many steps more, whatever the stopping
    rule says) or ``ess_target`` (a new target; recorded in the run's config.json) is given.
    When the chain grows, a ``report.html`` of the old chain is removed
    (``report_removed=True``; the command line writes it anew).
    """
    folder = RunFolder(run_dir)
    run_dir = folder.path
    rec = _record(folder)
    orig = Path(rec["toml_path"])
    src = orig if orig.exists() else folder.case
    overrides = rec.get("overrides") or {}
    if ess_target is not None:
        overrides = merge_overrides(overrides, {"sampler": {"ess_target": float(ess_target)}})
    cfg = load_case(src, overrides or None, additions=rec.get("additions") or None)
    try:
        folder.read_result()
        cut = False
    except RunError:  # a result.json cut short (written before they were atomic): the chain
        cut = True  # is the record; the rule is checked on it again below
    done = None if cut else stored_result(run_dir)
    store = HDF5Store.open_append(folder.chain)
    with store:
        store.check_compatible(_data_meta(cfg, store.meta))
        if cut:  # only once the chain opened whole
            folder.result.unlink()
        problem = build_problem(cfg, input_noise=store.meta.get("input_ref"))
        state = store.state
        if state is None:
            raise RunError(f"{run_dir}: the run has no saved block to resume from (it was "
                           "stopped before its first block); start it again with "
                           f"'pavement-mcmc fit ... --out {run_dir} --overwrite'")
        if done is not None and done.converged and more_steps is None and ess_target is None:
            return _unchanged(run_dir, problem, done)
        scfg = dict(cfg.sampler)
        n_done = int(state.extra.get("loop", {}).get("n_steps", 0))
        min_steps = 0
        if more_steps is not None:
            scfg["max_steps"] = min_steps = n_done + int(more_steps)
        elif n_done >= int(scfg["max_steps"]):
            raise RunError(f"{run_dir}: the run used its whole step budget ({n_done} steps) "
                           "without converging; ask for more with --more-steps N")
        smp = _sampler_for(problem, cfg)
        smp.set_state(state)
        # held to the rule stored with the run (a later change of the defaults re-judges none)
        rule = folder.rule(cfg.sampler)
        if ess_target is not None:  # the new target is the run's rule from now on (if killed,
            rec["overrides"] = overrides  # the next resume continues towards it)
            rec["rule"] = case_rule(scfg, rule).to_dict()
            folder.write_config(rec)
        removed = folder.report.exists()  # a report of the old chain would now mislead
        for stale in folder.outputs():  # they describe the old chain: until _finish writes
            stale.unlink(missing_ok=True)  # them anew the run is unfinished (if killed, too)
        try:
            res = _run(problem, smp, store, scfg, callback, max_seconds, min_steps, rule,
                       check_due=done is None)
        except StoreWriteFailed as err:
            raise resume_hint(err, run_dir) from None
    return replace(_finish(run_dir, problem, res, getattr(smp, "chosen", {})),
                   report_removed=removed)


def _unchanged(run_dir: Path, problem, res: RunResult) -> FitOutput:
    from ..storage import read_run

    folder = RunFolder(run_dir)
    data = read_run(folder.chain)
    table = statistics_table(problem, keep(data, folder.read_result(), problem.cfg.sampler))
    if not (folder.summary_csv.is_file() and folder.summary_md.is_file()):
        # killed between result.json and the summaries (before they were written first)
        write_table(table, run_dir, plausibility(problem, table), problem.model.boundary_note())
    return FitOutput(run_dir, res, table, problem, plausibility(problem, table), ran=False)
