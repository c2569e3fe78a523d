"""Plain batched NumPy Crank-Nicolson: the independent cross-check of the compiled kernels and
the baseline of ``make bench``."""

from __future__ import annotations

import numpy as np

from .forward import _DAMP, _N_START, _check
from .grid import Grid
from .inputs import Coefficients, Forcing


def _operator(kappa: np.ndarray, C: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dense (n_sets, N, N) operator ``A`` (``dT/dt = -A T + ...``) on nodes ``0 .. N-1``, the
    bottom rate ``c_N-1`` and the top rate ``a_1`` (1/s), straight from the finite-volume
    definitions: ``a_i = kappa_i-1 / (C_i V_i d_i-1)``, ``c_i = kappa_i / (C_i V_i d_i)`` with
    ``V_0 = d_0 / 2``, ``V_i = (d_i-1 + d_i) / 2`` (``d`` = cell widths, m)."""
    S, N = kappa.shape
    V = 0.5 * (np.r_[0.0, d[:-1]] + d)
    a = kappa[:, :-1] / (C[:, 1:N] * V[1:] * d[:-1])  # rows 1..N-1, coupling to the node above
    c = kappa / (C[:, :N] * V * d)
    A = np.zeros((S, N, N))
    idx = np.arange(N)
    A[:, idx, idx] = c
    A[:, idx[1:], idx[1:]] += a
    A[:, idx[1:], idx[:-1]] = -a
    A[:, idx[:-1], idx[1:]] = -c[:, :-1]
    return A, c[:, -1], a[:, 0]


def solve_numpy(grid: Grid, forcing: Forcing, coeffs: Coefficients) -> np.ndarray:
    """Plain batched NumPy Crank–Nicolson (same scheme as ``solve(..., "cn")``).

    Vectorised over sets with a Python loop over time steps. It takes an independent linear
    algebra route — per interval the dense one-step propagator
    :math:`P = (I + \\tfrac{\\Delta t}{2}A)^{-1}(I - \\tfrac{\\Delta t}{2}A)` from
    ``np.linalg.solve`` (per step, with lagged kappa, when ``beta`` is set) — and builds ``A``
    from the cell widths directly (not the kernels' geometry factors), so it cross-checks the
    compiled reverse-Thomas kernels on uniform and stretched grids, with a Robin or a
    Dirichlet top (``forcing.T_top``: the unknowns are nodes 1..N-1). It is the baseline of the
    benchmark.

    Returns
    -------
    (n_sets, n_obs, n_nodes) temperatures, degC.
    """
    kappa, C, h, q, beta = _check(grid, forcing, coeffs)
    S, N = kappa.shape
    d = grid.dx_cells
    Ta, Tb = np.asarray(forcing.T_air, float), np.asarray(forcing.T_bottom, float)
    Tt = None if forcing.T_top is None else np.asarray(forcing.T_top, float)
    k0 = 0 if Tt is None else 1  # first unknown node
    hs = 2.0 / (C[:, 0] * d[0])
    out = np.empty((S, grid.n_obs, N + 1))
    T = np.broadcast_to(np.asarray(forcing.T0, float)[:N], (S, N)).copy()
    if Tt is not None:
        T[:, 0] = Tt[0]
    out[:, 0, :N] = T
    out[:, 0, N] = Tb[0]
    nonlin = beta is not None and bool(np.any(beta != 0.0))
    eye = np.eye(N - k0)
    A, cN, a1 = _operator(kappa, C, d)
    nstep = 0

    def lin(v: np.ndarray, j: int, w: float) -> np.ndarray:
        return v[..., j] + w * (v[..., j + 1] - v[..., j])

    def rhs(j: int, w: float) -> np.ndarray:
        """``b(t)`` on the unknowns, the forcing part of ``dT/dt = -A T + b``."""
        b = np.zeros((S, N))
        if Tt is None:
            b[:, 0] = hs * (h[:, j] * lin(Ta, j, w) + lin(q, j, w))
        else:
            b[:, 1] = a1 * lin(Tt, j, w)
        b[:, N - 1] += cN * lin(Tb, j, w)
        return b[:, k0:]

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
                    A, cN, a1 = _operator(kappa * (1.0 + beta[:, None] * (Tc - coeffs.T_ref)), C, d)
                K = A[:, k0:, k0:].copy()
                if Tt is None:
                    K[:, 0, 0] += hs * h[:, j]
                Linv = np.linalg.solve(eye + r * K, np.broadcast_to(eye, K.shape))
                P = np.einsum("sij,sjk->sik", Linv, eye - r * K)
            w0, wh, w1 = m / ns, (m + 0.5) / ns, (m + 1) / ns
            U = T[:, k0:]
            if nstep < _N_START or (m == 0 and _DAMP):
                # two backward-Euler half steps: T+ = Linv (T + r b(t+))
                for w in (wh, w1):
                    U = np.einsum("sij,sj->si", Linv, U + r * rhs(j, w))
            else:
                b = r * (rhs(j, w0) + rhs(j, w1))
                U = np.einsum("sij,sj->si", P, U) + np.einsum("sij,sj->si", Linv, b)
            T = T.copy()
            T[:, k0:] = U
            if Tt is not None:
                T[:, 0] = lin(Tt, j, w1)
            nstep += 1
        out[:, j + 1, :N] = T
        out[:, j + 1, N] = Tb[j + 1]
    return out
