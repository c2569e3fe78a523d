"""Run storage: one interface (:class:`Store`), an in-memory and an HDF5 implementation.

A run holds, per saved step, ``chain`` (n_steps, n_chains, n_params), ``log_prob``
(n_steps, n_chains), ``blobs`` (n_steps, n_chains, n_blobs) and ``accepted`` (n_steps, n_chains),
plus metadata fixed at creation (parameter and blob names, configuration JSON, data hash, sampler,
package version, creation time) and the state needed to resume exactly (:class:`RunState`: last
position, log-probability and blobs, the ``numpy.random.Generator`` state, free-form JSON and
named float arrays such as an adapted proposal covariance).

Writing is buffered: :meth:`Store.append` fills memory, :meth:`Store.flush` writes the block and
the resume state, then commits. The commit is a single small write of ``(n_saved, slot,
generation)``: the state is double-buffered in two slots and the new one is written to the slot
not referenced by the last commit, so a process killed mid-flush leaves the previous block and
its state readable. Readers use ``n_saved``, never a dataset's shape.

The HDF5 file is written in SWMR mode (single writer, multiple readers), so :func:`read_run`
works on a file another process is writing (emcee issues 389 and 393). SWMR forbids creating
datasets or attributes once it is on, so everything is created up front: metadata are attributes
written at creation, variable-length state lives in resizable ``uint8`` / ``float64`` datasets.
"""

from __future__ import annotations

import datetime
import json
import os
import socket
import time
import warnings
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import __version__

__all__ = [
    "HDF5Store",
    "MemoryStore",
    "RunData",
    "RunState",
    "Store",
    "StoreBusy",
    "StoreMismatch",
    "config_diff",
    "read_run",
    "rng_from_state",
]

FORMAT_VERSION = 1


class StoreMismatch(ValueError):
    """A stored run does not match the configuration or data it is asked to continue with."""


class StoreBusy(RuntimeError):
    """The run file is open for writing by a live process."""


# --------------------------------------------------------------------------------------------
# JSON helpers


