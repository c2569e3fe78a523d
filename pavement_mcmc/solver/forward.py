"""``solve``: nodal temperatures of many parameter sets in one compiled call (the scheme is
documented in :mod:`pavement_mcmc.solver`)."""

from __future__ import annotations

import math

import numba
import numpy as np

from .grid import Grid
from .inputs import Coefficients, Forcing
from .kernels import cn as _kernels
from .kernels import cn_simd as _kernels_simd
from .kernels import dff as _kernels_dff
from .kernels.scalar import cn_scalar

SCHEMES = ("cn", "dff")
_BLOCK_MAX = 256  # most parameter sets per compiled block (working set stays in L2)
_SCALAR_MAX = 4  # up to this many sets: the one-set-at-a-time scalar CN kernel
_PARALLEL_MIN = 64  # from this many sets: blocks run on numba's threads
# ... or from 16 sets (two blocks of 8) when a solve is long: sets x solver steps x nodes above
# this. Off: on the 72-h grass window (16 sets, 2 cores) two threads gave a gradient in 1.67 ms
# against 1.98 ms on one when the machine was idle, but 15.9 ms against 2.3 ms when another
# process held the second core (the threads meet at every observation interval and wait for a
# descheduled partner). The same numbers either way (blocks are independent).
_PARALLEL_WORK = math.inf
_N_START = 1  # CN steps replaced by two backward-Euler half steps each (Rannacher start-up)
_DAMP = True  # ... and the first CN step of every observation interval (h jumps there)


def _all_finite(a: np.ndarray) -> bool:
    """``np.isfinite(a).all()``; fast path: a sum is finite unless an entry is not (or it
    overflows, then the exact test decides). ``np.all`` costs ~4 us per call on small arrays."""
    return math.isfinite(a.sum()) or bool(np.isfinite(a).all())


def _check(grid: Grid, forcing: Forcing, coeffs: Coefficients) -> tuple[np.ndarray, ...]:
    """Validate shapes and values; return float64 kappa, C, h, q, beta (beta may be None)."""
    n_obs, n_nodes = grid.n_obs, grid.n_nodes
    kappa = np.asarray(coeffs.kappa, dtype=float)
    if kappa.ndim != 2 or kappa.shape[0] < 1:
        raise ValueError(f"Coefficients.kappa must be (n_sets, n_nodes-1), got {kappa.shape}")
    S = kappa.shape[0]
    C = np.asarray(coeffs.C, dtype=float)
    h = np.asarray(coeffs.h, dtype=float)
    q = np.asarray(coeffs.q, dtype=float)
    for name, arr, shape in (("kappa", kappa, (S, n_nodes - 1)), ("C", C, (S, n_nodes)),
                             ("h", h, (S, n_obs - 1)), ("q", q, (S, n_obs))):
        if arr.shape != shape:
            raise ValueError(
                f"Coefficients.{name} has shape {arr.shape}, expected {shape} "
                f"(n_sets={S}, n_nodes={n_nodes}, n_obs={n_obs})"
            )
        if not _all_finite(arr):
            raise ValueError(f"Coefficients.{name} contains non-finite values")
    if not (kappa.min() > 0 and C[:, :-1].min() > 0):
        raise ValueError("Coefficients.kappa and C must be positive")
    beta = coeffs.beta
    if beta is not None:
        beta = np.asarray(beta, dtype=float)
        if beta.shape != (S,) or not _all_finite(beta):
            raise ValueError(f"Coefficients.beta must be finite (n_sets,)=({S},), got {beta.shape}")
    if forcing.__dict__.get("_checked_for") is not grid:  # once per forcing and grid (frozen)
        _check_forcing(grid, forcing)
        forcing.__dict__["_checked_for"] = grid
    return kappa, C, h, q, beta


def _check_forcing(grid: Grid, forcing: Forcing) -> None:
    """The forcing's shapes on ``grid``, and a finite Dirichlet top."""
    n_obs, n_nodes = grid.n_obs, grid.n_nodes
    for name, shape in (("T_air", (n_obs,)), ("T_bottom", (n_obs,)), ("T0", (n_nodes,))):
        arr = np.asarray(getattr(forcing, name))
        if arr.shape != shape:
            raise ValueError(f"Forcing.{name} has shape {arr.shape}, expected {shape}")
    T_top = getattr(forcing, "T_top", None)
    if T_top is not None:
        T_top = np.asarray(T_top, dtype=float)
        if T_top.shape != (n_obs,) or not _all_finite(T_top):
            raise ValueError(f"Forcing.T_top must be finite (n_obs,)=({n_obs},), got shape {T_top.shape}")
        if n_nodes < 3:
            raise ValueError(f"a Dirichlet top (Forcing.T_top) needs a grid with >= 3 nodes, got {n_nodes}")


