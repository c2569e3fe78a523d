"""Compiled forward-with-store and reverse sweep (discrete adjoint) of the linear CN kernel.

Internal module; the public API and the derivation live in :mod:`pavement_mcmc.solver.adjoint`, the
notation and the sets-innermost layout in :mod:`pavement_mcmc.solver.kernels.cn`. The steps are those of
the forward kernel's own (``_kernels._cn_step`` / ``_be_step`` on a copy of the state in the
next slot; the factorisation is ``_kernels._prepare``).

State slots. Every solver state of the run gets a slot: slot 0 is ``T0``; a Crank-Nicolson step
adds one slot, a step replaced by two backward-Euler half steps two (midpoint, end).
``slot0[j]`` is the slot of the state at ``t_obs[j]``. The reverse sweep needs the states of one
observation interval at a time; they come either from a store filled by :func:`fwd_serial` /
:func:`fwd_parallel` (``buf``: each block of ``nb`` sets owns the contiguous segment
``buf[s0 n_slots N : (s0 + nb) n_slots N]``, viewed as ``(n_slots, N, nb)``) or, without a
store, are recomputed per interval from the forward output ``out`` (the checkpoints). For up to
``solver._SCALAR_MAX`` sets, :func:`fwd_scalar` / :func:`vjp_scalar` do the same one set at a
time with scalar loops (in :mod:`._kernels_adjoint_scalar`, the arithmetic of
``_kernels_scalar.cn_scalar``), states always stored.

Reverse step, with ``mu = M^-T lambda`` (``lambda`` = d loss / d T+): the parameter
contributions are ``-mu^T dG/dp`` with ``G = (M - I) X - r b = T - T+`` (``X = T + T+`` for a CN
step, ``X = T+`` for a half step, the bottom node of ``X`` being the matching sum of
``T_bottom``). Per set they are accumulated in scale-free sums, which
:func:`pavement_mcmc.solver.adjoint._gradients` converts:

- ``acc_a[k] = sum r mu_k (X_k - X_k+1)``, ``acc_b[k] = sum r mu_k+1 (X_k - X_k+1)``:
  ``dL/dkappa_k = -(dc_k/dkappa_k) acc_a[k] + (da_k+1/dkappa_k) acc_b[k]``, i.e. on a uniform
  grid ``-(f_k acc_a[k] / C_k - acc_b[k] / C_k+1) / dx^2`` (``f_0 = 2``, else 1);
- ``acc_h[j] = sum r mu_0 (X_0 - T_air sum)`` over interval ``j``: ``dL/dh_j = -hs acc_h[j]``
  with ``hs = 2 / (C_0 dx_0)``;
- ``acc_q[j] = sum r mu_0 (interpolation weight of q_j)``: ``dL/dq_j = hs acc_q[j]``;
- C: every row ``i`` of ``G`` is proportional to ``1/C_i``, so ``dL/dC_i = sum mu_i (T_i - T+_i)
  / C_i = sum mu_i G_i / C_i``, and ``sum mu_i G_i = c_i acc_a[i] - a_i acc_b[i-1]`` (plus
  ``hs (sum_j h_j acc_h[j] - sum_j q_j acc_q[j])`` at the surface): no accumulator of its own.

Dirichlet top: the forward kernels' ``invD0 = 0`` (:func:`._kernels._surface_pivot`) makes
``mu[0] = 0``, which is the transposed solve of the reduced system (rows 1 .. N-1); ``acc_h``,
``acc_q`` and row 0's terms then vanish, and ``kappa_0`` still enters through ``a_1`` (node 0 of
the stored states is ``T_top``).

Every kernel takes the :class:`~pavement_mcmc.solver.kernels.cn.Problem` ``P`` and the sums as
one tuple ``acc = (acc_a, acc_b, acc_h, acc_q)``.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from . import adjoint_simd as _vadj
from . import cn_simd as _vstep
from .cn import _FM, _be_step, _block_inputs, _cn_step, _lin, _prepare, _store, _surface_pivot
from .simd import W


@njit(cache=True)
def slot_layout(substeps, n_start, damp):
    """``(first, slot0)``: global index of each interval's first step, slot of each ``t_obs``."""
    n_int = substeps.shape[0]
    first = np.empty(n_int, dtype=np.int64)
    slot0 = np.empty(n_int + 1, dtype=np.int64)
    nstep = 0
    slot = 0
    for j in range(n_int):
        first[j] = nstep
        slot0[j] = slot
        for m in range(substeps[j]):
            slot += 2 if (nstep + m < n_start or (m == 0 and damp)) else 1
        nstep += substeps[j]
    slot0[n_int] = slot
    return first, slot0


