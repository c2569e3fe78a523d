"""A run in an HDF5 file (:class:`HDF5Store`) and :func:`read_run` for a finished or live run.

The HDF5 file is written in SWMR mode (single writer, multiple readers), so :func:`read_run`
works on a file another process is writing (emcee issues 389 and 393). SWMR forbids creating
datasets or attributes once it is on, so everything is created up front: metadata are attributes
written at creation, variable-length state lives in resizable ``uint8`` / ``float64`` datasets.

Storage faults: every chunk carries HDF5's ``fletcher32`` checksum and the commit a digest
(:mod:`.integrity`), so a cut or altered file is refused by :func:`read_run`,
:meth:`HDF5Store.open_readonly` and :meth:`HDF5Store.open_append` with a message naming it.
A write that fails (disk full, ``ulimit -f``, I/O error) raises
:class:`~.integrity.StoreWriteFailed`; the store then points HDF5's file descriptor at
``/dev/null`` before closing. Why: HDF5 closes a dataset by writing its cached chunks; when that
write fails, the dataset is left half-closed and HDF5's exit handler crashes on it (a
segmentation fault, ``H5D_close`` from ``H5_term_library``). Nothing written after the failure
may reach the file anyway: the last commit is what a resume continues from.
"""

from __future__ import annotations

import json
import os
import socket
import time

import numpy as np

from . import recovery
from . import rows as row_layout
from .base import FORMAT_VERSION, Store, StoreBusy
from .integrity import (
    N_DIGEST,
    StoreDamaged,
    StoreWriteFailed,
    check_headers,
    close_after_failure,
    creation_failed,
    first_line,
    hdf5_end_of_file,
    human_bytes,
    neutralise,
    system_reason,
    truncation,
    unreadable,
)
from .records import RunData, RunState, _dumps, _loads
from .swmr import open_swmr_reader, open_swmr_writer
from .writer import _ABANDONED, _pid_alive, _writer_record


def _h5py():
    import h5py

    return h5py


