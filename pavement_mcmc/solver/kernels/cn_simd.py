"""The Crank-Nicolson and backward-Euler steps of :mod:`.cn` on explicit SIMD vectors of sets.

Internal module; notation and factorisation in :mod:`pavement_mcmc.solver.kernels.cn`. Same
arithmetic, same rounding as ``cn._cn_step`` / ``cn._be_step`` (the fused multiply-adds those get
under ``fastmath={"contract"}`` are written out with :func:`.simd.vfma`), but the loop order is
turned round: sets in chunks of ``W`` (one vector) outside, nodes inside, so that ``T[i]``,
``T[i+1]`` and ``R[i+1]`` of the bottom-up sweep and ``T[i-1]`` of the top-down one stay in
registers. Per node and step that is 7 loads and 2 stores of a vector (11 and 2 before), and no
per-row loop set-up. The arrays' set axis must be padded to a multiple of ``W`` (``cn._cn_block``
pads with copies of its last set).

``z`` is the block's ``(6, n_sets)`` scratch of ``cn._prepare``: rows ``hc = 2``, ``hh = 3``,
``invD0 = 4``. ``qB`` holds the block's surface flux ``q`` at the observation times (``(n_obs,
n_sets)``); ``j`` is the interval, ``w*`` the interpolation weights of the step's ends within it.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .cn import _FM, _block_inputs, _lin, _prepare, _store, _surface_pivot
from .simd import W, vadd, vfma, vload, vmul, vsplat, vstore, vsub

_WIDE = 2 * W  # sets per chunk (two registers: two independent recursions in flight); the rest in W
_STAGGER = 80  # doubles: consecutive work arrays start 640 B apart modulo 4 KiB (no 4K aliasing)


@njit(cache=True, inline="always")
def _topdown(T, R, l, invD, s, prev):
    """``T[0] = prev``, then ``T[i] = (R[i] + l[i] T[i-1]) invD[i]`` for the chunk at set ``s``."""
    vstore(T, 0, s, prev)
    for i in range(1, T.shape[0]):
        prev = vmul(vfma(vload(l, i, s, prev), prev, vload(R, i, s, prev)), vload(invD, i, s, prev))
        vstore(T, i, s, prev)


@njit(cache=True, inline="always")
def _cn_chunk(T, R, l, u, g, invD, z, qB, j, s, ta, tb, tt, v0, v1):
    """:func:`cn_step` for the sets ``s .. s+n-1``, ``n`` the width of the vectors ``ta`` .. ``v1``."""
    N = T.shape[0]
    qa = vload(qB, j, s, ta)
    dq = vsub(vload(qB, j + 1, s, ta), qa)
    qsum = vmul(vload(z, 2, s, ta), vadd(vfma(v0, dq, qa), vfma(v1, dq, qa)))
    hh = vload(z, 3, s, ta)
    if N == 1:
        t = vload(T, 0, s, ta)
        rr = vadd(vfma(hh, vsub(ta, t), vfma(vload(u, 0, s, ta), vsub(tb, t), t)), qsum)
        vstore(T, 0, s, vmul(rr, vload(z, 4, s, ta)))
        return
    tn = vload(T, N - 1, s, ta)  # T[i+1], T[i], R[i+1] of the sweep ride along in registers
    t = vload(T, N - 2, s, ta)
    r = vfma(vload(u, N - 1, s, ta), vsub(tb, tn), vfma(vload(l, N - 1, s, ta), vsub(t, tn), tn))
    vstore(R, N - 1, s, r)
    for i in range(N - 2, 0, -1):
        tm = vload(T, i - 1, s, ta)
        r0 = vfma(vload(u, i, s, ta), vsub(tn, t), vfma(vload(l, i, s, ta), vsub(tm, t), t))
        r = vfma(vload(g, i + 1, s, ta), r, r0)
        vstore(R, i, s, r)
        tn = t
        t = tm
    rr = vfma(hh, vsub(ta, t), vfma(vload(u, 0, s, ta), vsub(tn, t), t))
    rr = vfma(vload(g, 1, s, ta), r, vadd(rr, qsum))
    _topdown(T, R, l, invD, s, vfma(rr, vload(z, 4, s, ta), tt))


@njit(cache=True, inline="always")
def _be_chunk(T, R, l, u, g, invD, z, qB, j, s, ta, tb, tt, vw):
    """:func:`be_step` for the sets ``s .. s+n-1``, ``n`` the width of the vectors ``ta`` .. ``vw``."""
    N = T.shape[0]
    qa = vload(qB, j, s, ta)
    q1 = vmul(vload(z, 2, s, ta), vfma(vw, vsub(vload(qB, j + 1, s, ta), qa), qa))
    hh = vload(z, 3, s, ta)
    if N == 1:
        rr = vadd(vfma(hh, ta, vfma(vload(u, 0, s, ta), tb, vload(T, 0, s, ta))), q1)
        vstore(T, 0, s, vmul(rr, vload(z, 4, s, ta)))
        return
    r = vfma(vload(u, N - 1, s, ta), tb, vload(T, N - 1, s, ta))
    vstore(R, N - 1, s, r)
    for i in range(N - 2, 0, -1):
        r = vfma(vload(g, i + 1, s, ta), r, vload(T, i, s, ta))
        vstore(R, i, s, r)
    rr = vfma(vload(g, 1, s, ta), r, vadd(vfma(hh, ta, vload(T, 0, s, ta)), q1))
    _topdown(T, R, l, invD, s, vfma(rr, vload(z, 4, s, ta), tt))


@njit(cache=True)
def cn_step(T, R, l, u, g, invD, z, Ta_sum, Tb_sum, qB, j, w0, w1, Tt1):
    """One CN step in place (``cn._cn_step``): ``Ta_sum = T_air^n + T_air^{n+1}``, ``Tb_sum``
    likewise, ``Tt1`` the Dirichlet top at the step's end (0 for a Robin top); chunks of
    ``_WIDE`` sets, then one of ``W``."""
    nbp = T.shape[1]
    s = 0
    while s + _WIDE <= nbp:
        _cn_chunk(T, R, l, u, g, invD, z, qB, j, s, vsplat(Ta_sum, _WIDE), vsplat(Tb_sum, _WIDE),
                  vsplat(Tt1, _WIDE), vsplat(w0, _WIDE), vsplat(w1, _WIDE))
        s += _WIDE
    while s < nbp:
        _cn_chunk(T, R, l, u, g, invD, z, qB, j, s, vsplat(Ta_sum, W), vsplat(Tb_sum, W), vsplat(Tt1, W),
                  vsplat(w0, W), vsplat(w1, W))
        s += W


@njit(cache=True)
def be_step(T, R, l, u, g, invD, z, Ta1, Tb1, qB, j, wq, Tt1):
    """One backward-Euler half step in place (``cn._be_step``): ``Ta1``, ``Tb1``, ``Tt1`` at the
    step's end, ``wq`` its weight for ``q`` within interval ``j``; chunks as :func:`cn_step`."""
    nbp = T.shape[1]
    s = 0
    while s + _WIDE <= nbp:
        _be_chunk(T, R, l, u, g, invD, z, qB, j, s, vsplat(Ta1, _WIDE), vsplat(Tb1, _WIDE),
                  vsplat(Tt1, _WIDE), vsplat(wq, _WIDE))
        s += _WIDE
    while s < nbp:
        _be_chunk(T, R, l, u, g, invD, z, qB, j, s, vsplat(Ta1, W), vsplat(Tb1, W), vsplat(Tt1, W),
                  vsplat(wq, W))
        s += W