@njit(cache=True, fastmath=_FM)
def _transpose_gain(l, invD, gt):
    """``gt[i] = l[i] invD[i]`` (i >= 1): the bottom-up elimination gains of ``M^T``."""
    N, nb = l.shape
    for i in range(1, N):
        for s in range(nb):
            gt[i, s] = l[i, s] * invD[i, s]


@njit(cache=True, fastmath=_FM)
def _adjoint_step(
    lam, mu, T, Tp, ct, cl, u, gt, invD0, invD, r, XN, Ta, wq0, wq1, acc_a, acc_b, acc_h, acc_q, j
):
    """One step of the reverse sweep, in place on ``lam``; adds the step's contributions.

    Solves ``mu = M^-T lam`` with the forward factorisation (same pivots as ``M``): ``M^T`` row
    ``i`` is ``-u[i-1] mu[i-1] + D_i mu[i] - l[i+1] mu[i+1] = lam[i]``; bottom-up
    ``R[i] = lam[i] + gt[i+1] R[i+1]``, then ``mu[0] = R[0] invD0``,
    ``mu[i] = (R[i] + u[i-1] mu[i-1]) invD[i]`` (``R`` is kept in ``mu``). Then
    ``lam <- mu + cl (mu - lam)`` (``cl = 1``: CN, ``2 mu - lam``; ``cl = 0``: half step, ``mu``).

    ``T -> Tp`` is the forward step; ``X = Tp + ct T`` (``ct = 1`` CN, 0 half step); ``XN``,
    ``Ta``: the bottom and air temperatures (sums) of its right-hand side; ``wq0``, ``wq1``: the
    total interpolation weights of ``q_j``, ``q_j+1`` in it.
    """
    N, nb = lam.shape
    for s in range(nb):
        mu[N - 1, s] = lam[N - 1, s]
    for i in range(N - 2, -1, -1):
        for s in range(nb):
            mu[i, s] = lam[i, s] + gt[i + 1, s] * mu[i + 1, s]
    for s in range(nb):
        m0 = mu[0, s] * invD0[s]
        mu[0, s] = m0
        lam[0, s] = m0 + cl * (m0 - lam[0, s])
    for s in range(nb):
        acc_h[j, s] += r * mu[0, s] * (Tp[0, s] + ct * T[0, s] - Ta)
    for s in range(nb):
        acc_q[j, s] += r * wq0 * mu[0, s]
    for s in range(nb):
        acc_q[j + 1, s] += r * wq1 * mu[0, s]
    for i in range(1, N):
        for s in range(nb):
            mi = (mu[i, s] + u[i - 1, s] * mu[i - 1, s]) * invD[i, s]
            mu[i, s] = mi
            lam[i, s] = mi + cl * (mi - lam[i, s])
    for i in range(N - 1):
        for s in range(nb):
            dk = r * ((Tp[i, s] + ct * T[i, s]) - (Tp[i + 1, s] + ct * T[i + 1, s]))
            acc_a[i, s] += mu[i, s] * dk
            acc_b[i, s] += mu[i + 1, s] * dk
    i = N - 1
    for s in range(nb):
        acc_a[i, s] += r * mu[i, s] * (Tp[i, s] + ct * T[i, s] - XN)


@njit(cache=True, fastmath=_FM)
def _block_setup(P, s0, nb):
    """The block's kappa and C (sets innermost), initial state and factorisation workspace."""
    N = P.kappaT.shape[0]
    kap0, CB, T = _block_inputs(P, s0, nb)
    return kap0, CB, T, np.zeros((8, N, nb)), np.zeros((6, nb)), np.zeros((N, nb))


@njit(cache=True, fastmath=_FM)
def _factor(geo, dx0, top, kap0, CB, r, hj, refactor, w, z, gt):
    """Factorise ``M`` for an interval: all of it if ``refactor`` (new step length), else only
    the surface pivot (new ``h``); also the transpose gains ``gt``."""
    if refactor:  # (beta, T_ref, T, Tb0 are unused in the linear case)
        _prepare(geo, dx0, 0.0, top, False, kap0, CB, z[1], r, hj, gt, 0.0, w, z)
        _transpose_gain(w[3], w[6], gt)
    else:
        _surface_pivot(z[0], z[2], hj, z[4], z[3], top)


