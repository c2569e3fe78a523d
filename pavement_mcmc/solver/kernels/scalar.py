"""Compiled Crank-Nicolson kernel for a FEW parameter sets (one set at a time, scalar loops).

Internal module. For a handful of sets the sets-innermost kernels of
:mod:`pavement_mcmc.solver.kernels.cn` spend their time in loop set-up (inner loops of length 1); this
kernel runs the identical arithmetic (same operation order, so the results agree to rounding)
with plain scalar loops over depth. Constant-kappa Crank-Nicolson only, ``N >= 2`` unknowns;
Robin or Dirichlet top, any grid (the notation of :mod:`pavement_mcmc.solver.kernels.cn`; the
top is handled without a branch: ``invD0 = 0`` and ``T_top`` added, see :func:`_be_half`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .cn import _FM, _lin


@njit(cache=True, fastmath=_FM, inline="always")
def _be_half(T, Tn, R, l, u, g, invD, invD0, hh, Ta, Tb, qk, Tt):
    """One backward-Euler half step of one set from ``T`` into ``Tn`` (may be ``T``). Node 0:
    ``(...) invD0 + Tt``; Robin: ``Tt = 0``; Dirichlet top: ``invD0 = 0``, ``Tt = T_top``."""
    N = T.shape[0]
    R[N - 1] = T[N - 1] + u[N - 1] * Tb
    for i in range(N - 2, 0, -1):
        R[i] = T[i] + g[i + 1] * R[i + 1]
    Tn[0] = (T[0] + hh * Ta + qk + g[1] * R[1]) * invD0 + Tt
    for i in range(1, N):
        Tn[i] = (R[i] + l[i] * Tn[i - 1]) * invD[i]


@njit(cache=True, fastmath=_FM, inline="always")
def _cn_full(T, Tn, R, l, u, g, invD, invD0, hh, Ta_sum, Tb_sum, q_sum, Tt):
    """One Crank-Nicolson step of one set from ``T`` into ``Tn`` (may be ``T``); node 0 as
    :func:`_be_half` (branch-free: ``fma(rr, invD0, 0)`` rounds as ``rr invD0``)."""
    N = T.shape[0]
    t = T[N - 1]
    R[N - 1] = t + l[N - 1] * (T[N - 2] - t) + u[N - 1] * (Tb_sum - t)
    for i in range(N - 2, 0, -1):
        t = T[i]
        R[i] = t + l[i] * (T[i - 1] - t) + u[i] * (T[i + 1] - t) + g[i + 1] * R[i + 1]
    t = T[0]
    rr = t + u[0] * (T[1] - t) + hh * (Ta_sum - t) + q_sum + g[1] * R[1]
    Tn[0] = rr * invD0 + Tt
    for i in range(1, N):
        Tn[i] = (R[i] + l[i] * Tn[i - 1]) * invD[i]


@njit(cache=True, fastmath=_FM)
def _scalar_factor(P, s, r, l, u, g, invD, gt):
    """Rates and bottom-up factorisation of ``I + r A`` for set ``s`` (as
    :func:`pavement_mcmc.solver.kernels.cn._cn_factor`), and the gains ``gt`` of its transpose (for the
    adjoint). Returns ``(d0, hc)`` (surface pivot without ``h``, ``r hs``)."""
    kappaT, CT, ga, rho = P.kappaT, P.CT, P.geo[0], P.geo[1]
    N = l.shape[0]
    inv = ga[N - 1] / CT[N - 1, s]
    l[N - 1] = r * (kappaT[N - 2, s] * inv)
    u[N - 1] = r * (kappaT[N - 1, s] * (inv * rho[N - 1]))
    invD[N - 1] = 1.0 / (1.0 + l[N - 1] + u[N - 1])
    d0 = 0.0
    for i in range(N - 2, -1, -1):
        if i == 0:
            a_i = 0.0
            c_i = 2.0 * kappaT[0, s] * ga[0] / CT[0, s]
        else:
            inv = ga[i] / CT[i, s]
            a_i = kappaT[i - 1, s] * inv
            c_i = kappaT[i, s] * (inv * rho[i])
        l[i] = r * a_i
        u[i] = r * c_i
        g[i + 1] = u[i] * invD[i + 1]
        dd = 1.0 + l[i] + u[i] - g[i + 1] * l[i + 1]
        if i > 0:
            invD[i] = 1.0 / dd
        else:
            d0 = dd
    for i in range(1, N):
        gt[i] = l[i] * invD[i]
    return d0, r * (2.0 / (CT[0, s] * P.dx0))


@njit(cache=True, fastmath=_FM)
def cn_scalar(P, out):
    """CN for every set of the :class:`~pavement_mcmc.solver.kernels.cn.Problem` ``P``, one
    after the other (linear only); fills ``out`` (n_obs, N+1, S)."""
    T_air, T_bot, T_top, t_obs, substeps = P.T_air, P.T_bot, P.T_top, P.t_obs, P.substeps
    top, n_start, damp = P.top, P.n_start, P.damp
    N, S = P.kappaT.shape
    n_int = substeps.shape[0]
    l = np.empty(N)
    u = np.empty(N)
    g = np.zeros(N)
    invD = np.empty(N)
    gt = np.zeros(N)
    R = np.empty(N)
    T = np.empty(N)
    for s in range(S):
        for i in range(N):
            T[i] = P.T0[i]
        if top:
            T[0] = T_top[0]
        for i in range(N):
            out[0, i, s] = T[i]
        out[0, N, s] = T_bot[0]
        dt_fact = -1.0
        d0 = 0.0
        hc = 0.0
        nstep = 0
        for j in range(n_int):
            ns = substeps[j]
            dt = (t_obs[j + 1] - t_obs[j]) / ns
            if dt != dt_fact:  # refactorise only when the step length changes
                d0, hc = _scalar_factor(P, s, 0.5 * dt, l, u, g, invD, gt)
                dt_fact = dt
            hh = hc * P.hT[j, s]
            invD0 = 0.0 if top else 1.0 / (d0 + hh)
            qa = P.qT[j, s]
            qb = P.qT[j + 1, s]
            for m in range(ns):
                w0 = m / ns
                w1 = (m + 1) / ns
                if nstep < n_start or (m == 0 and damp):  # two backward-Euler half steps
                    for k in range(2):
                        wk = (m + 0.5) / ns if k == 0 else w1
                        Ta = _lin(T_air[j], T_air[j + 1], wk)
                        Tb = _lin(T_bot[j], T_bot[j + 1], wk)
                        qk = hc * _lin(qa, qb, wk)
                        Tt = _lin(T_top[j], T_top[j + 1], wk)
                        _be_half(T, T, R, l, u, g, invD, invD0, hh, Ta, Tb, qk, Tt)
                else:
                    Ta_sum = _lin(T_air[j], T_air[j + 1], w0) + _lin(T_air[j], T_air[j + 1], w1)
                    Tb_sum = _lin(T_bot[j], T_bot[j + 1], w0) + _lin(T_bot[j], T_bot[j + 1], w1)
                    q_sum = hc * (_lin(qa, qb, w0) + _lin(qa, qb, w1))
                    Tt = _lin(T_top[j], T_top[j + 1], w1)
                    _cn_full(T, T, R, l, u, g, invD, invD0, hh, Ta_sum, Tb_sum, q_sum, Tt)
                nstep += 1
            for i in range(N):
                out[j + 1, i, s] = T[i]
            out[j + 1, N, s] = T_bot[j + 1]
