"""Continue a run whose writer died: its committed steps, checked, in place or in a fresh copy.

A writer killed, or one whose write failed (a full disk, a file-size limit), leaves its HDF5 file
marked as open for writing, so HDF5 refuses to open it read-write ("already open for write"),
and under a file-size limit shorter than the end HDF5 recorded ("truncated file"). The committed
steps are whole: format 3 writes a committed row once (:mod:`.rows`) and the commit's digest
covers every row and the state (:mod:`.integrity`). What lies beyond them is the block that was
being written. Both ways on start by reading the committed rows and state and checking them
against the digest; a file that fails the check is refused and left as it was.

* **In place** (format 3, when the disk has less free than :data:`COPY_ROOM` times the copy):
  the file is extended to the end HDF5 recorded and to the end of every chunk its indexes name
  (``os.truncate``: a sparse hole, no blocks), opened read-write (SWMR) with its flags cleared
  (``h5clear``'s way), its allocation end set past all of that (``H5Fincrement_filesize``, as
  ``h5clear -i``: HDF5 gives out new space from that end, and one left short of a block the
  file refers to would give that block out again), and read once more through that handle and
  checked against the digest before anything is written. A flush then writes only chunks no
  commit names. What the failed flush wrote stays in the file unused (HDF5 keeps no record of
  free space): the file ends larger than an undisturbed run's by up to a flush's chunks.
  Killed at any moment, the file is again a dead writer's: flags set, the same commit, resumed
  the same way. No ``.crashed`` copy is kept: it would need the room that is
  missing, and it would hold nothing of the run beyond the checked committed steps.
* **A fresh copy** (formats 1 and 2, which rewrite committed rows and are upgraded to format 3
  this way; a file the in-place way cannot check; a disk with room): the committed steps go to
  ``path + '.recovering'``, which is renamed over ``path``; the old file is kept as ``path +
  '.crashed'`` (it keeps its blocks). The room is checked first: a disk that cannot hold the
  copy is told in one line how many bytes to free.
"""

from __future__ import annotations

import ctypes
import os
import shutil

import h5py

from . import rows as row_layout
from .integrity import (
    N_DIGEST,
    StoreDamaged,
    StoreWriteFailed,
    close_after_failure,
    first_line,
    full_digest,
    hdf5_end_of_file,
    human_bytes,
    system_reason,
)
from .swmr import _hdf5_library, open_swmr_writer

#: the copy is made only on a disk with this many times its size free: the old file, kept
#: beside it, then takes a tenth of the room at most. With 2 (the copy, and as much again), 2 of
#: 5 full tmpfs disks given 1.4 MB took the copy and filled again, the old file holding 1.8 MB
#: (``benchmarks/full_disk_resume.py``); else the run goes on in place
COPY_ROOM = 10
#: bytes of a fresh run file besides its rows and state (headers, indexes; Case A: 25 kB)
_OVERHEAD = 64 * 1024


def recover(cls, path: str) -> h5py.File:
    """Open, read-write, the run at ``path`` left by a dead writer; ``cls``: the store class
    (its ``open_readonly``, ``create`` and constructor). Raises :class:`StoreDamaged` if its
    committed steps fail their digest, :class:`StoreWriteFailed` if there is no room to go on."""
    src = cls.open_readonly(path)
    try:
        data = src.read()  # every committed row and the state, checked against the digest
        commit = src._read_commit()
        fmt3 = src._chunk is not None and len(commit) == 3 + N_DIGEST
        end = _blocks_end(src._f) if fmt3 else None
    finally:
        src.close()
    need = copy_bytes(data)
    free = shutil.disk_usage(os.path.dirname(os.path.abspath(path))).free
    why = "the run is of format 1 or 2" if not fmt3 else None
    if fmt3 and free < COPY_ROOM * need:
        f, why = _in_place(cls, path, commit, end)
        if f is not None:
            return f
    if free < need:
        raise StoreWriteFailed(
            f"resuming {path} needs a fresh copy of its {data.n_saved} committed steps beside "
            f"it ({why}): about {human_bytes(need)}, and the disk has {human_bytes(free)} free; "
            f"free {human_bytes(need - free)} more, then resume again",
            path=path, reason="not enough free space for a copy", n_saved=data.n_saved)
    _copy(cls, path, data, commit[2])
    return open_swmr_writer(path)


