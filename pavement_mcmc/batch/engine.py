"""The batch engine: independent units mapped over a Dask distributed cluster.

:func:`map_units` is the one place units are scheduled, for ``pavement-mcmc batch`` and for
the validation campaigns alike. Everything a scheduler does is Dask's: an embedded
``LocalCluster`` by default (one worker process per core, one thread each, no set-up), or an
existing cluster by address (``scheduler=`` or the standard ``DASK_SCHEDULER_ADDRESS``
variable). A worker process that dies mid-unit is noticed by the Dask scheduler, which runs
the unit again elsewhere (up to ``distributed.scheduler.allowed-failures`` times); a unit that
raises is retried ``retries`` times (``Client.submit(retries=...)``). A unit that still fails
is returned as a :class:`Failure` with its reason; it never stops the others. A scheduler that
goes away mid-batch (killed, its machine lost) stops the batch with :class:`SchedulerLost`: the
units still out are not failures of their own, and running the batch again finishes them.
"""

from __future__ import annotations

import functools
import logging
import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import CancelledError
from contextlib import contextmanager
from dataclasses import dataclass

from ..data.errors import UserError

#: the standard Dask environment variable naming an existing scheduler
SCHEDULER_ENV = "DASK_SCHEDULER_ADDRESS"
#: the environment of the local cluster's workers: one core each, so the compiled solver and
#: BLAS use one thread (numba's default of one thread per core, times one worker per core,
#: oversubscribes the machine: measured 5-10x slower per unit on 2 cores)
WORKER_ENV = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
              "MKL_NUM_THREADS": "1"}


@dataclass(frozen=True)
class Failure:
    """A unit that did not produce a result: its key and the reason (the exception's text)."""

    key: str
    reason: str


class SchedulerLost(UserError, RuntimeError):
    """The Dask scheduler went away during a batch; the units it still held did not run."""


def default_workers() -> int:
    """One worker per core this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


@contextmanager
def connect(scheduler: str | None = None, n_workers: int | None = None) -> Iterator:
    """A ``distributed.Client``: to ``scheduler`` (or ``$DASK_SCHEDULER_ADDRESS``) if given,
    else to a new embedded ``LocalCluster`` of ``n_workers`` single-threaded worker processes
    (environment :data:`WORKER_ENV`), closed on exit. Workers of an existing cluster should be
    started the same way: ``NUMBA_NUM_THREADS=1 dask worker ADDRESS --nthreads 1``."""
    from distributed import Client, LocalCluster

    address = scheduler or os.environ.get(SCHEDULER_ENV)
    if address:
        with _quiet("distributed.client"), Client(address) as client:
            yield client  # a lost scheduler is told by map_units, not by Dask's log
        return
    n = int(n_workers or default_workers())
    with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=50, env=WORKER_ENV) as cluster, Client(cluster) as client:
        yield client


def map_units(fn: Callable, units: Iterable, *, key: Callable = str, client=None,
              scheduler: str | None = None, n_workers: int | None = None, retries: int = 1,
              on_done: Callable | None = None, **kwargs) -> list:
    """Run ``fn(unit, **kwargs)`` for every unit on a Dask cluster; results in the units' order.

    Parameters
    ----------
    fn : a picklable function of one unit (and ``kwargs``); it runs on a worker.
    units : the units (picklable).
    key : unit -> a unique name (Dask's task key, the :class:`Failure`'s key).
    client : an open ``distributed.Client`` to use; else one is opened with :func:`connect`
        (``scheduler``, ``n_workers``) and closed afterwards.
    retries : Dask retries of a unit that raised (a dead worker is retried by the scheduler).
    on_done : called in this process as ``on_done(index, outcome)`` whenever a unit ends
        (a progress bar).

    Returns
    -------
    list : ``fn``'s return value for each unit, or a :class:`Failure` for a unit that failed.
    """
    units = list(units)
    if client is None:
        with connect(scheduler, n_workers) as own:
            return map_units(fn, units, key=key, client=own, retries=retries, on_done=on_done,
                             **kwargs)
    from distributed import as_completed

    keys = [str(key(u)) for u in units]
    if len(set(keys)) != len(keys):
        raise ValueError("map_units: two units share a key")
    token = os.urandom(4).hex()  # a fresh task name per call: never a cached result of another
    call = functools.partial(fn, **kwargs) if kwargs else fn
    name = getattr(fn, "__name__", "unit")
    futures = [client.submit(call, u, key=f"{name}-{k}-{token}", retries=retries, pure=False)
               for u, k in zip(units, keys)]
    index = {f.key: i for i, f in enumerate(futures)}
    out: list = [None] * len(units)
    pending = set(range(len(units)))
    try:
        for fut in as_completed(futures):
            i = index[fut.key]
            try:
                out[i] = _outcome(fut, keys[i])
            except (OSError, CancelledError):  # the connection closed, the task cancelled
                continue
            pending.discard(i)
            fut.release()
            if on_done is not None:
                on_done(i, out[i])
    except (OSError, CancelledError):
        pass
    if pending:  # the scheduler that held them went away
        lost = [keys[i] for i in sorted(pending)]
        raise SchedulerLost(
            f"the Dask scheduler {getattr(client.scheduler, 'address', '')} went away during "
            f"the batch: {len(units) - len(lost)} of {len(units)} units ended, {len(lost)} did "
            f"not ({', '.join(lost[:3])}{', ...' if len(lost) > 3 else ''}); run the batch "
            "again when a scheduler is up: ended units are read back, interrupted ones resumed")
    return out


def _outcome(fut, key: str):
    """A finished future's result, or the :class:`Failure` of one that raised; a cancelled one
    (its scheduler lost) raises ``CancelledError``."""
    if fut.status == "finished":
        return fut.result()
    if fut.status == "error":
        err = fut.exception()
        why = (" (the worker running it died each time: out of memory?)"
               if type(err).__name__ == "KilledWorker" else "")
        return Failure(key, f"{type(err).__name__}: {err}{why}")
    raise CancelledError(key)


@contextmanager
def _quiet(name: str) -> Iterator[None]:
    """Silence one logger for the duration (Dask logs each reconnection attempt as an error)."""
    log = logging.getLogger(name)
    level = log.level
    log.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        log.setLevel(level)
