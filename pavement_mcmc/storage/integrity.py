"""Whether a stored run is whole: the digest in the commit record, and the store's two errors.

Every commit records, beside ``(n_saved, slot, generation)``, a CRC-32 of each row column
(chain, log_prob, blobs, accepted: the bytes of rows ``[0, n_saved)``, continued block by block,
so the figure does not depend on where the blocks ended) and one of the resume state. The
commit is written last and read first: a reader checks what it read against it, so a truncated
or altered file is refused (:class:`StoreDamaged`), never read as zeros. HDF5's ``fletcher32``
filter on every chunk adds a check that HDF5 itself makes while reading; it cannot see a chunk
cut off at the end of a truncated file (a chunk of zeros carries a zero checksum), the digest can.

A write that fails (a full disk, a file-size limit, an I/O error) is a
:class:`StoreWriteFailed`: the run is kept up to its last commit and the message says so.
"""

from __future__ import annotations

import os
import re
import zlib

import numpy as np

from ..data.errors import UserError
from .records import RunState, _dumps

#: entries of the digest in a commit record: one CRC-32 per row column, one of the state
N_DIGEST = 5


class StoreDamaged(UserError, ValueError):
    """A stored run is not whole (truncated, altered): it is refused rather than misread."""


class StoreWriteFailed(UserError, RuntimeError):
    """Writing a run failed (disk full, file too large, I/O error); its last commit is kept.

    Attributes: ``path``, ``reason`` (the system's words), ``n_saved`` (committed rows),
    ``n_steps`` (the sampler's committed step count), ``bytes_per_step``.
    """

    def __init__(self, message: str, *, path: str = "", reason: str = "", n_saved: int = 0,
                 n_steps: int = 0, bytes_per_step: int = 0) -> None:
        super().__init__(message)
        self.path, self.reason = path, reason
        self.n_saved, self.n_steps, self.bytes_per_step = n_saved, n_steps, bytes_per_step


def rows_digest(previous: tuple[int, ...], cols) -> tuple[int, ...]:
    """The row CRCs of ``previous`` continued over new rows ``cols`` (chain, log_prob, blobs,
    accepted; each an array with the steps first)."""
    return tuple(zlib.crc32(np.ascontiguousarray(c).tobytes(), int(p))
                 for p, c in zip(previous, cols, strict=True))


def state_digest(state: RunState | None) -> int:
    """CRC-32 of everything a resume reads: positions, log-posterior, blobs, the Generator's
    state, the sampler's extras and its named arrays (0 without a state)."""
    if state is None:
        return 0
    crc = 0
    for a in (state.position, state.log_prob, state.blobs):
        crc = zlib.crc32(np.ascontiguousarray(a, dtype=np.float64).tobytes(), crc)
    names = sorted(state.arrays)
    head = {"rng_state": state.rng_state, "extra": state.extra,
            "arrays": [[k, list(np.shape(state.arrays[k]))] for k in names]}
    crc = zlib.crc32(_dumps(head).encode(), crc)
    for k in names:
        crc = zlib.crc32(np.ascontiguousarray(state.arrays[k], dtype=np.float64).tobytes(), crc)
    return crc


def full_digest(rows: tuple, state: RunState | None) -> tuple[int, ...]:
    """The digest a commit of ``rows`` (all of them, from step 0) and ``state`` records."""
    return (*rows_digest((0, 0, 0, 0), rows), state_digest(state))


def what_differs(stored: tuple[int, ...], found: tuple[int, ...], with_rows: bool) -> list[str]:
    """Names of the parts whose CRC does not match the commit record."""
    names = ("chain", "log_prob", "blobs", "accepted", "resume state")
    return [n for i, (n, a, b) in enumerate(zip(names, stored, found, strict=True))
            if (with_rows or i == 4) and int(a) != int(b)]


