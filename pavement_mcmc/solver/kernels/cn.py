"""Compiled (numba) time-stepping pieces behind :func:`pavement_mcmc.solver.solve`.

Internal module. It holds the :class:`Problem`, the rates, the factorisation and the CN /
backward-Euler steps as loops over sets; the forward CN driver (``cn_serial`` / ``cn_parallel``)
runs the same steps on explicit vectors in :mod:`.cn_simd`, the adjoint (:mod:`.adjoint`) and Du
Fort-Frankel (:mod:`.dff`) kernels use the loops here. The public API, the discretisation and
its documentation live in :mod:`pavement_mcmc.solver`. Every array here is laid out with the
parameter sets as the LAST, contiguous axis (``(n_unknowns, n_sets)``), so the inner loops run
over sets and the compiler vectorises them (AVX2/AVX-512). The drivers' outer ``prange`` runs
over blocks of ``block`` sets; each block integrates the whole time window with its working set
(~10 arrays of ``n_unknowns x block`` doubles) resident in L1/L2.

Every kernel reads its inputs from one :class:`Problem` (a named tuple: one place that lists
the arguments). The block drivers unpack it once and hand the inner helpers, called per
interval or per step, only the fields they use: passing the whole struct into them costs
(numba takes a reference to every array in it per call; measured +5-10 % on the adjoint's
forward pass and the lagged-kappa path).

Notation (per set, per node ``i = 0 .. N-1``; node ``N`` is the Dirichlet bottom; geometry
factors of :meth:`pavement_mcmc.solver.Grid._rate_geometry`, ``geo = (ga, rho)`` with
``ga[i] = 1 / (V_i dx_i-1)``, ``rho[i] = dx_i-1 / dx_i``, ``ga[0] = 1 / dx_0^2``):

- ``a[i] = kappa[i-1] ga[i] / C[i]`` (``a[0] = 0``), ``c[i] = kappa[i] ga[i] rho[i] / C[i]``,
  except ``c[0] = 2 kappa[0] ga[0] / C[0]`` (half control volume ``dx_0/2`` at the surface), 1/s;
  on a uniform grid ``ga = 1/dx^2``, ``rho = 1``;
- ``hs = 2 / (C[0] dx_0)``, m^2 K J^-1, the surface flux -> surface-node rate factor;
- Crank-Nicolson with ``r = dt/2``: ``l = r a``, ``u = r c``, ``hc = r hs``.

Dirichlet top (``Problem.top``): node 0 takes ``T_top`` at every step end and the unknowns are
nodes ``1 .. N-1``. The bottom-up factorisation of rows ``1 .. N-1`` does not involve row 0, so
it is shared; only the surface row is replaced (``T[0] = T_top``, written branch-free as
``rr invD0 + T_top`` with ``invD0 = 0``; a Robin top passes ``T_top = 0``) and the top-down
substitution ``T[1] = (R[1] + l[1] T[0]) invD[1]`` carries the boundary value in (``l[1] T_top``
is the Dirichlet term of the right-hand side).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

_FM = {"contract"}  # allow fused multiply-add only; no reassociation (measured: same speed)


class Problem(NamedTuple):
    """The read-only inputs of every kernel, sets innermost (``N`` = n_nodes-1, ``S`` sets).

    - kappaT (N, S): cell conductivities, W m-1 K-1 (cell ``i`` = ``[x_i, x_i+1]``);
    - CT (N+1, S): nodal heat capacities, J m-3 K-1 (only the first N are used);
    - hT (n_obs-1, S) W m-2 K-1; qT (n_obs, S) W m-2; beta (S,) 1/K;
    - T_air, T_bot, T_top (n_obs,) degC (T_top zeros unless ``top``); T0 (N+1,) degC;
    - t_obs (n_obs,) s; substeps (n_obs-1,) int;
    - geo (2, N) = (ga, rho) and dx0 (m): the grid's geometry factors (module docstring);
    - T_ref degC; nonlin: lagged kappa(T); top: Dirichlet top;
    - n_start: the first ``n_start`` CN steps are each replaced by two backward-Euler half
      steps; damp: so is the first step of every observation interval (``h`` may jump there).
    """

    kappaT: np.ndarray
    CT: np.ndarray
    hT: np.ndarray
    qT: np.ndarray
    beta: np.ndarray
    T_air: np.ndarray
    T_bot: np.ndarray
    T_top: np.ndarray
    T0: np.ndarray
    t_obs: np.ndarray
    substeps: np.ndarray
    geo: np.ndarray
    dx0: float
    T_ref: float
    nonlin: bool
    top: bool
    n_start: int
    damp: bool


@njit(cache=True, fastmath=_FM, inline="always")
def _lin(v0, v1, w):
    """Linear interpolation ``v0 + w (v1 - v0)``."""
    return v0 + w * (v1 - v0)


@njit(cache=True, fastmath=_FM)
def _rates(kap, C, geo, dx0, a, c, hs):
    """Fill the per-node rates ``a``, ``c`` (1/s) and surface factor ``hs`` from cell kappa;
    ``geo = (ga, rho)`` and ``dx0``: the grid's geometry factors (module docstring)."""
    N, nb = a.shape
    ga, rho = geo[0], geo[1]
    g0 = ga[0]
    for s in range(nb):
        a[0, s] = 0.0
        c[0, s] = 2.0 * kap[0, s] * g0 / C[0, s]
        hs[s] = 2.0 / (C[0, s] * dx0)
    for i in range(1, N):
        gi = ga[i]
        ri = rho[i]
        for s in range(nb):
            inv = gi / C[i, s]
            a[i, s] = kap[i - 1, s] * inv
            c[i, s] = kap[i, s] * (inv * ri)


