"""``solve``: nodal temperatures of many parameter sets in one compiled call (the scheme is
documented in :mod:`pavement_mcmc.solver`)."""

from __future__ import annotations

import numba
import numpy as np

from .grid import Coefficients, Forcing, Grid
from .kernels import cn as _kernels
from .kernels import dff as _kernels_dff
from .kernels.scalar import cn_scalar

SCHEMES = ("cn", "dff")
_BLOCK_MAX = 256  # most parameter sets per compiled block (working set stays in L2)
_SCALAR_MAX = 4  # up to this many sets: the one-set-at-a-time scalar CN kernel
_PARALLEL_MIN = 64  # from this many sets: blocks run on numba's threads
_N_START = 1  # CN steps replaced by two backward-Euler half steps each (Rannacher start-up)
_DAMP = True  # ... and the first CN step of every observation interval (h jumps there)

def _check(grid: Grid, forcing: Forcing, coeffs: Coefficients) -> tuple[np.ndarray, ...]:
    """Validate shapes and values; return float64 kappa, C, h, q, beta (beta may be None)."""
    n_obs, n_nodes = grid.n_obs, grid.n_nodes
    kappa = np.asarray(coeffs.kappa, dtype=float)
    if kappa.ndim != 2 or kappa.shape[0] < 1:
        raise ValueError(f"Coefficients.kappa must be (n_sets, n_nodes-1), got {kappa.shape}")
    S = kappa.shape[0]
    want = {
        "kappa": (S, n_nodes - 1),
        "C": (S, n_nodes),
        "h": (S, n_obs - 1),
        "q": (S, n_obs),
    }
    arrays = {"kappa": kappa}
    for name in ("C", "h", "q"):
        arrays[name] = np.asarray(getattr(coeffs, name), dtype=float)
    for name, shape in want.items():
        if arrays[name].shape != shape:
            raise ValueError(
                f"Coefficients.{name} has shape {arrays[name].shape}, expected {shape} "
                f"(n_sets={S}, n_nodes={n_nodes}, n_obs={n_obs})"
            )
        if not np.all(np.isfinite(arrays[name])):
            raise ValueError(f"Coefficients.{name} contains non-finite values")
    if np.any(kappa <= 0) or np.any(arrays["C"][:, :-1] <= 0):
        raise ValueError("Coefficients.kappa and C must be positive")
    beta = coeffs.beta
    if beta is not None:
        beta = np.asarray(beta, dtype=float)
        if beta.shape != (S,) or not np.all(np.isfinite(beta)):
            raise ValueError(f"Coefficients.beta must be finite (n_sets,)=({S},), got {beta.shape}")
    for name, shape in (("T_air", (n_obs,)), ("T_bottom", (n_obs,)), ("T0", (n_nodes,))):
        arr = np.asarray(getattr(forcing, name))
        if arr.shape != shape:
            raise ValueError(f"Forcing.{name} has shape {arr.shape}, expected {shape}")
    return kappa, arrays["C"], arrays["h"], arrays["q"], beta


def solve(grid: Grid, forcing: Forcing, coeffs: Coefficients, scheme: str = "cn") -> np.ndarray:
    """Nodal temperatures at the observation times for every parameter set.

    Parameters
    ----------
    grid : space-time grid.
    forcing : air/bottom temperatures and the initial profile, degC.
    coeffs : per-set kappa, C, h, q (and optional beta), SI units.
    scheme : ``"cn"`` (Crank–Nicolson, default) or ``"dff"`` (Du Fort–Frankel).

    Returns
    -------
    (n_sets, n_obs, n_nodes) temperatures, degC. Row ``0`` is ``forcing.T0``; the last node is
    ``T_bottom``. (A transposed view of the kernel's sets-innermost buffer.)
    """
    if scheme not in SCHEMES:
        raise ValueError(f"unknown scheme {scheme!r}; valid schemes: {', '.join(SCHEMES)}")
    kappa, C, h, q, beta = _check(grid, forcing, coeffs)
    S = kappa.shape[0]
    nonlin = beta is not None and bool(np.any(beta != 0.0))
    out = np.empty((grid.n_obs, grid.n_nodes, S))
    T_air = np.ascontiguousarray(forcing.T_air, dtype=float)
    T_bot = np.ascontiguousarray(forcing.T_bottom, dtype=float)
    T0 = np.ascontiguousarray(forcing.T0, dtype=float)
    kT, CT, hT, qT = (np.ascontiguousarray(v.T) for v in (kappa, C, h, q))
    if scheme == "cn" and not nonlin and S <= _SCALAR_MAX and grid.n_nodes > 2:
        cn_scalar(kT, CT, hT, qT, T_air, T_bot, T0, grid.t_obs, grid.substeps, grid.dx, _N_START, _DAMP, out)
        return out.transpose(2, 0, 1)
    threads = numba.get_num_threads()
    parallel = threads > 1 and S >= _PARALLEL_MIN
    per_thread = -(-S // threads) if parallel else S
    block = min(_BLOCK_MAX, -(-per_thread // 8) * 8)
    kernels = {
        ("cn", False): _kernels.cn_serial,
        ("cn", True): _kernels.cn_parallel,
        ("dff", False): _kernels_dff.dff_serial,
        ("dff", True): _kernels_dff.dff_serial,
    }
    kernels[scheme, parallel](
        kT,
        CT,
        hT,
        qT,
        np.zeros(S) if beta is None else np.ascontiguousarray(beta),
        float(coeffs.T_ref),
        nonlin,
        T_air,
        T_bot,
        T0,
        grid.t_obs,
        grid.substeps,
        grid.dx,
        _N_START,
        _DAMP,
        block,
        out,
    )
    return out.transpose(2, 0, 1)