def copy_bytes(data) -> int:
    """About the bytes of a fresh format-3 file holding the committed run ``data``: whole chunks
    of rows (the last, partial one in a tail slot), both state slots' arrays, headers."""
    m, p, b = data.chain.shape[1], len(data.param_names), len(data.blob_names)
    c = row_layout.chunk_rows(m, p, b)
    per_step = 8 * m * (p + 1 + b) + m
    st = data.state
    state = 0 if st is None else 8 * (st.position.size + st.log_prob.size + st.blobs.size
                                      + sum(a.size for a in st.arrays.values())) + 8192
    return -(-data.n_saved // c) * c * per_step + state + _OVERHEAD


def _blocks_end(f) -> int | None:
    """The end of the last chunk (or contiguous block) any dataset of ``f`` names, read through
    every chunk index; None if an index cannot be read."""
    ends = [0]

    def visit(name, obj) -> None:
        if not isinstance(obj, h5py.Dataset):
            return
        d = obj.id
        if obj.chunks is None:
            off = d.get_offset()
            ends.append(0 if off is None else off + d.get_storage_size())
            return
        for i in range(d.get_num_chunks()):
            info = d.get_chunk_info(i)
            if info.byte_offset is not None:
                ends.append(info.byte_offset + info.size)

    try:
        f.visititems(visit)
    except (KeyError, OSError, RuntimeError, ValueError):
        return None
    return max(ends)


def _in_place(cls, path: str, commit: tuple, end: int | None) -> tuple[h5py.File | None, str]:
    """The file at ``path`` opened read-write where it is, its committed steps checked again
    (module docstring); else None and why not."""
    lib = _hdf5_library()
    if lib is None or not hasattr(lib, "H5Fincrement_filesize"):
        return None, "h5py's HDF5 library cannot be reached to continue it in place"
    if end is None:
        return None, "a chunk index beyond its committed steps cannot be read"
    end = max(end, hdf5_end_of_file(path) or 0)
    try:
        if os.path.getsize(path) < end:
            os.truncate(path, end)  # a hole: the file system allocates no block for it
        f = open_swmr_writer(path, clear_flags=True)
    except OSError as err:
        return None, f"it cannot be opened in place ({system_reason(err)})"
    try:
        if lib.H5Fincrement_filesize(ctypes.c_int64(f.id.id), ctypes.c_uint64(0)) < 0:
            raise OSError("H5Fincrement_filesize failed")
        store = cls(f, path, writable=True)
        data = store.read()  # through the handle that will write, before anything is written
        if tuple(store._read_commit()) != tuple(commit) or data.n_saved != commit[0]:
            raise StoreDamaged(f"{path}: its commit changed while it was reopened")
    except (KeyError, OSError, RuntimeError, ValueError) as err:
        close_after_failure(f)  # nothing more reaches the file
        return None, f"it did not read back whole in place ({first_line(err)})"
    return f, ""


def _copy(cls, path: str, data, generation: int) -> None:
    """Write the committed run ``data`` into a fresh file and rename it over ``path``, keeping
    the old file as ``path + '.crashed'``."""
    tmp = path + ".recovering"
    new = cls.create(tmp, data.param_names, data.blob_names, data.chain.shape[1], data.meta,
                     overwrite=True)
    rows = (data.chain, data.log_prob, data.blobs, data.accepted)
    try:
        if data.n_saved:
            new._write_rows(0, 0, *rows)
        if data.state is not None:
            new._write_state(0, data.state)
        new._commit(data.n_saved, 0 if data.state is not None else -1, generation,
                    full_digest(rows, data.state))
    except Exception as err:
        new._write_failed(err, 0)
        new.close()
        os.unlink(tmp)
        reason = system_reason(err)
        raise StoreWriteFailed(
            f"copying the {data.n_saved} committed steps of {path} into a fresh file failed: "
            f"{reason}; {path} is kept as it was; free space, then resume again",
            path=path, reason=reason, n_saved=data.n_saved) from err
    new.close()
    _keep_aside(path, path + ".crashed")
    os.replace(tmp, path)  # one rename: killed at any moment, a run is at ``path``


def _keep_aside(path: str, aside: str) -> None:
    """Make ``aside`` a second name of ``path`` (a copy where hard links are not supported),
    replacing an older ``aside``; ``path`` itself is left in place."""
    tmp = aside + ".new"
    if os.path.lexists(tmp):
        os.unlink(tmp)
    try:
        os.link(path, tmp)
    except OSError:  # no hard links on this file system (or across a mount)
        shutil.copyfile(path, tmp)
    os.replace(tmp, aside)

