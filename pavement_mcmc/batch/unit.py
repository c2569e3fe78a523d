"""One unit of a batch, run on a worker: an ordinary run folder, fitted, resumed or read back.

:func:`run_unit` makes ``OUT/<unit key>/`` with the existing :func:`~pavement_mcmc.runs.fit`
(so ``report``, ``diagnose``, ``resume`` ... work on it), and reduces it to one table row
(:func:`unit_row`). It is idempotent, which is what makes a batch lose nothing:

* ``unit.json`` present: the unit finished earlier; its row is returned, nothing recomputed
  (unless ``result.json`` is newer: the run was continued with ``resume``; the row is re-read);
* ``chain.h5`` with a saved block but no ``unit.json``: the unit was killed (or its run failed
  on an error Dask retries); it is continued with :func:`~pavement_mcmc.runs.resume`, bit for
  bit;
* a ``chain.h5`` that is damaged (:class:`~pavement_mcmc.storage.StoreDamaged`) is not read:
  the unit is fitted again (same seed, same chain);
* otherwise it is fitted from scratch with the seed :func:`~.units.unit_seed` gives its key.

The row is always computed from the stored chain, so a unit that was interrupted and resumed
gives the same row, bit for bit, as one that ran straight through. A unit whose chain another
live process is still writing (a worker orphaned by a lost scheduler finishing it) is waited
for, not written twice. ``unit.json`` also records the unit's wall time, the worker process's
CPU time (``cpu_s``: a unit's cost on a loaded machine, where wall time also counts waiting for
a core) and the worker's own peak resident memory while it ran (``peak_rss_mb``: the
high-water mark reset at the unit's start, so neither an earlier unit nor the process the
worker was forked from counts). Errors a user can fix
(bad window, bad config, missing data) come back as a row with ``status = "failed"`` and the
reason; anything else propagates to Dask, which retries it.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import numpy as np

from ..data import ConfigError, DataError
from ..runs import RunFolder, fit, load_kept, resume
from ..runs.tables import plausibility, statistics_table
from ..storage import StoreBusy, StoreMismatch, write_atomic
from .units import Unit, unit_seed

#: the columns of the batch table, in order (units: kappa W m-1 K-1, C J m-3 K-1, kappa/C m2 s-1,
#: h W m-2 K-1, rmse degC; *_lo / *_hi are the 2.5 % and 97.5 % posterior quantiles)
COLUMNS = ("key", "site", "start_time", "start_h", "end_h", "status",
           "kappa", "kappa_lo", "kappa_hi", "C", "C_lo", "C_hi",
           "diffusivity", "diffusivity_lo", "diffusivity_hi", "h_mean", "h_mean_lo", "h_mean_hi",
           "converged", "n_steps", "min_ess", "max_rhat", "rmse", "verdict", "reason", "run_dir")
#: errors that are the unit's own (recorded, not retried)
UNIT_ERRORS = (ConfigError, DataError, StoreMismatch, FileNotFoundError, ValueError)
#: the "no time budget" of a batch unit, s (the config wants a number)
NO_BUDGET = 1e9
#: draws used for the derived quantities (kappa/C, mean h): evenly spaced over the kept chain
N_DERIVED = 400
#: how long a unit waits for another live process that is still writing its chain, s
BUSY_WAIT = 3600.0


def run_unit(unit: Unit, out: str | Path, batch_seed: int = 0, *, max_seconds: float | None = None,
             counter: str | Path | None = None) -> dict:
    """Fit, resume or read back one unit's run folder ``out/<key>`` and return its row.

    ``max_seconds``: a wall-time budget per unit (None: steps only, the default; a time budget
    makes where a chain stops depend on the machine). ``counter``: a file to which a line is
    appended whenever this function starts sampling (tests count recomputations with it).
    """
    folder = RunFolder(Path(out) / _folder(unit.key))
    run_dir, done = folder.path, folder.unit
    if _finished(run_dir):
        return json.loads(done.read_text())
    # else: not finished, or continued since with `pavement-mcmc resume` (the row is re-read)
    row = {"key": unit.key, "site": unit.site, "start_time": unit.start_time,
           "start_h": unit.window_hours[0] if unit.window_hours else float("nan"),
           "end_h": unit.window_hours[1] if unit.window_hours else float("nan"),
           "run_dir": run_dir.name}  # relative to the batch folder: tables compare across folders
    t0, cpu0 = time.perf_counter(), time.process_time()
    _reset_peak_rss()
    try:
        if counter is not None:
            with open(counter, "a") as fh:
                fh.write(f"{unit.key} {os.getpid()}\n")
        if not _sample_when_free(unit, run_dir, batch_seed, max_seconds):
            return json.loads(done.read_text())  # the other writer finished the unit
        row.update(unit_row(run_dir))
    except UNIT_ERRORS as err:
        row.update(status="failed", reason=f"{type(err).__name__}: {err}")
    row = {c: row.get(c, _EMPTY.get(c, float("nan"))) for c in COLUMNS}
    run_dir.mkdir(parents=True, exist_ok=True)
    record = {**row, "elapsed_s": time.perf_counter() - t0,
              "cpu_s": time.process_time() - cpu0, "peak_rss_mb": _peak_rss_mb()}
    write_atomic(done, json.dumps(record, indent=1))  # a unit is finished exactly when unit.json exists
    return record


_EMPTY = {"status": "failed", "verdict": "", "reason": "", "converged": False, "start_time": ""}


def _finished(run_dir: Path) -> bool:
    """``unit.json`` is there and no resume has grown the run since it was written."""
    folder = RunFolder(run_dir)
    done, result = folder.unit, folder.result
    return done.exists() and not (result.exists() and result.stat().st_mtime > done.stat().st_mtime)


def _sample_when_free(unit: Unit, run_dir: Path, batch_seed: int, max_seconds) -> bool:
    """:func:`_sample`, waiting while another live process writes this unit's chain; False if
    that process finished the unit meanwhile."""
    t0 = time.monotonic()
    while True:
        try:
            _sample(unit, run_dir, batch_seed, max_seconds)
            return True
        except StoreBusy:
            if time.monotonic() - t0 > BUSY_WAIT:
                raise
            time.sleep(0.5)
            if _finished(run_dir):
                return False


def _folder(key: str) -> str:
    return "".join(c if c.isalnum() or c in "-_.@" else "_" for c in key)


def _sample(unit: Unit, run_dir: Path, batch_seed: int, max_seconds) -> None:
    whole = _resumable(run_dir)  # False for a chain file that is missing or damaged
    if whole and RunFolder(run_dir).finished:
        return  # sampled, killed while writing unit.json: the chain is complete
    # failed (an error Dask retries) or unfinished: continue it, else fit it again
    if whole:
        try:
            resume(run_dir, max_seconds=max_seconds)
            return
        except (StoreMismatch, OSError, KeyError, ValueError):
            pass  # a half-written file: start again (same seed, same chain)
    ov = unit.config_overrides(unit_seed(batch_seed, unit.key))
    # no time budget unless asked for: where a chain stops must not depend on the machine
    ov.setdefault("sampler", {})["max_seconds"] = float(max_seconds or NO_BUDGET)
    fit(unit.case, run_dir, overwrite=True, overrides=ov)


def _resumable(run_dir: Path) -> bool:
    folder = RunFolder(run_dir)
    if not folder.started:
        return False
    from ..storage import read_run

    try:
        return read_run(folder.chain).state is not None
    except (OSError, KeyError, ValueError):
        return False


def unit_row(run_dir: str | Path) -> dict:
    """The batch-table figures of a stored run (never re-runs a sampler)."""
    problem, kept = load_kept(run_dir)
    data = kept.run
    res = data.meta["result"]
    table = statistics_table(problem, kept)
    flat = kept.get_chain(flat=True)
    take = flat[np.unique(np.linspace(0, flat.shape[0] - 1, N_DERIVED).astype(int))]
    p = problem.space.expand(take)
    row: dict = {}
    kappa, C = np.broadcast_to(p["kappa"], (take.shape[0],)), np.broadcast_to(p["C"], (take.shape[0],))
    for name, draws, full in (("kappa", kappa, _col(problem, data, flat, "kappa")),
                              ("C", C, _col(problem, data, flat, "C")),
                              ("diffusivity", kappa / C, None)):
        src = full if full is not None else draws
        row[name] = float(np.mean(src))
        row[f"{name}_lo"], row[f"{name}_hi"] = (float(v) for v in np.percentile(src, [2.5, 97.5]))
    if any(problem.space[n].group == "h" for n in problem.space.names):
        h = np.asarray(problem.model.coefficients(p).h, float).mean(axis=1)
        row["h_mean"] = float(np.mean(h))
        row["h_mean_lo"], row["h_mean_hi"] = (float(v) for v in np.percentile(h, [2.5, 97.5]))
    temps = [i for i, b in enumerate(data.blob_names) if b[5:] in problem.model.meas.sensor_labels]
    if temps:
        b = kept.get_blobs()
        row["rmse"] = float(np.mean(np.sqrt(np.mean(b[..., temps] ** 2, axis=-1))))
    ess = [r["ess"] for r in table]
    rhat = [r["rhat"] for r in table]
    findings = plausibility(problem, table)
    converged = bool(res.get("converged", False))
    row.update(status="ok" if converged else "not converged", converged=converged,
               n_steps=int(res.get("n_steps", 0)), min_ess=float(np.min(ess)),
               max_rhat=float(np.max(rhat)),
               verdict="; ".join(f.text() for f in findings) or "plausible",
               reason="" if converged else str(res.get("reason", "")))
    return row


def _col(problem, data, flat, name):
    if name in data.param_names:
        return flat[:, data.param_names.index(name)]
    return None  # fixed: the draws of the derived set carry its value


def _reset_peak_rss() -> None:
    """Reset this process's peak resident memory to its current one (Linux >= 4.0)."""
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
    except OSError:
        pass


def _peak_rss_mb() -> float:
    """This process's peak resident memory since :func:`_reset_peak_rss`, MB (``VmHWM``).
    Elsewhere ``ru_maxrss``, which counts the whole life of the process (and, on Linux, is
    inherited from the process it was forked from: the 8 GB "per unit" of issue 25)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except (OSError, ValueError, IndexError):
        pass
    try:
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    except ImportError:  # pragma: no cover - not POSIX
        return float("nan")