def _problem(
    grid: Grid, forcing: Forcing, kappa, C, h, q, beta, T_ref: float, nonlin: bool
) -> _kernels.Problem:
    """The kernels' :class:`~.kernels.cn.Problem`: sets-innermost copies and the geometry."""
    T_top = getattr(forcing, "T_top", None)
    geom = grid._rate_geometry()
    return _kernels.Problem(
        *(np.ascontiguousarray(v.T) for v in (kappa, C, h, q)),
        np.zeros(kappa.shape[0]) if beta is None else np.ascontiguousarray(beta, dtype=float),
        *(np.ascontiguousarray(v, dtype=float) for v in (forcing.T_air, forcing.T_bottom)),
        np.zeros(grid.n_obs) if T_top is None else np.ascontiguousarray(T_top, dtype=float),
        np.ascontiguousarray(forcing.T0, dtype=float),
        grid.t_obs,
        grid.substeps,
        geom.kernel,
        geom.dx0,
        float(T_ref),
        bool(nonlin),
        T_top is not None,
        int(_N_START),
        bool(_DAMP),
    )


def solve(grid: Grid, forcing: Forcing, coeffs: Coefficients, scheme: str = "cn") -> np.ndarray:
    """Nodal temperatures at the observation times for every parameter set.

    Parameters
    ----------
    grid : space-time grid, uniform or stretched (``"dff"``: uniform only).
    forcing : air/bottom temperatures and the initial profile, degC; with ``forcing.T_top`` a
        Dirichlet top (``"cn"`` only; ``h`` and ``q`` are then ignored).
    coeffs : per-set kappa, C, h, q (and optional beta), SI units.
    scheme : ``"cn"`` (Crank–Nicolson, default) or ``"dff"`` (Du Fort–Frankel).

    Returns
    -------
    (n_sets, n_obs, n_nodes) temperatures, degC. Row ``0`` is ``forcing.T0`` (its first node
    ``T_top[0]`` with a Dirichlet top); the last node is ``T_bottom``, the first ``T_top`` if
    given. (A transposed view of the kernel's sets-innermost buffer.)
    """
    if scheme not in SCHEMES:
        raise ValueError(f"unknown scheme {scheme!r}; valid schemes: {', '.join(SCHEMES)}")
    kappa, C, h, q, beta = _check(grid, forcing, coeffs)
    if scheme == "dff" and (not grid.uniform or getattr(forcing, "T_top", None) is not None):
        raise ValueError(
            "scheme 'dff' (Du Fort-Frankel, kept for parity with the paper) runs on a uniform grid "
            "with a Robin top only; use scheme 'cn' for a stretched grid or a Dirichlet top (T_top)"
        )
    S = kappa.shape[0]
    nonlin = beta is not None and bool(np.any(beta != 0.0))
    out = np.empty((grid.n_obs, grid.n_nodes, S))
    P = _problem(grid, forcing, kappa, C, h, q, beta, coeffs.T_ref, nonlin)
    if scheme == "cn" and not nonlin and S <= _SCALAR_MAX and grid.n_nodes > 2:
        cn_scalar(P, out)
        return out.transpose(2, 0, 1)
    parallel = _parallel(S, grid)
    if scheme == "dff":  # serial only (parity, not speed), in blocks sized as cn's
        kernel = _kernels_dff.dff_serial
    else:
        kernel = _kernels_simd.cn_parallel if parallel else _kernels_simd.cn_serial
    kernel(P, _block(S, parallel), out)
    return out.transpose(2, 0, 1)


def _parallel(S: int, grid: Grid | None = None) -> bool:
    """Run blocks of sets on numba's threads? Many sets, or 16 and more on a long solve."""
    if numba.get_num_threads() < 2:
        return False
    if S >= _PARALLEL_MIN:
        return True
    if S < 16 or grid is None or _PARALLEL_WORK == math.inf:  # no need to count the work
        return False
    return float(S) * float(np.sum(grid.substeps)) * grid.n_nodes >= _PARALLEL_WORK


def _block(S: int, parallel: bool) -> int:
    """Sets per compiled block: all of them (serial) or one share per thread, rounded up to a
    multiple of 8, at most ``_BLOCK_MAX``."""
    per_thread = -(-S // numba.get_num_threads()) if parallel else S
    return min(_BLOCK_MAX, -(-per_thread // 8) * 8)
