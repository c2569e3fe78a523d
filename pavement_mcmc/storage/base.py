"""The storage interface (:class:`Store`) shared by every sampler and every backend.

Writing is buffered: :meth:`Store.append` fills memory, :meth:`Store.flush` writes the block and
the resume state, then commits. The commit is a single small write of ``(n_saved, slot,
generation, digest)``: the state is double-buffered in two slots and the new one is written to
the slot not referenced by the last commit, so a process killed mid-flush leaves the previous block
and its state readable. A backend may keep rows in the slots too: the HDF5 store keeps there the
rows after its last whole chunk, so that a committed row is never rewritten (:mod:`.rows`).
Readers use ``n_saved``, never a dataset's shape, and check what they read against the commit's
digest (:mod:`.integrity`): a damaged run is refused, never misread. A write that fails leaves
the last commit as it was and raises :class:`~.integrity.StoreWriteFailed`.
"""

from __future__ import annotations

import datetime
import json
import time
import warnings
from abc import ABC, abstractmethod

import numpy as np

from .. import __version__
from ..data.errors import UserError
from ..samplers.state import RunState
from .integrity import (
    N_DIGEST,
    StoreDamaged,
    full_digest,
    rows_digest,
    state_digest,
    what_differs,
)
from .records import RunData, _dumps, _encode, config_diff

#: 2: the commit record carries a digest (format 1, without it, is still read); 3: a committed
#: row is never rewritten (whole chunks written once, the rest in two tail slots: :mod:`.rows`)
FORMAT_VERSION = 3


class StoreMismatch(UserError, ValueError):
    """A stored run does not match the configuration or data it is asked to continue with."""


class StoreBusy(UserError, RuntimeError):
    """The run file is open for writing by a live process."""


