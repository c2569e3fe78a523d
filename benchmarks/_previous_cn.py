"""The forward CN driver as it was before the vector kernel (``kernels/cn_simd.py``), for
``bench_solver.py`` only: ``_cn_block``, ``cn_serial``, ``cn_parallel`` over the loop-over-sets steps
of :mod:`pavement_mcmc.solver.kernels.cn` (which the adjoint and Du Fort-Frankel kernels still use,
unchanged). It takes the package's own ``Problem``: a second named-tuple class of the same name
made numba's dispatch of whichever kernel was called second ~130 us a call slower.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from pavement_mcmc.solver.kernels.cn import (
    _FM,
    _be_pair,
    _block_inputs,
    _cn_step,
    _lin,
    _prepare,
    _store,
    _surface_pivot,
)


@njit(cache=True, fastmath=_FM)
def _cn_block(P, s0, nb, out):
    """Crank-Nicolson over all observation intervals for sets ``s0 .. s0+nb-1`` of the
    :class:`Problem` ``P``; fills their columns of ``out`` (n_obs, N+1, S), degC."""
    T_air, T_bot, T_top, t_obs, substeps = P.T_air, P.T_bot, P.T_top, P.t_obs, P.substeps
    nonlin, top, n_start, damp = P.nonlin, P.top, P.n_start, P.damp
    geo, dx0, T_ref, hT, qT = P.geo, P.dx0, P.T_ref, P.hT, P.qT
    N = P.kappaT.shape[0]
    n_int = substeps.shape[0]
    kap0, CB, T = _block_inputs(P, s0, nb)
    w = np.zeros((8, N, nb))
    z = np.zeros((6, nb))
    l, u, g, invD, R = w[3], w[4], w[5], w[6], w[7]
    d0, hc, hh, invD0, qs = z[0], z[2], z[3], z[4], z[5]
    bb = P.beta[s0 : s0 + nb]
    _store(out, 0, s0, T, T_bot[0])
    dt_fact = -1.0
    nstep = 0
    for j in range(n_int):
        ns = substeps[j]
        dt = (t_obs[j + 1] - t_obs[j]) / ns
        r = 0.5 * dt
        hj = hT[j, s0 : s0 + nb]
        qa = qT[j, s0 : s0 + nb]
        qb = qT[j + 1, s0 : s0 + nb]
        if not nonlin:
            if dt != dt_fact:  # refactorise only when the step length changes
                _prepare(geo, dx0, T_ref, top, False, kap0, CB, bb, r, hj, T, 0.0, w, z)
                dt_fact = dt
            else:
                _surface_pivot(d0, hc, hj, invD0, hh, top)
        for m in range(ns):
            w0 = m / ns
            w1 = (m + 1) / ns
            Ta0 = _lin(T_air[j], T_air[j + 1], w0)
            Ta1 = _lin(T_air[j], T_air[j + 1], w1)
            Tb0 = _lin(T_bot[j], T_bot[j + 1], w0)
            Tb1 = _lin(T_bot[j], T_bot[j + 1], w1)
            Tt1 = _lin(T_top[j], T_top[j + 1], w1)
            if nonlin:
                _prepare(geo, dx0, T_ref, top, True, kap0, CB, bb, r, hj, T, Tb0, w, z)
            if nstep < n_start or (m == 0 and damp):
                wh = (m + 0.5) / ns
                _be_pair(
                    T, w, z, _lin(T_air[j], T_air[j + 1], wh), _lin(T_bot[j], T_bot[j + 1], wh), Ta1, Tb1,
                    qa, qb, wh, w1, _lin(T_top[j], T_top[j + 1], wh), Tt1,
                )
            else:
                for s in range(nb):
                    qs[s] = hc[s] * (_lin(qa[s], qb[s], w0) + _lin(qa[s], qb[s], w1))
                _cn_step(T, R, l, u, g, invD0, hh, Ta0 + Ta1, Tb0 + Tb1, qs, invD, Tt1)
            nstep += 1
        _store(out, j + 1, s0, T, T_bot[j + 1])


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