class HDF5Store(Store):
    """A run in an HDF5 file written in SWMR mode; readable while it is being written.

    Layout: datasets ``chain``, ``log_prob``, ``blobs``, ``accepted`` (chunked, unlimited along
    steps, whole chunks only) and ``tail/<name>`` (two slots of the rows after the last whole
    chunk: :mod:`.rows`); ``state/position`` (2, n_chains, n_params), ``state/log_prob``,
    ``state/blobs`` (two slots), ``state/json0|1`` (uint8 JSON: rng state, extra, array index),
    ``state/arrays0|1`` (float64, concatenated named arrays); ``commit`` int64 (n_saved, slot,
    generation and the digest); ``writer`` uint8 (JSON pid and host of the live writer).
    Metadata are root attributes (``meta_json`` holds them all). ``flush`` calls ``H5Fflush``
    but not ``fsync``: a killed process leaves a readable file, a power cut may not.
    """

    def __init__(self, f, path: str, writable: bool) -> None:
        meta = _loads(f.attrs["meta_json"])
        if meta.get("format_version") not in (1, 2, FORMAT_VERSION):
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
        #: datasets stay open while the file is: a dataset closed mid-run flushes its chunk
        #: cache, and a failed flush there is ignored by h5py and crashes HDF5 at exit
        self._dsets: dict = {}
        self._failed = False
        #: steps in a tail slot (format 3); None: every row in the row datasets (formats 1, 2)
        self._chunk = row_layout.tail_length(f)
        #: the tail rows of the last commit (a writer keeps them to spare reading them back),
        #: and those of the flush under way until its commit is written
        self._tail: tuple | None = None
        self._tail_next: tuple | None = None

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
        try:
            f = h5py.File(path, "w", libver="latest")
        except OSError as err:  # no room for even the file's header
            raise creation_failed(path, err) from err
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
            row_layout.create(f, m, p, b)
            g = f.create_group("state")
            for name, tail in [("position", (m, p)), ("log_prob", (m,)), ("blobs", (m, b))]:
                whole = all(tail)  # a zero-width dataset cannot be chunked
                g.create_dataset(name, shape=(2, *tail), dtype="f8", fletcher32=whole,
                                 chunks=(1, *tail) if whole else None)
            for s in (0, 1):
                for name, dt in ((f"json{s}", "u1"), (f"arrays{s}", "f8")):
                    g.create_dataset(name, shape=(0,), maxshape=(None,), dtype=dt, chunks=(4096,),
                                     fletcher32=True)
            f.create_dataset("commit", data=np.array([0, -1, 0, *[0] * N_DIGEST], dtype=np.int64),
                             chunks=(3 + N_DIGEST,), fletcher32=True)
            f.create_dataset("writer", shape=(256,), dtype="u1")
        except BaseException as err:
            close_after_failure(f)
            raise creation_failed(path, err) from err
        return cls._start_writing(f, path)

    @classmethod
    def _start_writing(cls, f, path: str) -> HDF5Store:
        info = json.dumps({"pid": os.getpid(), "host": socket.gethostname()}).encode()[:256]
        try:
            store = cls(f, path, writable=True)
            store._ds("writer")[...] = np.frombuffer(info.ljust(256, b"\0"), dtype=np.uint8)
            if not f.swmr_mode:  # a file just created (a reopened one is opened in SWMR mode)
                f.swmr_mode = True
        except BaseException as err:
            close_after_failure(f)
            raise creation_failed(path, err) from err
        _ABANDONED.discard(os.path.realpath(path))
        return store

    @classmethod
    def open_append(cls, path: str | os.PathLike, recover: bool = True, force: bool = False) -> HDF5Store:
        """Reopen a run for writing; resume from ``.state`` (and ``.meta``, ``.n_saved``).

        If a writer was killed, or its last write failed (a full disk leaves the file shorter
        than HDF5 expects), HDF5 refuses to reopen the file. With ``recover`` its committed
        steps and state are checked against the commit's digest, then continued in place or
        copied into a fresh file (:mod:`.recovery`: which, and why). :class:`StoreBusy` is
        raised if the recorded writer is still alive on this host, or runs on another host
        (unless ``force``), or if another process holds the file open (HDF5 cannot lock it).
        """
        path = os.fspath(path)
        # first as a reader (bounded attempts, checked headers): HDF5's own r+ open of a file
        # with a damaged header can wait for ever or fail deep inside, and writes to it
        reader = cls.open_readonly(path)
        try:
            check_headers(reader._f, path)
        finally:
            reader.close()
        try:
            f = open_swmr_writer(path)  # SWMR from the open on (swmr.py: why)
        except FileNotFoundError:
            raise
        except OSError as err:  # a killed writer, or one whose last write failed (disk full)
            if "unable to lock file" in str(err):  # a SWMR reader holds a shared lock on it
                raise StoreBusy(f"{path} is open in another process (a reader such as read_run, "
                                "report or diagnose, or a writer starting); close it and resume "
                                "again") from err
            if "already open for write" not in str(err) and "truncated file" not in str(err):
                raise unreadable(path, err) from err
            w = _writer_record(path)  # {}: no writer recorded, none can be alive
            if w and w.get("host") != socket.gethostname() and not force:
                raise StoreBusy(
                    f"{path} is open for writing on host {w.get('host')!r}; "
                    "pass force=True if that writer is dead"
                ) from err
            if w.get("host") == socket.gethostname() and _pid_alive(int(w.get("pid", -1))) \
                    and not (w["pid"] == os.getpid() and os.path.realpath(path) in _ABANDONED):
                raise StoreBusy(f"{path} is being written by process {w['pid']}") from err
            if not recover:
                raise
            f = recovery.recover(cls, path)
        try:
            return cls._start_writing(f, path)
        except BaseException:
            f.close()
            raise

    @classmethod
    def open_readonly(cls, path: str | os.PathLike) -> HDF5Store:
        """Open a run for reading (SWMR); works while another process writes it."""
        path = os.fspath(path)
        try:
            try:
                f = open_swmr_reader(path)
            except OSError as err:  # e.g. file systems without locking, or a stale lock
                if "lock" not in str(err):
                    raise
                f = open_swmr_reader(path, locking=False)
        except FileNotFoundError:
            raise
        except OSError as err:
            raise unreadable(path, err) from err
        try:
            store = cls(f, path, writable=False)
        except BaseException as err:
            f.close()
            if isinstance(err, KeyError | OSError | RuntimeError | ValueError):
                raise unreadable(path, err) from err
            raise
        eof = hdf5_end_of_file(path)  # format 1 has no digest: a cut file is refused here
        if store.meta.get("format_version") == 1 and eof is not None and os.path.getsize(path) < eof:
            store.close()
            raise store._damaged("a run of format 1 (no checksums) cut short")
        return store

    def close(self) -> None:
        """Close the file (unflushed rows are discarded with a warning)."""
        if self.closed:
            return
        super().close()
        if self._failed:  # the descriptor points at /dev/null: nothing more reaches the file
            self._dsets.clear()
            close_after_failure(self._f)
            return
        try:
            if self.writable:
                self._ds("writer")[...] = 0
        finally:
            self._dsets.clear()
            self._f.close()

    def _write_failed(self, err: Exception, n_saved: int) -> Exception:
        """Stop writing: HDF5's descriptor to /dev/null (see the module docstring), then say
        what failed, where the run stands and how much room it needs."""
        self._failed = True
        neutralise(self._f)
        _ABANDONED.add(os.path.realpath(self.path))
        m, width = self.n_chains, self.n_params + 1 + self.n_blobs
        per_step = 8 * m * width + m
        chunk = int(self._dsets["chain"].chunks[0]) if "chain" in self._dsets else 1
        steps = self._committed_steps if self._committed_steps is not None else n_saved
        reason = system_reason(err)
        return StoreWriteFailed(
            f"writing {self.path} failed: {reason}. The run is kept up to its last committed "
            f"step ({steps} steps, {n_saved} stored); it needs about {human_bytes(per_step)} "
            f"of disk a step, allocated {human_bytes(per_step * chunk)} at a time",
            path=self.path, reason=reason, n_saved=n_saved, n_steps=steps,
            bytes_per_step=per_step)

    # --- primitives -----------------------------------------------------------------------
    def _ds(self, name: str):
        if not self.writable:  # a reader opens afresh: a kept dataset keeps stale chunks cached
            ds = self._f[name]
            ds.refresh()
            return ds
        ds = self._dsets.get(name)
        if ds is None:
            ds = self._dsets[name] = self._f[name]
        return ds

    def _read_commit(self) -> tuple[int, ...]:
        for attempt in range(3):  # a reader may meet the record while the writer rewrites it
            try:
                rec = tuple(int(v) for v in self._ds("commit")[...])
                break
            except (KeyError, OSError, RuntimeError, ValueError) as err:
                if attempt == 2 or self.writable:
                    raise unreadable(self.path, err, "its commit record cannot be read") from err
                time.sleep(0.01)
        if len(rec) not in (3, 3 + N_DIGEST):
            raise StoreDamaged(f"{self.path} is damaged: a commit record of {len(rec)} entries")
        return rec

    def _get(self, name: str, sel) -> np.ndarray:
        """``dataset[sel]``; an error names the dataset and says what HDF5 found."""
        try:
            return self._ds(name)[sel]
        except Exception as err:
            first = first_line(err)
            if "filter returned failure" in first:
                first = "a block fails its fletcher32 checksum"
            raise OSError(f"{name}: {first}") from err

    def _read_rows(self, stop: int, slot: int) -> tuple[np.ndarray, ...]:
        return row_layout.read(self._get, stop, slot, self._chunk)

    def _read_state(self, slot: int) -> RunState:
        g = "state/"
        raw = bytes(self._get(f"{g}json{slot}", ...))
        try:
            d = _loads(raw)
        except ValueError as err:  # UnicodeDecodeError, JSONDecodeError
            raise ValueError(f"{g}json{slot}: not the JSON written ({err})") from err
        flat = self._get(f"{g}arrays{slot}", ...)
        arrays = {k: flat[o : o + int(np.prod(s))].reshape(s) for k, (o, s) in d["index"].items()}
        return RunState(
            self._get(g + "position", slot),
            self._get(g + "log_prob", slot),
            self._get(g + "blobs", slot),
            d["rng_state"],
            d["extra"],
            arrays,
        )

    def _damaged(self, what: str) -> StoreDamaged:
        cut = truncation(self.path)
        return StoreDamaged(f"{self.path} is damaged: {cut + '; ' if cut else ''}{what}; it is not read")

    def _write_rows(self, start, slot, chain, log_prob, blobs, accepted) -> None:
        self._tail_next = row_layout.write(self._ds, self._get, start, slot,
                                           (chain, log_prob, blobs, accepted), self._chunk,
                                           self._tail)

    def _write_state(self, slot: int, state: RunState) -> None:
        g = {k: self._ds(f"state/{k}") for k in ("position", "log_prob", "blobs", f"json{slot}",
                                                  f"arrays{slot}")}
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

    def _commit(self, n_saved: int, slot: int, generation: int, digest: tuple = ()) -> None:
        self._f.flush()  # rows and state reach the file before the commit that exposes them
        ds = self._ds("commit")
        rec = [n_saved, slot, generation, *digest][: ds.shape[0]]  # format 1: no digest
        ds[...] = np.array(rec, dtype=np.int64)
        self._f.flush()
        self._tail, self._tail_next = self._tail_next, None


def read_run(path: str | os.PathLike) -> RunData:
    """Read a stored run (committed steps, metadata, resume state) as plain numpy arrays.

    Safe on a file another process is currently writing.
    """
    with HDF5Store.open_readonly(path) as store:
        return store.read()
