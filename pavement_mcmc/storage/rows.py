"""Where the rows of an HDF5 run lie: whole chunks written once, the rest double-buffered.

Format 3. The row datasets ``chain``, ``log_prob``, ``blobs``, ``accepted`` (chunks of ``C``
steps) receive whole chunks only, each written once, to a place never written before. The rows
after the last whole chunk (fewer than ``C``) live in ``tail/<name>``, two slots of one chunk
each: a flush writes the current tail (the committed tail rows and the new ones) into the slot
the last commit does not use, the slot that commit's state is written to, and the commit names
that slot for both. When the tail fills a chunk, the chunk goes to the row dataset and the tail
starts again. The committed rows are then ``rows[:n_whole] + tail[slot][:n_saved - n_whole]``
with ``n_whole = n_saved // C * C``.

Why: formats 1 and 2 appended each block into the chunk that already held the previous block's
rows, rewriting it. Linux may cut a write to the page cache between pages when a fatal signal
arrives, so a writer killed by SIGKILL inside a flush could tear that chunk, and the committed
rows in it then failed their checksum: the run was refused, its steps lost. Now a write only
touches chunks no commit refers to (HDF5 rewrites a chunk of a fixed size in place).

Formats 1 and 2 (all rows in the row datasets) are still read and continued in their layout.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: the row datasets, in the order of the commit's digest and of :class:`.records.RunData`
ROWS = ("chain", "log_prob", "blobs", "accepted")


def chunk_rows(n_chains: int, n_params: int, n_blobs: int) -> int:
    """Steps in a chunk: up to 1024, and chunks of at most 2^18 bytes."""
    return max(1, min(1024, 2**18 // (8 * n_chains * max(n_params, n_blobs, 1))))


def create(f, n_chains: int, n_params: int, n_blobs: int) -> None:
    """The row datasets and their two tail slots in a new file ``f``."""
    m, c = n_chains, chunk_rows(n_chains, n_params, n_blobs)
    for name, shape, dt in zip(ROWS, _shapes(m, n_params, n_blobs), ["f8", "f8", "f8", "bool"],
                               strict=True):
        whole = all(shape)  # a zero-width dataset cannot be chunked (nor checksummed)
        f.create_dataset(name, shape=(0, *shape), maxshape=(None, *shape), dtype=dt,
                         chunks=(c, *shape) if whole else True, fletcher32=True)
        f.create_dataset(f"tail/{name}", shape=(2, c, *shape), dtype=dt, fletcher32=whole,
                         chunks=(1, c, *shape) if whole else None)


def _shapes(m: int, p: int, b: int) -> list[tuple[int, ...]]:
    return [(m, p), (m,), (m, b), (m,)]


def tail_length(f) -> int | None:
    """Steps a tail slot holds (a chunk's worth); None in a file of format 1 or 2."""
    return int(f["tail/chain"].shape[1]) if "tail" in f else None


def read(get: Callable, stop: int, slot: int, chunk: int | None) -> tuple[np.ndarray, ...]:
    """The rows of steps ``[0, stop)`` of a commit naming ``slot``; ``get(name, selection)``
    reads a dataset, ``chunk`` is :func:`tail_length`."""
    if chunk is None:
        return tuple(get(name, slice(None, stop)) for name in ROWS)
    n_whole = stop // chunk * chunk
    if stop == n_whole:
        return tuple(get(name, slice(None, n_whole)) for name in ROWS)
    if slot not in (0, 1):
        raise ValueError(f"commit: {stop - n_whole} tail rows but state slot {slot}")
    return tuple(np.concatenate([get(name, slice(None, n_whole)),
                                 get(f"tail/{name}", (slot, slice(None, stop - n_whole)))])
                 for name in ROWS)


def write(ds: Callable, get: Callable, start: int, slot: int, cols, chunk: int | None,
          tail: tuple | None = None) -> tuple | None:
    """Write rows ``cols`` (chain, log_prob, blobs, accepted) as steps ``[start, ...)`` for a
    commit to name ``slot``; the rows committed before sit in the other slot. ``ds(name)`` is
    the writable dataset, ``get`` and ``chunk`` as in :func:`read`; ``tail``: the committed
    tail rows if the caller kept them (else they are read). Returns the tail rows written (for
    the caller to keep once they are committed); None in formats 1 and 2."""
    if chunk is None:  # formats 1 and 2: append to the row datasets, drop what lies beyond
        stop = start + len(cols[0])
        for name, arr in zip(ROWS, cols, strict=True):
            d = ds(name)
            d.resize(stop, axis=0)
            if arr.size:
                d[start:stop] = arr
        return None
    n_whole = start // chunk * chunk
    if start > n_whole:  # the committed tail rows, in the slot the last commit names
        if tail is None or len(tail[0]) != start - n_whole:
            tail = tuple(get(f"tail/{name}", (1 - slot, slice(None, start - n_whole)))
                         for name in ROWS)
        cols = [np.concatenate([t, c]) for t, c in zip(tail, cols, strict=True)]
    n_new = len(cols[0]) // chunk * chunk  # rows of whole chunks to write now
    for name, arr in zip(ROWS, cols, strict=True):
        d = ds(name)
        if d.shape[0] != n_whole + n_new:  # drops whole chunks a killed flush left uncommitted
            d.resize(n_whole + n_new, axis=0)
        if n_new and arr.size:
            d[n_whole : n_whole + n_new] = arr[:n_new]
        if len(arr) > n_new and arr.size:
            t = ds(f"tail/{name}")
            whole = np.zeros(t.shape[1:], dtype=t.dtype)  # one write of the whole slot's chunk
            whole[: len(arr) - n_new] = arr[n_new:]
            t[slot] = whole
    return tuple(np.array(c[n_new:]) for c in cols)
