"""Plain batched NumPy Crank-Nicolson: the independent cross-check of the compiled kernels and
the baseline of ``make bench``."""

from __future__ import annotations

import numpy as np

from .forward import _DAMP, _N_START, _check
from .grid import Coefficients, Forcing, Grid


def _operator(kappa: np.ndarray, C: np.ndarray, dx: float) -> tuple[np.ndarray, np.ndarray]:
    """Dense (n_sets, N, N) operator ``A`` (``dT/dt = -A T + ...``) and the bottom rate ``c_N-1``."""
    S, N = kappa.shape
    a = kappa[:, :-1] / (C[:, 1:N] * dx**2)  # rows 1..N-1, coupling to the node above
    c = kappa / (C[:, :N] * dx**2)
    c[:, 0] *= 2.0
    A = np.zeros((S, N, N))
    idx = np.arange(N)
    A[:, idx, idx] = c
    A[:, idx[1:], idx[1:]] += a
    A[:, idx[1:], idx[:-1]] = -a
    A[:, idx[:-1], idx[1:]] = -c[:, :-1]
    return A, c[:, -1]


def solve_numpy(grid: Grid, forcing: Forcing, coeffs: Coefficients) -> np.ndarray:
    """Plain batched NumPy Crank–Nicolson (same scheme as ``solve(..., "cn")``).

    Vectorised over sets with a Python loop over time steps. It takes an independent linear
    algebra route — per interval the dense one-step propagator
    :math:`P = (I + \\tfrac{\\Delta t}{2}A)^{-1}(I - \\tfrac{\\Delta t}{2}A)` from
    ``np.linalg.solve`` (per step, with lagged kappa, when ``beta`` is set) — so it cross-checks
    the compiled reverse-Thomas kernel, and it is the baseline of the benchmark.

    Returns
    -------
    (n_sets, n_obs, n_nodes) temperatures, degC.
    """
    kappa, C, h, q, beta = _check(grid, forcing, coeffs)
    S, N = kappa.shape
    dx = grid.dx
    Ta, Tb = np.asarray(forcing.T_air, float), np.asarray(forcing.T_bottom, float)
    hs = 2.0 / (C[:, 0] * dx)
    out = np.empty((S, grid.n_obs, N + 1))
    T = np.broadcast_to(np.asarray(forcing.T0, float)[:N], (S, N)).copy()
    out[:, 0, :N] = T
    out[:, 0, N] = Tb[0]
    nonlin = beta is not None and bool(np.any(beta != 0.0))
    eye = np.eye(N)
    A, cN = _operator(kappa, C, dx)
    nstep = 0

    def lin(v: np.ndarray, j: int, w: float) -> np.ndarray:
        return v[..., j] + w * (v[..., j + 1] - v[..., j])

    for j in range(grid.n_obs - 1):
        ns = int(grid.substeps[j])
        r = 0.5 * (grid.t_obs[j + 1] - grid.t_obs[j]) / ns
        for m in range(ns):
            if nonlin or m == 0:
                if nonlin:
                    Tc = 0.5 * (
                        T
                        + np.concatenate([T[:, 1:], lin(Tb, j, m / ns)[None, None] * np.ones((S, 1))], axis=1)
                    )
                    A, cN = _operator(kappa * (1.0 + beta[:, None] * (Tc - coeffs.T_ref)), C, dx)
                K = A.copy()
                K[:, 0, 0] += hs * h[:, j]
                Linv = np.linalg.solve(eye + r * K, np.broadcast_to(eye, K.shape))
                P = np.einsum("sij,sjk->sik", Linv, eye - r * K)
            w0, wh, w1 = m / ns, (m + 0.5) / ns, (m + 1) / ns
            if nstep < _N_START or (m == 0 and _DAMP):
                # two backward-Euler half steps: T+ = Linv (T + r b(t+))
                for w in (wh, w1):
                    b = np.zeros((S, N))
                    b[:, 0] += r * hs * (h[:, j] * lin(Ta, j, w) + lin(q, j, w))
                    b[:, N - 1] += r * cN * lin(Tb, j, w)
                    T = np.einsum("sij,sj->si", Linv, T + b)
            else:
                b = np.zeros((S, N))
                b[:, 0] += (
                    r * hs * (h[:, j] * (lin(Ta, j, w0) + lin(Ta, j, w1)) + lin(q, j, w0) + lin(q, j, w1))
                )
                b[:, N - 1] += r * cN * (lin(Tb, j, w0) + lin(Tb, j, w1))
                T = np.einsum("sij,sj->si", P, T) + np.einsum("sij,sj->si", Linv, b)
            nstep += 1
        out[:, j + 1, :N] = T
        out[:, j + 1, N] = Tb[j + 1]
    return out
