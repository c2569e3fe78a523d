"""Run storage: one interface (:class:`Store`), an in-memory and an HDF5 implementation.

A run holds, per saved step, ``chain`` (n_steps, n_chains, n_params), ``log_prob``
(n_steps, n_chains), ``blobs`` (n_steps, n_chains, n_blobs) and ``accepted`` (n_steps, n_chains),
plus metadata fixed at creation (parameter and blob names, configuration JSON, data hash, sampler,
package version, creation time) and the state needed to resume exactly (:class:`RunState`: last
position, log-probability and blobs, the ``numpy.random.Generator`` state, free-form JSON and
named float arrays such as an adapted proposal covariance).

Modules: :mod:`.records` (:class:`RunState`, :class:`RunData` and their JSON encoding),
:mod:`.base` (the :class:`Store` interface: buffered writing, the commit record, consistent
reading), :mod:`.integrity` (the commit's digest, :class:`StoreDamaged`,
:class:`StoreWriteFailed`), :mod:`.memory` (:class:`MemoryStore`), :mod:`.hdf5`
(:class:`HDF5Store` in SWMR mode and :func:`read_run`, which reads a finished or a live run),
:mod:`.rows` (where an HDF5 run's rows lie: whole chunks written once, a double-buffered tail),
:mod:`.swmr` (opening a file for reading with HDF5's metadata retries bounded, and for writing
in SWMR mode), :mod:`.writer` (who writes a file, and whether that process lives),
:mod:`.recovery` (a dead writer's run continued in place or copied).
"""

from __future__ import annotations

from ..samplers.state import RunState, rng_from_state
from .base import FORMAT_VERSION, Store, StoreBusy, StoreMismatch  # noqa: F401  (FORMAT_VERSION)
from .files import DISK_FULL, write_atomic
from .hdf5 import HDF5Store, read_run
from .integrity import StoreDamaged, StoreWriteFailed
from .memory import MemoryStore
from .records import RunData, config_diff

__all__ = [
    "DISK_FULL",
    "HDF5Store",
    "MemoryStore",
    "RunData",
    "RunState",
    "Store",
    "StoreBusy",
    "StoreDamaged",
    "StoreMismatch",
    "StoreWriteFailed",
    "config_diff",
    "read_run",
    "rng_from_state",
    "write_atomic",
]
