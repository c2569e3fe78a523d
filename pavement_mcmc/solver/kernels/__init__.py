"""Compiled (numba) kernels of the solver and its adjoint; internal.

numba's on-disk cache is keyed on each function's own source file, but these kernels call one
another across files (``cn_simd`` -> ``simd``, ``cn``; ``adjoint`` -> ``adjoint_simd`` ...):
after a change to a callee alone (an edit, a ``git pull`` or checkout) a caller's cached machine
code would be stale and silently wrong. So the cache of this folder is keyed on all of its
sources: when their digest differs from the one stored beside the cache, the folder's cache
files are removed before any kernel is loaded (one recompilation follows).
"""

from __future__ import annotations

import hashlib
from pathlib import Path


def refresh_cache(folder: Path) -> bool:
    """Remove ``folder``'s numba cache files if its ``*.py`` sources changed since they were
    written; True if it did. A read-only folder is left alone (numba then caches elsewhere)."""
    digest = hashlib.sha256(b"".join(p.name.encode() + p.read_bytes()
                                     for p in sorted(folder.glob("*.py")))).hexdigest()
    cache = folder / "__pycache__"
    stamp = cache / "kernel_sources.sha256"
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass
    try:
        cache.mkdir(exist_ok=True)
        for f in [*cache.glob("*.nbi"), *cache.glob("*.nbc")]:
            f.unlink(missing_ok=True)
        stamp.write_text(digest)
    except OSError:
        return False
    return True


refresh_cache(Path(__file__).parent)