@njit(cache=True, fastmath=_FM)
def _lagged_kappa(kap0, beta, T_ref, T, Tb, kap):
    """``kap = kap0 (1 + beta (T_cell - T_ref))`` with ``T_cell`` the mean of the cell's nodes."""
    N, nb = T.shape
    for i in range(N - 1):
        for s in range(nb):
            Tc = 0.5 * (T[i, s] + T[i + 1, s])
            kap[i, s] = kap0[i, s] * (1.0 + beta[s] * (Tc - T_ref))
    for s in range(nb):
        Tc = 0.5 * (T[N - 1, s] + Tb)
        kap[N - 1, s] = kap0[N - 1, s] * (1.0 + beta[s] * (Tc - T_ref))


@njit(cache=True, fastmath=_FM)
def _cn_factor(a, c, r, l, u, g, invD, d0):
    """Bottom-up (reverse Thomas) factorisation of ``I + r A`` below the surface row.

    Row ``i``: ``-l[i] T[i-1] + (1 + l[i] + u[i]) T[i] - u[i] T[i+1] = R[i]``. Eliminating from
    the bottom gives ``T[i] = (R'[i] + l[i] T[i-1]) invD[i]`` with ``R'[i] = R[i] + g[i+1] R'[i+1]``
    and ``g[i+1] = u[i] invD[i+1]``. Only the surface pivot ``d0 + hc h`` depends on ``h``; ``d0``
    is returned without it.
    """
    N, nb = a.shape
    for s in range(nb):
        l[N - 1, s] = r * a[N - 1, s]
        u[N - 1, s] = r * c[N - 1, s]
        invD[N - 1, s] = 1.0 / (1.0 + l[N - 1, s] + u[N - 1, s])
    for i in range(N - 2, -1, -1):
        for s in range(nb):
            li = r * a[i, s]
            ui = r * c[i, s]
            l[i, s] = li
            u[i, s] = ui
            gi = ui * invD[i + 1, s]
            g[i + 1, s] = gi
            dd = 1.0 + li + ui - gi * l[i + 1, s]
            if i > 0:
                invD[i, s] = 1.0 / dd
            else:
                d0[s] = dd
                invD[0, s] = 0.0


@njit(cache=True, fastmath=_FM)
def _cn_step(T, R, l, u, g, invD0, hh, Ta_sum, Tb_sum, q_sum, invD, Tt1):
    """One Crank-Nicolson step in place: bottom-up RHS + reduction, then top-down substitution.

    ``hh = hc h`` (per set), ``Ta_sum = T_air^n + T_air^{n+1}``, ``Tb_sum`` likewise,
    ``q_sum = hc (q^n + q^{n+1})`` (per set), ``invD0 = 1 / (d0 + hh)``. Node 0 becomes
    ``rr invD0 + Tt1``: Robin ``Tt1 = 0`` (``fma(rr, invD0, 0)`` rounds as ``rr invD0``);
    Dirichlet top ``invD0 = 0`` (:func:`_surface_pivot`), ``Tt1 = T_top^{n+1}`` (``N >= 2``).
    Branch-free: a branch here costs ~10 % for few sets (measured).
    """
    N, nb = T.shape
    if N == 1:
        for s in range(nb):
            t0 = T[0, s]
            rr = t0 + u[0, s] * (Tb_sum - t0) + hh[s] * (Ta_sum - t0) + q_sum[s]
            T[0, s] = rr * invD0[s]
        return
    i = N - 1
    for s in range(nb):
        t = T[i, s]
        R[i, s] = t + l[i, s] * (T[i - 1, s] - t) + u[i, s] * (Tb_sum - t)
    for i in range(N - 2, 0, -1):
        for s in range(nb):
            t = T[i, s]
            R[i, s] = (
                t + l[i, s] * (T[i - 1, s] - t) + u[i, s] * (T[i + 1, s] - t) + g[i + 1, s] * R[i + 1, s]
            )
    for s in range(nb):
        t = T[0, s]
        rr = t + u[0, s] * (T[1, s] - t) + hh[s] * (Ta_sum - t) + q_sum[s] + g[1, s] * R[1, s]
        T[0, s] = rr * invD0[s] + Tt1
    for i in range(1, N):
        for s in range(nb):
            T[i, s] = (R[i, s] + l[i, s] * T[i - 1, s]) * invD[i, s]