@njit(cache=True, fastmath=_FM)
def _advance(T_air, T_bot, T_top, n_start, damp, st, k, j, ns, first_j, qB, w, z):
    """Interval ``j``'s steps from slot ``k`` of ``st`` on, each into the next slot; returns the
    slot of the interval's end state. Same steps and arithmetic as ``cn_simd._cn_block``: its
    vector steps when the block's sets fill whole vectors (``qB``: the block's q, (n_obs, nb)),
    else the loop steps of ``_kernels`` (the same numbers)."""
    l, u, g, invD, R = w[3], w[4], w[5], w[6], w[7]
    hc, hh, invD0, qs = z[2], z[3], z[4], z[5]
    qa, qb = qB[j], qB[j + 1]
    nb = qa.shape[0]
    vec = nb % W == 0
    for m in range(ns):
        w0 = m / ns
        w1 = (m + 1) / ns
        if first_j + m < n_start or (m == 0 and damp):  # two backward-Euler half steps
            for half in range(2):
                wb = (m + 0.5) / ns if half == 0 else w1
                for s in range(nb):
                    qs[s] = hc[s] * _lin(qa[s], qb[s], wb)
                Ta = _lin(T_air[j], T_air[j + 1], wb)
                Tb = _lin(T_bot[j], T_bot[j + 1], wb)
                st[k + 1, :, :] = st[k]
                Tt = _lin(T_top[j], T_top[j + 1], wb)
                if vec:
                    _vstep.be_step(st[k + 1], R, l, u, g, invD, z, Ta, Tb, qB, j, wb, Tt)
                else:
                    _be_step(st[k + 1], R, l, u, g, invD0, hh, Ta, Tb, qs, invD, Tt)
                k += 1
        else:
            Ta_sum = _lin(T_air[j], T_air[j + 1], w0) + _lin(T_air[j], T_air[j + 1], w1)
            Tb_sum = _lin(T_bot[j], T_bot[j + 1], w0) + _lin(T_bot[j], T_bot[j + 1], w1)
            for s in range(nb):
                qs[s] = hc[s] * (_lin(qa[s], qb[s], w0) + _lin(qa[s], qb[s], w1))
            st[k + 1, :, :] = st[k]
            Tt = _lin(T_top[j], T_top[j + 1], w1)
            if vec:
                _vstep.cn_step(st[k + 1], R, l, u, g, invD, z, Ta_sum, Tb_sum, qB, j, w0, w1, Tt)
            else:
                _cn_step(st[k + 1], R, l, u, g, invD0, hh, Ta_sum, Tb_sum, qs, invD, Tt)
            k += 1
    return k


@njit(cache=True, fastmath=_FM)
def _retreat(T_air, T_bot, n_start, damp, st, k, j, ns, first_j, r, w, z, gt, lam, mu, acc):
    """Reverse sweep through interval ``j`` whose end state is slot ``k`` of ``st``: on entry
    ``lam`` = d loss / d T(t_obs[j+1]), on return d loss / d T(t_obs[j])."""
    acc_a, acc_b, acc_h, acc_q = acc
    u, invD, invD0 = w[4], w[6], z[4]
    for m in range(ns - 1, -1, -1):
        be = first_j + m < n_start or (m == 0 and damp)
        for half in range(2 if be else 1):  # latest first: the CN step, or the second half step
            if be:  # X = T+, b at the half step's end (the step's midpoint, then its end)
                wb = (m + 0.5) / ns if half == 1 else (m + 1) / ns
                ct, cl = 0.0, 0.0  # lambda(T) = mu
                XN = _lin(T_bot[j], T_bot[j + 1], wb)
                Ta = _lin(T_air[j], T_air[j + 1], wb)
                wq1 = wb
            else:  # X = T + T+, b at both ends
                w0 = m / ns
                w1 = (m + 1) / ns
                ct, cl = 1.0, 1.0  # lambda(T) = (2I - M)^T mu = 2 mu - M^T mu = 2 mu - lambda(T+)
                XN = _lin(T_bot[j], T_bot[j + 1], w0) + _lin(T_bot[j], T_bot[j + 1], w1)
                Ta = _lin(T_air[j], T_air[j + 1], w0) + _lin(T_air[j], T_air[j + 1], w1)
                wq1 = w0 + w1
            if lam.shape[1] % W == 0:  # the same numbers on vectors
                _vadj.adjoint_step(
                    lam, mu, st[k - 1], st[k], ct, cl, u, gt, z, invD, r, XN, Ta, (1.0 + ct) - wq1, wq1,
                    acc_a, acc_b, acc_h, acc_q, j,
                )
            else:
                _adjoint_step(
                    lam, mu, st[k - 1], st[k], ct, cl, u, gt, invD0, invD, r, XN, Ta, (1.0 + ct) - wq1, wq1,
                    acc_a, acc_b, acc_h, acc_q, j,
                )
            k -= 1


