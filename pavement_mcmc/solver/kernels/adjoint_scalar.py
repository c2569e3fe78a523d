"""Compiled adjoint kernels for a few parameter sets (one set at a time, scalar loops).

Internal module behind :func:`pavement_mcmc.solver.adjoint.solve_vjp`; the notation and the algorithm
are those of :mod:`pavement_mcmc.solver.kernels.adjoint` (sets-innermost kernels for many sets).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .adjoint import slot_layout
from .cn import _FM, _lin
from .scalar import _be_half, _cn_full, _scalar_factor

# ---------------------------------------------------------------------------------------------
# A few sets: one set at a time with scalar loops over depth (the sets-innermost loops above are
# all set-up for 1-4 sets), as _kernels_scalar.cn_scalar. Stored states only, N >= 2.


@njit(cache=True)
def _scalar_work(P, buf):
    """Slot layout, the state store ``(S, n_slots, N)`` view of ``buf`` and seven work vectors."""
    N, S = P.kappaT.shape
    first, slot0 = slot_layout(P.substeps, P.n_start, P.damp)
    st = buf.reshape((S, slot0[P.substeps.shape[0]] + 1, N))
    return (first, slot0, st, np.empty(N), np.empty(N), np.zeros(N), np.empty(N), np.zeros(N),
            np.empty(N), np.empty(N))


@njit(cache=True, fastmath=_FM)
def fwd_scalar(P, out, buf):
    """Crank-Nicolson set by set (the arithmetic of ``cn_scalar``), keeping every state in
    ``buf`` viewed as ``(S, n_slots, N)``; fills ``out`` (n_obs, N+1, S)."""
    T_air, T_bot, T_top, t_obs, substeps = P.T_air, P.T_bot, P.T_top, P.t_obs, P.substeps
    top, n_start, damp = P.top, P.n_start, P.damp
    N, S = P.kappaT.shape
    n_int = substeps.shape[0]
    first, slot0, st, l, u, g, invD, gt, R, _ = _scalar_work(P, buf)
    for s in range(S):
        for i in range(N):
            st[s, 0, i] = P.T0[i]
        if top:
            st[s, 0, 0] = T_top[0]
        for i in range(N):
            out[0, i, s] = st[s, 0, i]
        out[0, N, s] = T_bot[0]
        dt_fact = -1.0
        d0 = 0.0
        hc = 0.0
        for j in range(n_int):
            ns = substeps[j]
            dt = (t_obs[j + 1] - t_obs[j]) / ns
            if dt != dt_fact:
                d0, hc = _scalar_factor(P, s, 0.5 * dt, l, u, g, invD, gt)
                dt_fact = dt
            hh = hc * P.hT[j, s]
            invD0 = 0.0 if top else 1.0 / (d0 + hh)
            qa = P.qT[j, s]
            qb = P.qT[j + 1, s]
            k = slot0[j]
            for m in range(ns):
                w0 = m / ns
                w1 = (m + 1) / ns
                if first[j] + m < n_start or (m == 0 and damp):  # two backward-Euler half steps
                    for half in range(2):
                        wk = (m + 0.5) / ns if half == 0 else w1
                        T = st[s, k]
                        Tn = st[s, k + 1]
                        Ta = _lin(T_air[j], T_air[j + 1], wk)
                        Tb = _lin(T_bot[j], T_bot[j + 1], wk)
                        qk = hc * _lin(qa, qb, wk)
                        Tt = _lin(T_top[j], T_top[j + 1], wk)
                        _be_half(T, Tn, R, l, u, g, invD, invD0, hh, Ta, Tb, qk, Tt)
                        k += 1
                else:
                    T = st[s, k]
                    Tn = st[s, k + 1]
                    Ta_sum = _lin(T_air[j], T_air[j + 1], w0) + _lin(T_air[j], T_air[j + 1], w1)
                    Tb_sum = _lin(T_bot[j], T_bot[j + 1], w0) + _lin(T_bot[j], T_bot[j + 1], w1)
                    q_sum = hc * (_lin(qa, qb, w0) + _lin(qa, qb, w1))
                    Tt = _lin(T_top[j], T_top[j + 1], w1)
                    _cn_full(T, Tn, R, l, u, g, invD, invD0, hh, Ta_sum, Tb_sum, q_sum, Tt)
                    k += 1
            for i in range(N):
                out[j + 1, i, s] = st[s, k, i]
            out[j + 1, N, s] = T_bot[j + 1]


@njit(cache=True, fastmath=_FM)
def vjp_scalar(P, G, buf, acc):
    """Reverse sweep set by set over the states stored by :func:`fwd_scalar`; fills the sums
    ``acc = (acc_a, acc_b, acc_h, acc_q)``, shaped (N, S), (N, S), (n_obs-1, S), (n_obs, S), as
    :func:`_vjp_block`; ``G`` (S, n_obs, N+1): d loss / d out (same steps as
    :func:`_adjoint_step`, scalar loops; a Dirichlet top has ``invD0 = 0``, hence ``mu[0] = 0``)."""
    T_air, T_bot, t_obs, substeps, n_start, damp = P.T_air, P.T_bot, P.t_obs, P.substeps, P.n_start, P.damp
    acc_a, acc_b, acc_h, acc_q = acc
    N, S = P.kappaT.shape
    n_int = substeps.shape[0]
    first, slot0, st, l, u, g, invD, gt, lam, mu = _scalar_work(P, buf)
    for s in range(S):
        for i in range(N):
            lam[i] = 0.0
            acc_a[i, s] = 0.0
            acc_b[i, s] = 0.0
        for j in range(n_int + 1):
            acc_q[j, s] = 0.0
        dt_fact = -1.0
        d0 = 0.0
        hc = 0.0
        for j in range(n_int - 1, -1, -1):
            ns = substeps[j]
            dt = (t_obs[j + 1] - t_obs[j]) / ns
            r = 0.5 * dt
            if dt != dt_fact:
                d0, hc = _scalar_factor(P, s, r, l, u, g, invD, gt)
                dt_fact = dt
            invD0 = 0.0 if P.top else 1.0 / (d0 + hc * P.hT[j, s])
            for i in range(N):
                lam[i] += G[s, j + 1, i]
            k = slot0[j + 1]
            ah = 0.0
            for m in range(ns - 1, -1, -1):
                be = first[j] + m < n_start or (m == 0 and damp)
                for half in range(2 if be else 1):  # latest first
                    if be:
                        wb = (m + 0.5) / ns if half == 1 else (m + 1) / ns
                        ct = 0.0
                        XN = _lin(T_bot[j], T_bot[j + 1], wb)
                        Ta = _lin(T_air[j], T_air[j + 1], wb)
                        wq1 = wb
                    else:
                        w0 = m / ns
                        w1 = (m + 1) / ns
                        ct = 1.0
                        XN = _lin(T_bot[j], T_bot[j + 1], w0) + _lin(T_bot[j], T_bot[j + 1], w1)
                        Ta = _lin(T_air[j], T_air[j + 1], w0) + _lin(T_air[j], T_air[j + 1], w1)
                        wq1 = w0 + w1
                    T = st[s, k - 1]
                    Tp = st[s, k]
                    # mu = M^-T lam; lam <- mu (half step) or 2 mu - lam (CN): cl = ct
                    mu[N - 1] = lam[N - 1]
                    for i in range(N - 2, -1, -1):
                        mu[i] = lam[i] + gt[i + 1] * mu[i + 1]
                    mu[0] = mu[0] * invD0
                    for i in range(1, N):
                        mu[i] = (mu[i] + u[i - 1] * mu[i - 1]) * invD[i]
                    for i in range(N):
                        lam[i] = mu[i] + ct * (mu[i] - lam[i])
                    nu0 = r * mu[0]
                    ah += nu0 * (Tp[0] + ct * T[0] - Ta)
                    acc_q[j, s] += nu0 * ((1.0 + ct) - wq1)
                    acc_q[j + 1, s] += nu0 * wq1
                    xk = Tp[0] + ct * T[0]
                    for i in range(N - 1):
                        xk1 = Tp[i + 1] + ct * T[i + 1]
                        dk = r * (xk - xk1)
                        acc_a[i, s] += mu[i] * dk
                        acc_b[i, s] += mu[i + 1] * dk
                        xk = xk1
                    acc_a[N - 1, s] += r * mu[N - 1] * (xk - XN)
                    k -= 1
            acc_h[j, s] = ah
