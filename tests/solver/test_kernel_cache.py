"""The kernels' numba cache is keyed on all their sources (solver/kernels/__init__.py)."""

from __future__ import annotations

from pavement_mcmc.solver.kernels import refresh_cache


def test_a_change_to_any_kernel_source_clears_the_folders_cache(tmp_path):
    """numba alone would keep ``caller``'s cached code when only ``callee.py`` changed."""
    (tmp_path / "caller.py").write_text("from .callee import f\n")
    (tmp_path / "callee.py").write_text("def f(): return 1\n")
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    (cache / "caller.g-1.py311.nbi").write_bytes(b"index")
    (cache / "caller.g-1.py311.1.nbc").write_bytes(b"code")
    (cache / "caller.cpython-311.pyc").write_bytes(b"bytecode")
    assert refresh_cache(tmp_path)  # no stamp yet: cleared, stamped
    assert sorted(p.name for p in cache.iterdir()) == ["caller.cpython-311.pyc", "kernel_sources.sha256"]
    (cache / "caller.g-1.py311.nbi").write_bytes(b"index")  # numba writes its cache again
    assert not refresh_cache(tmp_path)  # same sources: kept
    assert (cache / "caller.g-1.py311.nbi").exists()
    (tmp_path / "callee.py").write_text("def f(): return 2\n")  # only the callee changes
    assert refresh_cache(tmp_path)
    assert not (cache / "caller.g-1.py311.nbi").exists()
