"""Compiled Du Fort-Frankel kernels (the paper's scheme, kept for parity).

Internal module; see :mod:`pavement_mcmc.solver` for the scheme and :mod:`pavement_mcmc.solver.kernels.cn`
for the notation and the sets-innermost layout. Robin top only; the rates take the grid's
geometry factors, but :func:`pavement_mcmc.solver.solve` runs this scheme on uniform grids only
(parity with the paper, whose consistency condition dt/dx -> 0 is stated for a uniform dx).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .cn import (
    _FM,
    _be_pair,
    _block_inputs,
    _lagged_kappa,
    _lin,
    _prepare,
    _rates,
    _store,
)


@njit(cache=True, fastmath=_FM)
def _dff_coeffs(geo, dx0, kap, CB, dt, h, a, c, hs, p, wa, wc, ws):
    """Du Fort-Frankel update coefficients: ``T+ = p T- + wa T[i-1] + wc T[i+1] + ws (source)``.

    ``(T+ - T-) / (2 dt) = a (T[i-1] - Tbar) + c (T[i+1] - Tbar) - hs h Tbar + hs F`` with
    ``Tbar = (T+ + T-)/2`` and ``F = h T_air + q`` at the surface node (``a[0] = 0``).
    """
    N, nb = a.shape
    _rates(kap, CB, geo, dx0, a, c, hs)
    for i in range(N):
        for s in range(nb):
            e = dt * (a[i, s] + c[i, s])
            if i == 0:
                e += dt * hs[s] * h[s]
            inv = 1.0 / (1.0 + e)
            p[i, s] = (1.0 - e) * inv
            wa[i, s] = 2.0 * dt * a[i, s] * inv
            wc[i, s] = 2.0 * dt * c[i, s] * inv
    for s in range(nb):
        ws[s] = 2.0 * dt * hs[s] / (1.0 + dt * (c[0, s] + hs[s] * h[s]))


@njit(cache=True, fastmath=_FM)
def _dff_step(Tm, T, p, wa, wc, ws, F, Tb):
    """Overwrite ``Tm`` (level n-1) with level n+1; ``T`` is level n; ``F = h T_air + q``."""
    N, nb = T.shape
    for s in range(nb):
        Tm[0, s] = p[0, s] * Tm[0, s] + wc[0, s] * (T[1, s] if N > 1 else Tb) + ws[s] * F[s]
    for i in range(1, N - 1):
        for s in range(nb):
            Tm[i, s] = p[i, s] * Tm[i, s] + wa[i, s] * T[i - 1, s] + wc[i, s] * T[i + 1, s]
    if N > 1:
        i = N - 1
        for s in range(nb):
            Tm[i, s] = p[i, s] * Tm[i, s] + wa[i, s] * T[i - 1, s] + wc[i, s] * Tb


@njit(cache=True, fastmath=_FM)
def _dff_block(P, s0, nb, out):
    """Du Fort-Frankel for sets ``s0 .. s0+nb-1`` of the
    :class:`~pavement_mcmc.solver.kernels.cn.Problem` ``P`` (Robin top); fills ``out``.

    Three-level explicit scheme, started (and restarted whenever the step length changes) with
    two backward-Euler half steps. ``kappa(T)`` is evaluated at the middle level ``n``.
    """
    T_air, T_bot, t_obs, substeps, nonlin = P.T_air, P.T_bot, P.t_obs, P.substeps, P.nonlin
    geo, dx0, T_ref = P.geo, P.dx0, P.T_ref
    N = P.kappaT.shape[0]
    n_int = substeps.shape[0]
    kap0, CB, T = _block_inputs(P, s0, nb)
    Tm = T.copy()
    w = np.zeros((8, N, nb))
    z = np.zeros((6, nb))
    v = np.zeros((6, N, nb))
    y = np.zeros((3, nb))
    kap, a, c, p, wa, wc = v[0], v[1], v[2], v[3], v[4], v[5]
    hs, ws, F = y[0], y[1], y[2]
    bb = P.beta[s0 : s0 + nb]
    _store(out, 0, s0, T, T_bot[0])
    dt_prev = -1.0
    for j in range(n_int):
        ns = substeps[j]
        dt = (t_obs[j + 1] - t_obs[j]) / ns
        hj = P.hT[j, s0 : s0 + nb]
        qa = P.qT[j, s0 : s0 + nb]
        qb = P.qT[j + 1, s0 : s0 + nb]
        if not nonlin:
            _dff_coeffs(geo, dx0, kap0, CB, dt, hj, a, c, hs, p, wa, wc, ws)
        for m in range(ns):
            w0 = m / ns
            w1 = (m + 1) / ns
            Ta0 = _lin(T_air[j], T_air[j + 1], w0)
            Tb0 = _lin(T_bot[j], T_bot[j + 1], w0)
            if dt != dt_prev:  # (re)start: level n -> n+1 by two implicit half steps
                Tm[:, :] = T
                wh = (m + 0.5) / ns
                _prepare(geo, dx0, T_ref, False, nonlin, kap0, CB, bb, 0.5 * dt, hj, T, Tb0, w, z)
                _be_pair(
                    T, w, z, _lin(T_air[j], T_air[j + 1], wh), _lin(T_bot[j], T_bot[j + 1], wh),
                    _lin(T_air[j], T_air[j + 1], w1), _lin(T_bot[j], T_bot[j + 1], w1), qa, qb, wh, w1,
                    0.0, 0.0,
                )
                dt_prev = dt
                continue
            if nonlin:
                _lagged_kappa(kap0, bb, T_ref, T, Tb0, kap)
                _dff_coeffs(geo, dx0, kap, CB, dt, hj, a, c, hs, p, wa, wc, ws)
            for s in range(nb):
                F[s] = hj[s] * Ta0 + _lin(qa[s], qb[s], w0)
            _dff_step(Tm, T, p, wa, wc, ws, F, Tb0)
            Tm, T = T, Tm
        _store(out, j + 1, s0, T, T_bot[j + 1])


@njit(cache=True)
def dff_serial(P, block, out):
    """:func:`_dff_block` over blocks of ``block`` sets on the calling thread (the scheme is kept
    for parity, not speed: no parallel variant, which saves its compile time).
    ``P.n_start`` and ``P.damp`` are unused."""
    S = P.kappaT.shape[1]
    for s0 in range(0, S, block):
        _dff_block(P, s0, min(block, S - s0), out)