def system_reason(err: BaseException) -> str:
    """The operating system's words for an HDF5 write error ('No space left on device (errno
    28)'), read off the errno HDF5 quotes; else the error's first line. Always one line."""
    for e in (err, err.__cause__, err.__context__):
        if e is None:
            continue
        if isinstance(e, OSError) and e.errno:
            return f"{os.strerror(e.errno)} (errno {e.errno})"
        m = re.search(r"errno\s*=\s*(\d+)", str(e))
        if m and int(m.group(1)):
            return f"{os.strerror(int(m.group(1)))} (errno {m.group(1)})"
    return first_line(err)


def first_line(err: BaseException) -> str:
    """The first line of an error's message (its type's name if it has none)."""
    return str(err).splitlines()[0] if str(err) else type(err).__name__


def truncation(path: str) -> str | None:
    """``"it is truncated (size of end bytes)"`` if the file is shorter than HDF5's recorded end."""
    eof, size = hdf5_end_of_file(path), os.path.getsize(path) if os.path.exists(path) else 0
    return f"it is truncated ({size} of {eof} bytes)" if eof is not None and size < eof else None


def hdf5_end_of_file(path: str) -> int | None:
    """The end-of-file address an HDF5 file's superblock (version 2 or 3) records, in bytes,
    or None for an older or unreadable superblock. A file shorter than this was cut off."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(48)
    except OSError:
        return None
    if head[:8] != b"\x89HDF\r\n\x1a\n" or len(head) < 36 or head[8] not in (2, 3):
        return None
    if head[9] != 8:  # size of offsets
        return None
    return int.from_bytes(head[28:36], "little")


def human_bytes(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000.0
    return f"{n:.1f} GB"  # pragma: no cover


# --- an HDF5 file after a failed write, a file HDF5 cannot read -----------------------------


def neutralise(f) -> None:
    """Point the HDF5 file's descriptor at /dev/null: writes still succeed (to nowhere), so
    HDF5 can close its datasets without leaving them half-closed."""
    try:
        fd = f.id.get_vfd_handle()
        nul = os.open(os.devnull, os.O_RDWR)
    except Exception:  # not a POSIX file driver: close as usual
        return
    try:
        os.dup2(nul, int(fd))
    finally:
        os.close(nul)


def close_after_failure(f) -> None:
    """Close a file whose writing failed, nothing more reaching the disk; HDF5's complaints
    (it cannot set the file's size on /dev/null) are the failure already reported."""
    neutralise(f)
    try:
        f.close()
    except Exception:
        pass


def creation_failed(path: str, err: BaseException) -> BaseException:
    """A write error of HDF5 (OSError, RuntimeError) while a run file was created, as a
    :class:`StoreWriteFailed`; any other error as it is."""
    if isinstance(err, OSError | RuntimeError) and not isinstance(err, StoreWriteFailed):
        reason = system_reason(err)
        return StoreWriteFailed(f"creating {path} failed: {reason}; nothing was stored",
                                path=path, reason=reason)
    return err


def unreadable(path: str, err: BaseException, what: str = "HDF5 cannot read it") -> StoreDamaged:
    """A damaged file's error: what HDF5 said, and whether the file was cut short."""
    return StoreDamaged(f"{path} is damaged: {truncation(path) or what} ({first_line(err)}); "
                        "it is not read")


def check_headers(f, path: str) -> None:
    """Open every object of the HDF5 file ``f`` (no data read): :class:`StoreDamaged` naming the
    first whose header HDF5 cannot read (its metadata checksums)."""
    names: list[str] = []
    try:
        f.visit(names.append)
    except (KeyError, OSError, RuntimeError, ValueError) as err:
        raise unreadable(path, err, "its objects cannot be listed") from err
    for name in names:
        try:
            dict(f[name].attrs)
        except (KeyError, OSError, RuntimeError, ValueError) as err:
            raise unreadable(path, err, f"the header of {name!r} cannot be read") from err
