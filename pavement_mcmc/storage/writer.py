"""Who writes a run file: the writer record's pid and host, whether that process still lives,
and the files this process gave up writing (after a failed write their writer is not alive)."""

from __future__ import annotations

import json
import os

from .integrity import unreadable
from .swmr import open_swmr_reader

#: run files this process gave up writing after a failed write: their writer is not alive
_ABANDONED: set[str] = set()


def _writer_record(path: str) -> dict:
    """The pid and host recorded by a run file's writer ({} if none or unreadable)."""
    try:
        with open_swmr_reader(path) as fr:
            raw = bytes(fr["writer"][...]).rstrip(b"\0")
        return json.loads(raw) if raw else {}
    except (KeyError, OSError, RuntimeError, ValueError) as err:
        raise unreadable(path, err) from err


def _pid_alive(pid: int) -> bool:
    """Whether process ``pid`` still runs. A zombie does not: it has exited and holds no file,
    but ``kill(pid, 0)`` still finds it until its parent reaps it (a killed batch's Dask worker,
    orphaned, stays a zombie for about a second here before init reaps it; a batch run again
    at once found its store "being written" by it, tests/batch/test_batch.py)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    try:  # Linux: the state letter after the command name in /proc/<pid>/stat
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as fh:
            state = fh.read().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return True
    return state not in ("Z", "X")