@njit(cache=True)
def _work_arrays(n, rows, nbp):
    """``n`` zeroed C-contiguous ``(rows, nbp)`` arrays in one buffer, each 64-byte aligned (a
    vector is one cache line) and starting ``_STAGGER`` doubles further modulo 4 KiB than the
    previous one (a load whose address equals a pending store's modulo 4 KiB waits for it)."""
    stride = -(-rows * nbp // 512) * 512 + _STAGGER
    buf = np.zeros(n * stride + W)
    o = (-(buf.ctypes.data // 8)) % W
    return [buf[o + k * stride : o + k * stride + rows * nbp].reshape((rows, nbp)) for k in range(n)]


@njit(cache=True, fastmath=_FM)
def _padded_inputs(P, s0, nb, ws):
    """Fill the block's kappa, C, initial state (``ws[0..2]``, as ``cn._block_inputs``), h, q
    (``ws[3..4]``) and beta (``ws[5][0]``), the sets padded to ``nbp`` columns by copies of the
    last set (the vector steps run on whole vectors; the copies are computed, never stored)."""
    kap, C, T = _block_inputs(P, s0, nb)
    nbp = ws[0].shape[1]
    for s in range(nbp):
        k = min(s, nb - 1)
        for src, dst in ((kap, ws[0]), (C, ws[1]), (T, ws[2])):
            for i in range(src.shape[0]):
                dst[i, s] = src[i, k]
        for i in range(P.hT.shape[0]):
            ws[3][i, s] = P.hT[i, s0 + k]
        for i in range(P.qT.shape[0]):
            ws[4][i, s] = P.qT[i, s0 + k]
        ws[5][0, s] = P.beta[s0 + k]


@njit(cache=True, fastmath=_FM)
def _cn_block(P, s0, nb, out):
    """Crank-Nicolson over all observation intervals for sets ``s0 .. s0+nb-1`` of the
    :class:`~.cn.Problem` ``P``; fills their columns of ``out`` (n_obs, N+1, S), degC. The sets
    are padded to a multiple of the vector width ``W``."""
    T_air, T_bot, T_top, t_obs, substeps = P.T_air, P.T_bot, P.T_top, P.t_obs, P.substeps
    nonlin, top, n_start, damp = P.nonlin, P.top, P.n_start, P.damp
    geo, dx0, T_ref = P.geo, P.dx0, P.T_ref
    N = P.kappaT.shape[0]
    n_int = substeps.shape[0]
    nbp = -(-nb // W) * W
    wk = _work_arrays(10, N, nbp)  # kap, a, c, l, u, g, invD, R, kap0, C
    T = _work_arrays(1, N, nbp)[0]
    ins = _work_arrays(3, max(n_int + 1, 7), nbp)  # h, q, z (+ beta in z's last row)
    ws = (wk[8], wk[9], T, ins[0], ins[1], ins[2][6:7])
    _padded_inputs(P, s0, nb, ws)
    kap0, CB, hB, qB, z, bb = wk[8], wk[9], ins[0], ins[1], ins[2], ins[2][6]
    l, u, g, invD, R = wk[3], wk[4], wk[5], wk[6], wk[7]
    d0, hc, hh, invD0 = z[0], z[2], z[3], z[4]
    _store(out, 0, s0, T[:, :nb], T_bot[0])
    dt_fact = -1.0
    nstep = 0
    for j in range(n_int):
        ns = substeps[j]
        dt = (t_obs[j + 1] - t_obs[j]) / ns
        r = 0.5 * dt
        hj = hB[j]
        if not nonlin:
            if dt != dt_fact:  # refactorise only when the step length changes
                _prepare(geo, dx0, T_ref, top, False, kap0, CB, bb, r, hj, T, 0.0, wk, z)
                dt_fact = dt
            else:
                _surface_pivot(d0, hc, hj, invD0, hh, top)
        for m in range(ns):
            w0 = m / ns
            w1 = (m + 1) / ns
            Ta1 = _lin(T_air[j], T_air[j + 1], w1)
            Tb1 = _lin(T_bot[j], T_bot[j + 1], w1)
            Tt1 = _lin(T_top[j], T_top[j + 1], w1)
            Tb0 = _lin(T_bot[j], T_bot[j + 1], w0)
            if nonlin:
                _prepare(geo, dx0, T_ref, top, True, kap0, CB, bb, r, hj, T, Tb0, wk, z)
            if nstep < n_start or (m == 0 and damp):  # two backward-Euler half steps
                wh = (m + 0.5) / ns
                Tah, Tbh = _lin(T_air[j], T_air[j + 1], wh), _lin(T_bot[j], T_bot[j + 1], wh)
                be_step(T, R, l, u, g, invD, z, Tah, Tbh, qB, j, wh, _lin(T_top[j], T_top[j + 1], wh))
                be_step(T, R, l, u, g, invD, z, Ta1, Tb1, qB, j, w1, Tt1)
            else:
                Ta0 = _lin(T_air[j], T_air[j + 1], w0)
                cn_step(T, R, l, u, g, invD, z, Ta0 + Ta1, Tb0 + Tb1, qB, j, w0, w1, Tt1)
            nstep += 1
        _store(out, j + 1, s0, T[:, :nb], T_bot[j + 1])


@njit(cache=True, parallel=True)
def cn_parallel(P, block, out):
    """:func:`_cn_block` over blocks of ``block`` sets, the blocks spread over numba's threads."""
    S = P.kappaT.shape[1]
    for b in prange((S + block - 1) // block):
        s0 = b * block
        _cn_block(P, s0, min(block, S - s0), out)


@njit(cache=True)
def cn_serial(P, block, out):
    """As :func:`cn_parallel`, on the calling thread (no thread start-up cost)."""
    S = P.kappaT.shape[1]
    for s0 in range(0, S, block):
        _cn_block(P, s0, min(block, S - s0), out)