@njit(cache=True, fastmath=_FM)
def _fwd_block(P, s0, nb, out, buf):
    """Crank-Nicolson for sets ``s0 .. s0+nb-1`` (as ``_kernels._cn_block``, linear), keeping
    every state in the block's segment of ``buf``; fills their columns of ``out``."""
    T_air, T_bot, T_top, t_obs, substeps = P.T_air, P.T_bot, P.T_top, P.t_obs, P.substeps
    n_start, damp, geo, dx0, top, hT, qT = P.n_start, P.damp, P.geo, P.dx0, P.top, P.hT, P.qT
    N = P.kappaT.shape[0]
    n_int = substeps.shape[0]
    first, slot0 = slot_layout(substeps, n_start, damp)
    n_slots = slot0[n_int] + 1
    st = buf[s0 * n_slots * N : (s0 + nb) * n_slots * N].reshape((n_slots, N, nb))
    kap0, CB, T, w, z, gt = _block_setup(P, s0, nb)
    qB = np.ascontiguousarray(qT[:, s0 : s0 + nb])
    st[0, :, :] = T
    _store(out, 0, s0, st[0], T_bot[0])
    dt_fact = -1.0
    for j in range(n_int):
        ns = substeps[j]
        dt = (t_obs[j + 1] - t_obs[j]) / ns
        _factor(geo, dx0, top, kap0, CB, 0.5 * dt, hT[j, s0 : s0 + nb], dt != dt_fact, w, z, gt)
        dt_fact = dt
        k = _advance(T_air, T_bot, T_top, n_start, damp, st, slot0[j], j, ns, first[j], qB, w, z)
        _store(out, j + 1, s0, st[k], T_bot[j + 1])


@njit(cache=True, fastmath=_FM)
def _vjp_block(P, out, G, stored, buf, s0, nb, acc):
    """Reverse sweep for sets ``s0 .. s0+nb-1``; fills their columns of the sums ``acc =
    (acc_a, acc_b, acc_h, acc_q)``, shaped (N, S), (N, S), (n_obs-1, S), (n_obs, S) (module
    docstring).

    ``out`` (n_obs, N+1, S): the forward solution; ``G`` (S, n_obs, N+1), in the caller's layout
    (read once per interval, so no transposed copy is needed): d loss / d out. If
    ``stored``, the states are read from ``buf`` (filled by the forward with store); otherwise
    each interval is recomputed from ``out``.
    """
    T_air, T_bot, T_top, t_obs, substeps = P.T_air, P.T_bot, P.T_top, P.t_obs, P.substeps
    n_start, damp, geo, dx0, top, hT, qT = P.n_start, P.damp, P.geo, P.dx0, P.top, P.hT, P.qT
    N = P.kappaT.shape[0]
    n_int = substeps.shape[0]
    first, slot0 = slot_layout(substeps, n_start, damp)
    n_slots = slot0[n_int] + 1
    if stored:
        st = buf[s0 * n_slots * N : (s0 + nb) * n_slots * N].reshape((n_slots, N, nb))
    else:
        max_slots = 0
        for j in range(n_int):
            max_slots = max(max_slots, slot0[j + 1] - slot0[j])
        st = np.empty((max_slots + 1, N, nb))
    kap0, CB, _, w, z, gt = _block_setup(P, s0, nb)
    qB = np.ascontiguousarray(qT[:, s0 : s0 + nb])
    lam = np.zeros((N, nb))
    mu = np.zeros((N, nb))
    a_b = np.zeros((2, N, nb))
    h_b = np.zeros((n_int, nb))
    q_b = np.zeros((n_int + 1, nb))
    dt_fact = -1.0
    for j in range(n_int - 1, -1, -1):
        ns = substeps[j]
        dt = (t_obs[j + 1] - t_obs[j]) / ns
        _factor(geo, dx0, top, kap0, CB, 0.5 * dt, hT[j, s0 : s0 + nb], dt != dt_fact, w, z, gt)
        dt_fact = dt
        if stored:
            k = slot0[j + 1]
        else:  # recompute the interval from its checkpoint, as the forward did
            for i in range(N):
                for s in range(nb):
                    st[0, i, s] = out[j, i, s0 + s]
            k = _advance(T_air, T_bot, T_top, n_start, damp, st, 0, j, ns, first[j], qB, w, z)
        for i in range(N):
            for s in range(nb):
                lam[i, s] += G[s0 + s, j + 1, i]
        _retreat(
            T_air, T_bot, n_start, damp, st, k, j, ns, first[j], 0.5 * dt, w, z, gt, lam, mu,
            (a_b[0], a_b[1], h_b, q_b),
        )
    acc_a, acc_b, acc_h, acc_q = acc
    for i in range(N):
        for s in range(nb):
            acc_a[i, s0 + s] = a_b[0, i, s]
            acc_b[i, s0 + s] = a_b[1, i, s]
    for j in range(n_int):
        for s in range(nb):
            acc_h[j, s0 + s] = h_b[j, s]
    for j in range(n_int + 1):
        for s in range(nb):
            acc_q[j, s0 + s] = q_b[j, s]