def _encode(obj: Any) -> Any:
    """Make ``obj`` JSON-serialisable; ndarrays become ``{"__ndarray__": list, "dtype": str}``."""
    if isinstance(obj, dict):
        return {str(k): _encode(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_encode(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return {"__ndarray__": obj.tolist(), "dtype": obj.dtype.str}
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def _decode_hook(d: dict) -> Any:
    if "__ndarray__" in d:
        return np.array(d["__ndarray__"], dtype=d["dtype"])
    return d


def _dumps(obj: Any) -> str:
    return json.dumps(_encode(obj), sort_keys=True)


def _loads(s: str | bytes) -> Any:
    return json.loads(s, object_hook=_decode_hook)


def rng_from_state(state: dict) -> np.random.Generator:
    """A new ``Generator`` whose bit generator (same class as recorded) is in ``state``."""
    cls = getattr(np.random, str(state.get("bit_generator")), None)
    if not (isinstance(cls, type) and issubclass(cls, np.random.BitGenerator)):
        raise ValueError(f"unknown bit generator {state.get('bit_generator')!r}")
    bg = cls()
    bg.state = state
    return np.random.Generator(bg)


def config_diff(old: Any, new: Any, path: str = "") -> list[str]:
    """Key paths where two JSON-like values differ, as ``'a.b: old -> new'`` strings."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for k in sorted(set(old) | set(new), key=str):
            p = f"{path}.{k}" if path else str(k)
            if k not in new:
                out.append(f"{p}: removed (was {old[k]!r})")
            elif k not in old:
                out.append(f"{p}: added ({new[k]!r})")
            else:
                out.extend(config_diff(old[k], new[k], p))
        return out
    if isinstance(old, list) and isinstance(new, list) and len(old) == len(new):
        return [
            d
            for i, (a, b) in enumerate(zip(old, new, strict=True))
            for d in config_diff(a, b, f"{path}[{i}]")
        ]
    return [] if old == new else [f"{path or '<root>'}: {old!r} -> {new!r}"]


# --------------------------------------------------------------------------------------------
# Plain containers


@dataclass
class RunState:
    """What a sampler needs to continue a run exactly.

    Attributes
    ----------
    position : (n_chains, n_params) current position of every chain.
    log_prob : (n_chains,) log-posterior at ``position``.
    blobs : (n_chains, n_blobs) blobs at ``position``.
    rng_state : ``rng.bit_generator.state`` of the sampler's Generator, or None.
    extra : free-form JSON-serialisable dict (e.g. step sizes, iteration counters).
    arrays : named float arrays (e.g. an adapted proposal covariance).
    """

    position: np.ndarray
    log_prob: np.ndarray
    blobs: np.ndarray
    rng_state: dict | None = None
    extra: dict = field(default_factory=dict)
    arrays: dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def capture(
        cls,
        position,
        log_prob,
        blobs,
        rng: np.random.Generator | None = None,
        extra: dict | None = None,
        arrays: dict | None = None,
    ) -> RunState:
        """Build a state, copying arrays and recording ``rng``'s bit-generator state."""
        position = np.array(position, dtype=float)
        blobs = np.zeros((len(position), 0)) if blobs is None else np.array(blobs, dtype=float)
        return cls(
            position,
            np.array(log_prob, dtype=float),
            blobs,
            None if rng is None else rng.bit_generator.state,
            dict(extra or {}),
            {k: np.array(v, dtype=float) for k, v in (arrays or {}).items()},
        )

    def make_rng(self) -> np.random.Generator:
        """A new Generator continuing exactly where the recorded one stopped."""
        if self.rng_state is None:
            raise ValueError("this run state has no recorded random-generator state")
        return rng_from_state(self.rng_state)


@dataclass
class RunData:
    """A stored run as plain numpy arrays (committed steps only)."""

    chain: np.ndarray  # (n_saved, n_chains, n_params)
    log_prob: np.ndarray  # (n_saved, n_chains)
    blobs: np.ndarray  # (n_saved, n_chains, n_blobs)
    accepted: np.ndarray  # (n_saved, n_chains) bool
    param_names: list[str]
    blob_names: list[str]
    meta: dict
    state: RunState | None

    @property
    def n_saved(self) -> int:
        return int(self.chain.shape[0])

    def get_chain(self, discard: int = 0, thin: int = 1, flat: bool = False) -> np.ndarray:
        """``chain[discard::thin]``, flattened to (n, n_params) over steps and chains if ``flat``."""
        c = self.chain[discard::thin]
        return c.reshape(-1, c.shape[2]) if flat else c


# --------------------------------------------------------------------------------------------
# The interface


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
        return self._consistent_read(with_rows=False)[1]

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
        """Write the buffered rows and ``state`` (plus staged arrays), then commit."""
        self._check_writable()
        n_saved, slot, gen = self._read_commit()
        if self._buffer:
            cols = [np.stack(c) for c in zip(*self._buffer, strict=True)]
            self._write_rows(n_saved, *cols)
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
        self._write_state(new_slot, st)
        self._commit(n_saved + len(self._buffer), new_slot, gen + 1)
        self._buffer.clear()
        self._pending_arrays.clear()

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
        for _ in range(200):
            n_saved, slot, gen = self._read_commit()
            try:
                rows = self._read_rows(n_saved) if with_rows else ()
                state = None if slot < 0 else self._read_state(slot)
            except Exception:
                # A writer two commits ahead may be rewriting our slot: retry; otherwise the
                # store is really broken.
                if self._read_commit()[2] == gen:
                    raise
                continue
            # The writer only rewrites a slot after a newer commit: unchanged generation => the
            # state we read is whole. Rows below n_saved are never rewritten.
            if self._read_commit()[2] == gen:
                return rows, state
            time.sleep(0.005)
        raise RuntimeError("could not get a consistent read while the run is being written")

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
        for key in ("data_hash", "param_names", "blob_names", "n_chains", "sampler"):
            if key in meta_new and _encode(meta_new[key]) != current.get(key):
                problems.append(f"{key}: {current.get(key)!r} -> {meta_new[key]!r}")
        if problems:
            raise StoreMismatch(f"stored run {self._where()} does not match: " + "; ".join(problems))

    def _where(self) -> str:
        return type(self).__name__

    # --- backend primitives ---------------------------------------------------------------
    @abstractmethod
    def _read_commit(self) -> tuple[int, int, int]:
        """(n_saved, state slot or -1, generation)."""

    @abstractmethod
    def _read_rows(self, stop: int) -> tuple[np.ndarray, ...]:
        """chain, log_prob, blobs, accepted for steps [0, stop)."""

    @abstractmethod
    def _read_state(self, slot: int) -> RunState: ...

    @abstractmethod
    def _write_rows(self, start: int, chain, log_prob, blobs, accepted) -> None:
        """Write rows at [start, start + len); drop anything stored beyond."""

    @abstractmethod
    def _write_state(self, slot: int, state: RunState) -> None: ...

    @abstractmethod
    def _commit(self, n_saved: int, slot: int, generation: int) -> None:
        """Make the written rows and state visible (the last write of a flush)."""


# --------------------------------------------------------------------------------------------
# In memory


class _MemoryRun:
    def __init__(self, n_chains: int, n_params: int, n_blobs: int) -> None:
        m = n_chains
        self.cols = [
            np.zeros((0, m, n_params)),
            np.zeros((0, m)),
            np.zeros((0, m, n_blobs)),
            np.zeros((0, m), dtype=bool),
        ]
        self.slots: list[str | None] = [None, None]  # JSON of each state slot
        self.commit = (0, -1, 0)


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

    def _read_commit(self) -> tuple[int, int, int]:
        return self._run.commit

    def _read_rows(self, stop: int) -> tuple[np.ndarray, ...]:
        return tuple(c[:stop].copy() for c in self._run.cols)

    def _read_state(self, slot: int) -> RunState:
        d = _loads(self._run.slots[slot])
        return RunState(d["position"], d["log_prob"], d["blobs"], d["rng_state"], d["extra"], d["arrays"])

    def _write_rows(self, start, chain, log_prob, blobs, accepted) -> None:
        cols = self._run.cols
        self._run.cols = [
            np.concatenate([c[:start], new])
            for c, new in zip(cols, [chain, log_prob, blobs, accepted], strict=True)
        ]

    def _write_state(self, slot: int, state: RunState) -> None:
        self._run.slots[slot] = _dumps(vars(state))

    def _commit(self, n_saved: int, slot: int, generation: int) -> None:
        self._run.commit = (n_saved, slot, generation)


# --------------------------------------------------------------------------------------------
# HDF5


def _h5py():
    import h5py

    return h5py


_ROWS = ("chain", "log_prob", "blobs", "accepted")


class HDF5Store(Store):
    """A run in an HDF5 file written in SWMR mode; readable while it is being written.

    Layout: datasets ``chain``, ``log_prob``, ``blobs``, ``accepted`` (chunked, unlimited along
    steps); ``state/position`` (2, n_chains, n_params), ``state/log_prob``, ``state/blobs`` (two
    slots), ``state/json0|1`` (uint8 JSON: rng state, extra, array index), ``state/arrays0|1``
    (float64, concatenated named arrays); ``commit`` int64 (n_saved, slot, generation);
    ``writer`` uint8 (JSON pid and host of the live writer). Metadata are root attributes
    (``meta_json`` holds them all). ``flush`` calls ``H5Fflush`` but not ``fsync``: a killed
    process leaves a readable file, a power cut may not.
    """

    def __init__(self, f, path: str, writable: bool) -> None:
        meta = _loads(f.attrs["meta_json"])
        if meta.get("format_version") != FORMAT_VERSION:
            raise ValueError(f"{path}: unsupported run format {meta.get('format_version')!r}")
        super().__init__(
            json.loads(f.attrs["param_names"]),
            json.loads(f.attrs["blob_names"]),
            int(f.attrs["n_chains"]),
            meta,
            writable,
        )
        self._f = f
        self.path = path

    def _where(self) -> str:
        return self.path

    @classmethod
    def create(
        cls,
        path: str | os.PathLike,
        param_names: list[str],
        blob_names: list[str],
        n_chains: int,
        meta: dict,
        overwrite: bool = False,
    ) -> HDF5Store:
        """Create a new run file and keep it open for writing.

        Raises ``FileExistsError`` if ``path`` exists and ``overwrite`` is False.
        """
        h5py = _h5py()
        path = os.fspath(path)
        if os.path.exists(path) and not overwrite:
            raise FileExistsError(
                f"{path} already holds a run; pass overwrite=True to replace "
                "it or resume it with HDF5Store.open_append"
            )
        meta = cls._make_meta(param_names, blob_names, n_chains, meta)
        m, p, b = int(n_chains), len(param_names), len(blob_names)
        rows = max(1, min(1024, 2**18 // (8 * m * max(p, b, 1))))
        f = h5py.File(path, "w", libver="latest")
        try:
            f.attrs.update(
                {
                    "meta_json": _dumps(meta),
                    "param_names": json.dumps(param_names),
                    "blob_names": json.dumps(blob_names),
                    "n_chains": m,
                    "format_version": FORMAT_VERSION,
                }
            )
            for name, tail, dt in zip(
                _ROWS, [(m, p), (m,), (m, b), (m,)], ["f8", "f8", "f8", "bool"], strict=True
            ):
                chunks = (rows, *tail) if all(tail) else True  # zero-width blobs: auto chunks
                f.create_dataset(name, shape=(0, *tail), maxshape=(None, *tail), dtype=dt, chunks=chunks)
            g = f.create_group("state")
            for name, tail in [("position", (m, p)), ("log_prob", (m,)), ("blobs", (m, b))]:
                g.create_dataset(name, shape=(2, *tail), dtype="f8")
            for s in (0, 1):
                g.create_dataset(f"json{s}", shape=(0,), maxshape=(None,), dtype="u1", chunks=(4096,))
                g.create_dataset(f"arrays{s}", shape=(0,), maxshape=(None,), dtype="f8", chunks=(4096,))
            f.create_dataset("commit", data=np.array([0, -1, 0], dtype=np.int64))
            f.create_dataset("writer", shape=(256,), dtype="u1")
            return cls._start_writing(f, path)
        except BaseException:
            f.close()
            raise

    @classmethod
    def _start_writing(cls, f, path: str) -> HDF5Store:
        info = json.dumps({"pid": os.getpid(), "host": socket.gethostname()}).encode()[:256]
        f["writer"][...] = np.frombuffer(info.ljust(256, b"\0"), dtype=np.uint8)
        f.swmr_mode = True
        return cls(f, path, writable=True)

    @classmethod
    def open_append(cls, path: str | os.PathLike, recover: bool = True, force: bool = False) -> HDF5Store:
        """Reopen a run for writing; resume from ``.state`` (and ``.meta``, ``.n_saved``).

        If a writer was killed, HDF5 refuses to reopen the file. With ``recover`` the committed
        steps and state are copied into a fresh file at ``path`` and the damaged file is kept as
        ``path + '.crashed'``. :class:`StoreBusy` is raised if the recorded writer is still
        alive on this host, or runs on another host (unless ``force``).
        """
        h5py = _h5py()
        path = os.fspath(path)
        try:
            f = h5py.File(path, "r+", libver="latest")
        except OSError as err:
            if "already open for write" not in str(err):
                raise
            with h5py.File(path, "r", swmr=True) as fr:
                raw = bytes(fr["writer"][...]).rstrip(b"\0")
            w = json.loads(raw) if raw else {}
            if w.get("host") != socket.gethostname() and not force:
                raise StoreBusy(
                    f"{path} is open for writing on host {w.get('host')!r}; "
                    "pass force=True if that writer is dead"
                ) from err
            if w.get("host") == socket.gethostname() and _pid_alive(int(w.get("pid", -1))):
                raise StoreBusy(f"{path} is being written by process {w['pid']}") from err
            if not recover:
                raise
            cls._recover(path)
            f = h5py.File(path, "r+", libver="latest")
        try:
            return cls._start_writing(f, path)
        except BaseException:
            f.close()
            raise

    @classmethod
    def _recover(cls, path: str) -> None:
        """Copy the committed part of a run left by a killed writer into a fresh file."""
        src = cls.open_readonly(path)
        try:
            data = src.read()
            gen = src._read_commit()[2]
        finally:
            src.close()
        tmp = path + ".recovering"
        new = cls.create(tmp, data.param_names, data.blob_names, src.n_chains, data.meta, overwrite=True)
        try:
            if data.n_saved:
                new._write_rows(0, data.chain, data.log_prob, data.blobs, data.accepted)
            if data.state is not None:
                new._write_state(0, data.state)
            new._commit(data.n_saved, 0 if data.state is not None else -1, gen)
        finally:
            new.close()
        os.replace(path, path + ".crashed")
        os.replace(tmp, path)

    @classmethod
    def open_readonly(cls, path: str | os.PathLike) -> HDF5Store:
        """Open a run for reading (SWMR); works while another process writes it."""
        path = os.fspath(path)
        h5py = _h5py()
        try:
            f = h5py.File(path, "r", libver="latest", swmr=True)
        except OSError as err:  # e.g. file systems without locking, or a stale lock
            if "lock" not in str(err):
                raise
            f = h5py.File(path, "r", libver="latest", swmr=True, locking=False)
        try:
            return cls(f, path, writable=False)
        except BaseException:
            f.close()
            raise

    def close(self) -> None:
        """Close the file (unflushed rows are discarded with a warning)."""
        if self.closed:
            return
        super().close()
        try:
            if self.writable:
                self._f["writer"][...] = 0
        finally:
            self._f.close()

    # --- primitives -----------------------------------------------------------------------
    def _ds(self, name: str):
        ds = self._f[name]
        if not self.writable:
            ds.refresh()
        return ds

    def _read_commit(self) -> tuple[int, int, int]:
        n, slot, gen = (int(v) for v in self._ds("commit")[...])
        return n, slot, gen

    def _read_rows(self, stop: int) -> tuple[np.ndarray, ...]:
        return tuple(self._ds(name)[:stop] for name in _ROWS)

    def _read_state(self, slot: int) -> RunState:
        g = "state/"
        d = _loads(bytes(self._ds(f"{g}json{slot}")[...]))
        flat = self._ds(f"{g}arrays{slot}")[...]
        arrays = {k: flat[o : o + int(np.prod(s))].reshape(s) for k, (o, s) in d["index"].items()}
        return RunState(
            self._ds(g + "position")[slot],
            self._ds(g + "log_prob")[slot],
            self._ds(g + "blobs")[slot],
            d["rng_state"],
            d["extra"],
            arrays,
        )

    def _write_rows(self, start, chain, log_prob, blobs, accepted) -> None:
        stop = start + len(chain)
        for name, arr in zip(_ROWS, [chain, log_prob, blobs, accepted], strict=True):
            ds = self._f[name]
            ds.resize(stop, axis=0)
            if arr.size:
                ds[start:stop] = arr

    def _write_state(self, slot: int, state: RunState) -> None:
        g = self._f["state"]
        g["position"][slot] = state.position
        g["log_prob"][slot] = state.log_prob
        if state.blobs.size:
            g["blobs"][slot] = state.blobs
        index, offset = {}, 0
        for k, a in state.arrays.items():
            index[k] = (offset, list(a.shape))
            offset += a.size
        payload = _dumps({"rng_state": state.rng_state, "extra": state.extra, "index": index})
        buf = np.frombuffer(payload.encode(), dtype=np.uint8)
        g[f"json{slot}"].resize(buf.shape)
        g[f"json{slot}"][:] = buf
        g[f"arrays{slot}"].resize((offset,))
        if offset:
            g[f"arrays{slot}"][:] = np.concatenate([a.ravel() for a in state.arrays.values()])

    def _commit(self, n_saved: int, slot: int, generation: int) -> None:
        self._f.flush()  # rows and state reach the file before the commit that exposes them
        self._f["commit"][...] = np.array([n_saved, slot, generation], dtype=np.int64)
        self._f.flush()


def _pid_alive(pid: int) -> bool:
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def read_run(path: str | os.PathLike) -> RunData:
    """Read a stored run (committed steps, metadata, resume state) as plain numpy arrays.

    Safe on a file another process is currently writing.
    """
    with HDF5Store.open_readonly(path) as store:
        return store.read()
