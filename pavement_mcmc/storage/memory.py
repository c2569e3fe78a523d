"""A run kept in memory (:class:`MemoryStore`), with the semantics of the HDF5 store."""

from __future__ import annotations

import numpy as np

from .base import Store
from .integrity import N_DIGEST
from .records import RunState, _dumps, _loads


class _MemoryRun:
    def __init__(self, n_chains: int, n_params: int, n_blobs: int) -> None:
        m = n_chains
        self.cols = [
            np.zeros((0, m, n_params)),
            np.zeros((0, m)),
            np.zeros((0, m, n_blobs)),
            np.zeros((0, m), dtype=bool),
        ]
        self.slots: list[tuple | None] = [None, None]  # each state slot: (JSON, rows, arrays)
        self.commit = (0, -1, 0, *[0] * N_DIGEST)


class MemoryStore(Store):
    """A run kept in memory (tests, short interactive runs). Same semantics as HDF5Store.

    ``MemoryStore.open_append(store)`` reopens a closed store for writing, as
    ``HDF5Store.open_append(path)`` reopens a file.
    """

    def __init__(
        self, run: _MemoryRun, param_names, blob_names, n_chains, meta, writable: bool = True
    ) -> None:
        super().__init__(param_names, blob_names, n_chains, meta, writable)
        self._run = run

    @classmethod
    def create(cls, param_names: list[str], blob_names: list[str], n_chains: int, meta: dict) -> MemoryStore:
        """A new, empty run."""
        meta = cls._make_meta(param_names, blob_names, n_chains, meta)
        run = _MemoryRun(int(n_chains), len(param_names), len(blob_names))
        return cls(run, param_names, blob_names, n_chains, meta)

    @classmethod
    def open_append(cls, store: MemoryStore) -> MemoryStore:
        """Reopen ``store``'s run for writing; resume from ``.state``."""
        return cls(store._run, store.param_names, store.blob_names, store.n_chains, store.meta)

    @classmethod
    def open_readonly(cls, store: MemoryStore) -> MemoryStore:
        """A read-only view of ``store``'s run."""
        return cls(
            store._run, store.param_names, store.blob_names, store.n_chains, store.meta, writable=False
        )

    def _read_commit(self) -> tuple[int, ...]:
        return self._run.commit

    def _read_rows(self, stop: int, slot: int) -> tuple[np.ndarray, ...]:
        return tuple(c[:stop].copy() for c in self._run.cols)

    def _read_state(self, slot: int) -> RunState:
        head, rows, arrays = self._run.slots[slot]
        d = _loads(head)
        return RunState(*(r.copy() for r in rows), d["rng_state"], d["extra"],
                        {k: v.copy() for k, v in arrays.items()})

    def _write_rows(self, start, slot, chain, log_prob, blobs, accepted) -> None:
        # rows past the commit are scratch; capacity doubles so a long run is not copied per block
        run = self._run
        stop = start + np.shape(chain)[0]
        if stop > run.cols[0].shape[0]:
            cap = max(stop, 2 * run.cols[0].shape[0], 64)
            run.cols = [np.concatenate([c, np.zeros((cap - c.shape[0], *c.shape[1:]), c.dtype)])
                        for c in run.cols]
        for c, new in zip(run.cols, [chain, log_prob, blobs, accepted], strict=True):
            c[start:stop] = new

    def _write_state(self, slot: int, state: RunState) -> None:
        # the small parts through JSON, as the HDF5 store keeps them; the arrays as copies (as
        # its datasets: JSON of hmc's 114 x 114 metric cost Case C's benchmark 0.2 s)
        rows = tuple(np.array(a, dtype=float) for a in (state.position, state.log_prob, state.blobs))
        arrays = {k: np.array(v, dtype=float) for k, v in state.arrays.items()}
        self._run.slots[slot] = (_dumps({"rng_state": state.rng_state, "extra": state.extra}), rows, arrays)

    def _commit(self, n_saved: int, slot: int, generation: int, digest: tuple = ()) -> None:
        self._run.commit = (n_saved, slot, generation, *digest)