@njit(cache=True, parallel=True)
def fwd_parallel(P, block, out, buf):
    """:func:`_fwd_block` over blocks of ``block`` sets, the blocks spread over numba's threads."""
    S = P.kappaT.shape[1]
    for b in prange((S + block - 1) // block):
        s0 = b * block
        _fwd_block(P, s0, min(block, S - s0), out, buf)


@njit(cache=True)
def fwd_serial(P, block, out, buf):
    """As :func:`fwd_parallel`, on the calling thread."""
    S = P.kappaT.shape[1]
    for s0 in range(0, S, block):
        _fwd_block(P, s0, min(block, S - s0), out, buf)


@njit(cache=True, parallel=True)
def vjp_parallel(P, out, G, stored, buf, block, acc):
    """:func:`_vjp_block` over blocks of ``block`` sets, the blocks spread over numba's threads."""
    S = P.kappaT.shape[1]
    for b in prange((S + block - 1) // block):
        s0 = b * block
        _vjp_block(P, out, G, stored, buf, s0, min(block, S - s0), acc)


@njit(cache=True)
def vjp_serial(P, out, G, stored, buf, block, acc):
    """As :func:`vjp_parallel`, on the calling thread."""
    S = P.kappaT.shape[1]
    for s0 in range(0, S, block):
        _vjp_block(P, out, G, stored, buf, s0, min(block, S - s0), acc)


@njit(cache=True)
def gradient_terms(kappa, C, acc_a, acc_b, vol_ratio, inv_rho, Vd, d, den, dx0, sums):
    """The kappa and C gradients and the surface factor ``hs`` (S,) from the reverse sweep's sums
    (all (S, N); ``sums`` (S,) = ``sum_j h_j acc_h[j] - sum_j q_j acc_q[j]``), for
    :func:`pavement_mcmc.solver.adjoint._gradients`. The NumPy expressions it replaces, whose
    operations and their order it keeps (no FMA: not ``fastmath``), so the floats are the same
    (``f = (2, 1, 1, ...)``, ``Cn = C[:, :N]``)::

        gk = -f * acc_a / Cn; gk[:, :-1] += vol_ratio * acc_b[:, :-1] / Cn[:, 1:]; gk /= den
        sg = f * kappa * acc_a; sg[:, 1:] -= kappa[:, :-1] * acc_b[:, :-1] * inv_rho[1:]
        sg /= Cn * Vd * d; hs = 2.0 / (Cn[:, 0] * dx0); sg[:, 0] += hs * sums; gC = sg / Cn
    """
    S, N = kappa.shape
    gk = np.empty((S, N))
    gC = np.zeros((S, N + 1))
    hs = np.empty(S)
    for s in range(S):
        hs[s] = 2.0 / (C[s, 0] * dx0)
        for k in range(N):
            f = 2.0 if k == 0 else 1.0
            g = (-f * acc_a[s, k]) / C[s, k]
            if k < N - 1:
                g = g + (vol_ratio[k] * acc_b[s, k]) / C[s, k + 1]
            gk[s, k] = g / den[k]
            sg = (f * kappa[s, k]) * acc_a[s, k]
            if k > 0:
                sg = sg - (kappa[s, k - 1] * acc_b[s, k - 1]) * inv_rho[k]
            sg = sg / ((C[s, k] * Vd[k]) * d[k])
            if k == 0:
                sg = sg + hs[s] * sums[s]
            gC[s, k] = sg / C[s, k]
    return gk, gC, hs
