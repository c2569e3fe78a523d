"""Small files of a run (``result.json``, ``summary.csv``, ``report.html``, ...) written whole or
not at all: a full disk or a kill while writing leaves the previous file (or none), never a
cut-off one that a later command would misread."""

from __future__ import annotations

import errno
import os
from pathlib import Path

#: the errors of a full disk, a quota or a file-size limit (``ulimit -f``)
DISK_FULL = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})


def write_atomic(path: str | Path, text: str, encoding: str = "utf-8") -> None:
    """Write ``text`` to a temporary file beside ``path``, flush it to disk, then rename it over
    ``path`` (atomic on POSIX). On any error the temporary file is removed and ``path`` is
    unchanged; the error is raised (an ``OSError`` with ``filename`` = ``path``)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", encoding=encoding, newline="") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as err:  # named by the file meant, not the temporary one
        tmp.unlink(missing_ok=True)
        raise OSError(err.errno, err.strerror, str(path)) from err
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
