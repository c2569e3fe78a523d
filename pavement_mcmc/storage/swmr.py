"""Open a run file for reading in SWMR mode, with HDF5's metadata retries bounded.

A SWMR reader that meets a metadata block failing its checksum (an object header, a chunk
index) reads it again, in case the writer was half-way through writing it, and waits longer
before each attempt: about 2^k ns before attempt k, 100 attempts by default. A block that is
really damaged, a flipped byte or a file cut off before its chunk index, then kept a reader
waiting for hours (measured: past 5 minutes with 0.2 s of CPU; 25 attempts take 0.04 s). The
attempts are set to :data:`READ_ATTEMPTS` here, about 0.3 s of waiting in all; a writer's race
is retried above that by the store (:meth:`.base.Store._consistent_read`).

A writer reopening a run opens it in SWMR mode at once (:func:`open_swmr_writer`): h5py's
``File(path, "r+", swmr=True)`` ignores ``swmr``, and a writer killed between its plain
read-write open and ``swmr_mode = True`` left the file marked as written without SWMR, which
no SWMR reader opens ("file is not already open for SWMR writing") and so no resume either.

h5py does not wrap ``H5Pset_metadata_read_attempts``; it is called through ``ctypes`` in the
HDF5 library h5py itself uses: looked up through the handle of h5py's extension module
``h5py.h5p``, whose dependencies are searched (h5py's libhdf5, bundled or the system's), never
through whichever libhdf5 a process holds first (another wheel's, loaded by ``ctypes``, would be
called with h5py's property list and refuse it). A library whose version is not the one h5py
reports is not used; HDF5's default then stays.
"""

from __future__ import annotations

import ctypes
import os

#: metadata read attempts of a SWMR reader (HDF5's default is 100)
READ_ATTEMPTS = 28

_LIB: list = []  # the HDF5 library h5py uses (or None), looked up once


def _hdf5_library():
    """h5py's HDF5 library as a ``ctypes.CDLL`` (None where it cannot be reached)."""
    if not _LIB:
        import h5py

        lib = None
        try:  # dlopen of a loaded module returns its handle; dlsym searches its dependencies
            cand = ctypes.CDLL(h5py.h5p.__file__)
            if hasattr(cand, "H5Pset_metadata_read_attempts") and _version(cand) == \
                    tuple(h5py.version.hdf5_version_tuple[:3]):
                lib = cand
        except (AttributeError, OSError):
            lib = None
        _LIB.append(lib)
    return _LIB[0]


def _version(lib) -> tuple[int, int, int]:
    """The version of the HDF5 library ``lib`` (``H5get_libversion``)."""
    v = [ctypes.c_uint(0) for _ in range(3)]
    lib.H5get_libversion(*(ctypes.byref(x) for x in v))
    return tuple(x.value for x in v)


def bound_read_attempts(fapl, attempts: int = READ_ATTEMPTS) -> bool:
    """Set a file access property list's metadata read attempts; False if HDF5's default stays."""
    lib = _hdf5_library()
    if lib is None:
        return False
    return lib.H5Pset_metadata_read_attempts(ctypes.c_int64(fapl.id), ctypes.c_uint(attempts)) >= 0


def open_swmr_reader(path: str, locking: bool = True):
    """``h5py.File(path, "r", libver="latest", swmr=True[, locking=False])``, with the metadata
    read attempts bounded (module docstring)."""
    import h5py

    fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    fapl.set_libver_bounds(h5py.h5f.LIBVER_LATEST, h5py.h5f.LIBVER_LATEST)
    if not locking:
        fapl.set_file_locking(False, True)
    bound_read_attempts(fapl)
    fid = h5py.h5f.open(os.fsencode(path), h5py.h5f.ACC_RDONLY | h5py.h5f.ACC_SWMR_READ, fapl=fapl)
    return h5py.File(fid)


def open_swmr_writer(path: str, clear_flags: bool = False):
    """``h5py.File(path, "r+", libver="latest")`` already in SWMR write mode. ``clear_flags``:
    first clear the superblock's status flags, the mark of a writer that did not close the file
    (HDF5's property ``clear_status_flags``, set as ``h5clear`` does; OSError if it cannot be)."""
    import h5py

    fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    fapl.set_libver_bounds(h5py.h5f.LIBVER_LATEST, h5py.h5f.LIBVER_LATEST)
    if clear_flags:
        lib, clear = _hdf5_library(), ctypes.c_bool(True)
        if lib is None or lib.H5Pset(ctypes.c_int64(fapl.id), b"clear_status_flags",
                                     ctypes.byref(clear)) < 0:
            raise OSError("HDF5's property clear_status_flags cannot be set")
    flags = h5py.h5f.ACC_RDWR | h5py.h5f.ACC_SWMR_WRITE
    return h5py.File(h5py.h5f.open(os.fsencode(path), flags, fapl=fapl))