@njit(cache=True, fastmath=_FM)
def _be_step(T, R, l, u, g, invD0, hh, Ta1, Tb1, q1, invD, Tt1):
    """One backward-Euler step of length ``r`` (half a CN step) with the CN factorisation.

    ``(I + r A) T^+ = T + r b(t^+)``: same matrix as CN, right-hand side without the explicit
    half; ``q1 = hc q(t^+)``; node 0 (Robin or Dirichlet top) as :func:`_cn_step`.
    """
    N, nb = T.shape
    if N == 1:
        for s in range(nb):
            T[0, s] = (T[0, s] + u[0, s] * Tb1 + hh[s] * Ta1 + q1[s]) * invD0[s]
        return
    i = N - 1
    for s in range(nb):
        R[i, s] = T[i, s] + u[i, s] * Tb1
    for i in range(N - 2, 0, -1):
        for s in range(nb):
            R[i, s] = T[i, s] + g[i + 1, s] * R[i + 1, s]
    for s in range(nb):
        T[0, s] = (T[0, s] + hh[s] * Ta1 + q1[s] + g[1, s] * R[1, s]) * invD0[s] + Tt1
    for i in range(1, N):
        for s in range(nb):
            T[i, s] = (R[i, s] + l[i, s] * T[i - 1, s]) * invD[i, s]


@njit(cache=True, fastmath=_FM)
def _surface_pivot(d0, hc, h, invD0, hh, top):
    """``hh = hc h``, ``invD0 = 1 / (d0 + hh)``; both 0 for a Dirichlet top (no surface row:
    the adjoint's ``mu[0] = R[0] invD0`` then vanishes, as it must)."""
    nb = d0.shape[0]
    if top:
        for s in range(nb):
            hh[s] = 0.0
            invD0[s] = 0.0
        return
    for s in range(nb):
        hh[s] = hc[s] * h[s]
        invD0[s] = 1.0 / (d0[s] + hh[s])


@njit(cache=True, fastmath=_FM)
def _prepare(geo, dx0, T_ref, top, nonlin, kap0, CB, beta, r, h, T, Tb0, w, z):
    """Rates, bottom-up factorisation and surface pivot for ``I + r A`` (lagged kappa if nonlin)."""
    kap, a, c, l, u, g, invD = w[0], w[1], w[2], w[3], w[4], w[5], w[6]
    d0, hs, hc, hh, invD0 = z[0], z[1], z[2], z[3], z[4]
    if nonlin:
        _lagged_kappa(kap0, beta, T_ref, T, Tb0, kap)
        _rates(kap, CB, geo, dx0, a, c, hs)
    else:
        _rates(kap0, CB, geo, dx0, a, c, hs)
    _cn_factor(a, c, r, l, u, g, invD, d0)
    for s in range(hs.shape[0]):
        hc[s] = r * hs[s]
    _surface_pivot(d0, hc, h, invD0, hh, top)


@njit(cache=True, fastmath=_FM)
def _be_pair(T, w, z, Tah, Tbh, Ta1, Tb1, qa, qb, wh, w1, Tth, Tt1):
    """Replace one CN step by two backward-Euler half steps (Rannacher start-up, damps the
    stiff modes excited by a non-smooth initial profile); ``w``, ``z`` hold the factorisation;
    ``Tth``, ``Tt1``: the Dirichlet top at the half steps' ends (0 for a Robin top)."""
    l, u, g, invD, R = w[3], w[4], w[5], w[6], w[7]
    hc, hh, invD0, qs = z[2], z[3], z[4], z[5]
    nb = T.shape[1]
    for s in range(nb):
        qs[s] = hc[s] * _lin(qa[s], qb[s], wh)
    _be_step(T, R, l, u, g, invD0, hh, Tah, Tbh, qs, invD, Tth)
    for s in range(nb):
        qs[s] = hc[s] * _lin(qa[s], qb[s], w1)
    _be_step(T, R, l, u, g, invD0, hh, Ta1, Tb1, qs, invD, Tt1)


@njit(cache=True, fastmath=_FM)
def _store(out, j, s0, T, Tb):
    N, nb = T.shape
    for i in range(N):
        for s in range(nb):
            out[j, i, s0 + s] = T[i, s]
    for s in range(nb):
        out[j, N, s0 + s] = Tb


@njit(cache=True, fastmath=_FM)
def _block_inputs(P, s0, nb):
    """The block's kappa, C (sets innermost) and its initial state (node 0 = ``T_top[0]`` if
    the top is Dirichlet)."""
    kappaT, CT, T0 = P.kappaT, P.CT, P.T0
    ncell = kappaT.shape[0]
    kap0 = np.empty((ncell, nb))
    CB = np.empty((ncell, nb))
    T = np.empty((ncell, nb))
    for i in range(ncell):
        for s in range(nb):
            kap0[i, s] = kappaT[i, s0 + s]
            CB[i, s] = CT[i, s0 + s]
            T[i, s] = T0[i]
    if P.top:
        for s in range(nb):
            T[0, s] = P.T_top[0]
    return kap0, CB, T