class Store(ABC):
    """Storage interface shared by every sampler; subclasses supply five row/state primitives.

    Writers: ``append`` rows, ``flush(state)`` per block, ``close``. Readers: ``read()``,
    ``state``, ``n_saved``, ``meta``. A store is a context manager.
    """

    def __init__(
        self, param_names: list[str], blob_names: list[str], n_chains: int, meta: dict, writable: bool
    ) -> None:
        self.param_names = list(param_names)
        self.blob_names = list(blob_names)
        self.n_chains = int(n_chains)
        self.meta = dict(meta)
        self.writable = writable
        self.closed = False
        self._buffer: list[tuple] = []
        self._pending_arrays: dict[str, np.ndarray] = {}
        #: the run loop's step count in the last commit seen (None: not known here)
        self._committed_steps: int | None = None

    @staticmethod
    def _make_meta(param_names, blob_names, n_chains, meta: dict) -> dict:
        if not param_names:
            raise ValueError("a run needs at least one parameter name")
        if len(set(param_names)) != len(param_names) or len(set(blob_names)) != len(blob_names):
            raise ValueError(f"duplicate names in {list(param_names)} / {list(blob_names)}")
        if int(n_chains) < 1:
            raise ValueError(f"n_chains must be >= 1; got {n_chains}")
        m = dict(meta)
        cfg = m.get("config_json", "{}")
        m["config_json"] = cfg if isinstance(cfg, str) else _dumps(cfg)
        json.loads(m["config_json"])  # must be valid JSON
        m.setdefault("data_hash", "")
        m.setdefault("sampler", "")
        m.setdefault("version", __version__)
        m.setdefault("created", datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"))
        m["format_version"] = FORMAT_VERSION
        _dumps(m)
        return m

    # --- properties -----------------------------------------------------------------------
    @property
    def n_params(self) -> int:
        return len(self.param_names)

    @property
    def n_blobs(self) -> int:
        return len(self.blob_names)

    @property
    def n_saved(self) -> int:
        """Number of committed steps."""
        return self._read_commit()[0]

    @property
    def n_buffered(self) -> int:
        """Rows appended but not yet flushed."""
        return len(self._buffer)

    @property
    def state(self) -> RunState | None:
        """The committed resume state (None before the first flush)."""
        st = self._consistent_read(with_rows=False)[1]
        self._committed_steps = _loop_steps(st)
        return st

    # --- writing --------------------------------------------------------------------------
    def _check_writable(self) -> None:
        if self.closed:
            raise ValueError("the store is closed")
        if not self.writable:
            raise ValueError("the store is open read-only")

    def append(
        self, positions: np.ndarray, log_prob: np.ndarray, blobs: np.ndarray | None, accepted: np.ndarray
    ) -> None:
        """Buffer one step: positions (n_chains, n_params), log_prob and accepted (n_chains,),
        blobs (n_chains, n_blobs) or None when there are no blobs."""
        self._check_writable()
        m = self.n_chains
        row = (
            np.array(positions, dtype=np.float64),
            np.array(log_prob, dtype=np.float64),
            np.zeros((m, 0)) if blobs is None else np.array(blobs, dtype=np.float64),
            np.array(accepted, dtype=bool),
        )
        for a, shape, name in zip(
            row,
            [(m, self.n_params), (m,), (m, self.n_blobs), (m,)],
            ["positions", "log_prob", "blobs", "accepted"],
            strict=True,
        ):
            if a.shape != shape:
                raise ValueError(f"append: {name} has shape {a.shape}, expected {shape}")
        self._buffer.append(row)

    def save_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Stage named float arrays; they are committed with the next :meth:`flush`."""
        self._check_writable()
        self._pending_arrays.update({str(k): np.array(v, dtype=np.float64) for k, v in arrays.items()})

    def load_arrays(self) -> dict[str, np.ndarray]:
        """The committed named arrays (empty dict if none)."""
        st = self.state
        return {} if st is None else st.arrays

    def flush(self, state: RunState) -> None:
        """Write the buffered rows and ``state`` (plus staged arrays), then commit.

        A write that fails raises :class:`~.integrity.StoreWriteFailed` (the backend says what
        failed); the buffered rows are lost, the last commit stays readable."""
        self._check_writable()
        n_saved, slot, gen, *digest = self._read_commit()
        cols = [np.stack(c) for c in zip(*self._buffer, strict=True)] if self._buffer else \
            [np.zeros((0, *s), dtype=d) for s, d in zip(self._row_shapes(), [float] * 3 + [bool],
                                                         strict=True)]
        st = RunState(
            np.array(state.position, dtype=np.float64),
            np.array(state.log_prob, dtype=np.float64),
            np.asarray(state.blobs, dtype=np.float64).reshape(self.n_chains, self.n_blobs),
            state.rng_state,
            dict(state.extra),
            {**{k: np.array(v, dtype=np.float64) for k, v in state.arrays.items()}, **self._pending_arrays},
        )
        if st.position.shape != (self.n_chains, self.n_params):
            raise ValueError(f"state.position has shape {st.position.shape}")
        new_slot = 0 if slot != 0 else 1
        if len(digest) == N_DIGEST:  # a run of format 1 has none
            digest = [*rows_digest(tuple(digest[:4]), cols), state_digest(st)]
        try:
            self._write_rows(n_saved, new_slot, *cols)  # no rows: the tail moves to new_slot
            self._write_state(new_slot, st)
            self._commit(n_saved + len(self._buffer), new_slot, gen + 1, tuple(digest))
        except Exception as err:
            self._buffer.clear()
            self._pending_arrays.clear()
            raise self._write_failed(err, n_saved) from err
        self._buffer.clear()
        self._pending_arrays.clear()
        self._committed_steps = _loop_steps(st)

    def _row_shapes(self) -> list[tuple[int, ...]]:
        """The shape of one step of chain, log_prob, blobs and accepted."""
        m = self.n_chains
        return [(m, self.n_params), (m,), (m, self.n_blobs), (m,)]

    def _write_failed(self, err: Exception, n_saved: int) -> Exception:
        """The error to raise when a backend write failed (the backend makes it a clear one);
        ``n_saved``: the rows of the last commit."""
        return err

    def close(self) -> None:
        """Close; unflushed rows are discarded with a warning."""
        if self._buffer:
            warnings.warn(
                f"closing store with {len(self._buffer)} unflushed steps; they are "
                "discarded (call flush(state) first)",
                RuntimeWarning,
                stacklevel=2,
            )
            self._buffer.clear()
        self.closed = True

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc: object) -> None:
        if not self.closed:
            self.close()

    # --- reading --------------------------------------------------------------------------
    def read(self) -> RunData:
        """The committed run, consistent even while another process writes it."""
        rows, state = self._consistent_read(with_rows=True)
        return RunData(*rows, self.param_names, self.blob_names, dict(self.meta), state)

    def _consistent_read(self, with_rows: bool) -> tuple[tuple, RunState | None]:
        failures = 0
        for _ in range(200):
            n_saved, slot, gen, *digest = self._read_commit()
            try:
                rows = self._read_rows(n_saved, slot) if with_rows else ()
                state = None if slot < 0 else self._read_state(slot)
            except Exception as err:
                # A writer two commits ahead may be rewriting our slot (state and tail rows), or
                # (formats 1, 2) the chunk holding the last committed rows and its next ones (a
                # checksum read mid-write): retry; failing again and again at one commit, the
                # store is really broken.
                failures = failures + 1 if self._read_commit()[2] == gen else 0
                if failures >= 3 or (failures and self.writable):
                    raise self._damaged(f"its {n_saved} committed steps cannot be read "
                                        f"({err})") from err
                time.sleep(0.01)
                continue
            # The writer only rewrites a slot after a newer commit: unchanged generation => the
            # state and tail rows we read are whole. Whole chunks of rows are never rewritten.
            if self._read_commit()[2] == gen:
                if len(digest) == N_DIGEST:
                    self._verify(tuple(digest), rows, state, n_saved)
                return rows, state
            time.sleep(0.005)
        raise RuntimeError("could not get a consistent read while the run is being written")

    def _verify(self, digest: tuple, rows: tuple, state: RunState | None, n_saved: int) -> None:
        """Refuse what does not match the commit's digest (a cut or altered file)."""
        found = full_digest(rows, state) if rows else (*digest[:4], state_digest(state))
        bad = what_differs(digest, found, with_rows=bool(rows))
        if bad:
            raise self._damaged(f"the stored {' and '.join(bad)} of its {n_saved} committed "
                                "steps do not match their checksum")

    def _damaged(self, what: str) -> StoreDamaged:
        return StoreDamaged(f"{self._where()} is damaged: {what}; it is not read")

    def check_compatible(self, meta_new: dict) -> None:
        """Raise :class:`StoreMismatch` naming what differs between the stored run and
        ``meta_new`` (config key paths, data hash, names, number of chains, sampler)."""
        problems = []
        if "config_json" in meta_new:
            new = meta_new["config_json"]
            new = json.loads(new) if isinstance(new, str) else _encode(new)
            diffs = config_diff(json.loads(self.meta["config_json"]), new)
            problems += [f"config {d}" for d in diffs]
        current = {
            "param_names": self.param_names,
            "blob_names": self.blob_names,
            "n_chains": self.n_chains,
            **self.meta,
        }
        if "data_hash" in meta_new and meta_new["data_hash"] != current.get("data_hash"):
            src = meta_new.get("data_source", "the data file")
            old, new = str(current.get("data_hash"))[:12], str(meta_new["data_hash"])[:12]
            problems.append(f"data: {src} changed since the run was made (its values differ; "
                            f"data hash {old} -> {new})")
        for key in ("param_names", "blob_names", "n_chains", "sampler"):
            if key in meta_new and _encode(meta_new[key]) != current.get(key):
                problems.append(f"{key}: {current.get(key)!r} -> {meta_new[key]!r}")
        if problems:
            raise StoreMismatch(f"stored run {self._where()} does not match: " + "; ".join(problems))

    def _where(self) -> str:
        return type(self).__name__

    # --- backend primitives ---------------------------------------------------------------
    @abstractmethod
    def _read_commit(self) -> tuple[int, ...]:
        """(n_saved, state slot or -1, generation, *digest); the digest is
        :data:`~.integrity.N_DIGEST` CRCs (empty in a run of format 1)."""

    @abstractmethod
    def _read_rows(self, stop: int, slot: int) -> tuple[np.ndarray, ...]:
        """chain, log_prob, blobs, accepted for steps [0, stop) of the commit naming ``slot``."""

    @abstractmethod
    def _read_state(self, slot: int) -> RunState: ...

    @abstractmethod
    def _write_rows(self, start: int, slot: int, chain, log_prob, blobs, accepted) -> None:
        """Write rows at [start, start + len) (perhaps none) for the next commit, which names
        ``slot`` (the last commit names the other one, or -1); drop anything stored beyond."""

    @abstractmethod
    def _write_state(self, slot: int, state: RunState) -> None: ...

    @abstractmethod
    def _commit(self, n_saved: int, slot: int, generation: int, digest: tuple = ()) -> None:
        """Make the written rows and state visible (the last write of a flush)."""


def _loop_steps(state: RunState | None) -> int | None:
    """The run loop's step count recorded in a state (None if it records none)."""
    n = (state.extra.get("loop") or {}).get("n_steps") if state is not None else None
    return None if n is None else int(n)
