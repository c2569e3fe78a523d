r"""Discrete adjoint (reverse mode, vector-Jacobian product) of the Crank–Nicolson solver.

:func:`solve_vjp` returns the forward solution of :func:`pavement_mcmc.solver.solve` (scheme
``"cn"``) together with the gradient of a scalar loss with respect to every coefficient, for
about the cost of two to three forward solves instead of one or two solves per coefficient by
finite differences. It is the EXACT gradient of the discrete scheme (Rannacher start-up included),
not of the continuous PDE, so it agrees with finite differences of ``solve`` to their accuracy.

Scheme recap (per set, see :mod:`pavement_mcmc.solver`): ``N`` unknown nodes, ``dT/dt = -A T +
b(t)``; in interval ``j`` (step ``dt``, ``r = dt/2``) ``M = I + r (A + h_j hs e_0 e_0^T)`` and

- a Crank–Nicolson step: :math:`M T^+ = (2I - M) T + r (b(t_0) + b(t_1))`;
- the first step of the run and of every observation interval: two backward-Euler half steps
  :math:`M T^+ = T + r\,b(t_{1/2})`, :math:`M T^{++} = T^+ + r\,b(t_1)`.

Adjoint. Write one step as :math:`G(p)\,=\,(M - I) X - r\,b_\Sigma = T - T^+` with
:math:`X = T + T^+`, :math:`b_\Sigma = b(t_0) + b(t_1)` (CN) or :math:`X = T^+`,
:math:`b_\Sigma = b(t^+)` (half step). With :math:`\lambda^+ = \mathrm{d}L/\mathrm{d}T^+` (the
cotangent of the outputs at that time plus what flows back from later steps) and
:math:`\mu = M^{-T}\lambda^+`:

.. math::

    \frac{\mathrm{d}L}{\mathrm{d}T} \mathrel{+}= (2I - M)^T\mu = 2\mu - \lambda^+ \;\text{(CN)},
    \quad \mu \;\text{(half step)};\qquad
    \frac{\mathrm{d}L}{\mathrm{d}p} \mathrel{+}= -\mu^T \frac{\partial G}{\partial p}.

Any grid (uniform or stretched: the rates carry the geometry factors of
:meth:`Grid._rate_geometry`, and :func:`_gradients` their derivatives). With a Dirichlet top
(``Forcing.T_top``) ``M`` is restricted to nodes ``1 .. N-1``; its transposed solve is the full
one with the surface pivot set to zero (:math:`\mu_0 = 0`), so ``h``, ``q`` and ``C_0`` get zero
gradients and :math:`\kappa_0` acts through :math:`a_1` only.

Because every row ``i`` of ``G`` is proportional to :math:`1/C_i`,
:math:`\partial L/\partial C_i \mathrel{+}= \mu_i (T_i - T^+_i)/C_i`; kappa of cell ``k`` enters
rows ``k`` (:math:`c_k`) and ``k+1`` (:math:`a_{k+1}`), the bottom cell's term coupling to
``T_bottom``; ``h_j`` and ``q`` enter the surface row (``q`` with its linear-in-time weights).
``M^T`` is solved with the forward kernel's bottom-up factorisation (same pivots), refactorised
only when the step length changes.

States and cost. The reverse sweep needs every solver state (slot) of the run. They are kept by
a forward pass of its own (the solver's steps and arithmetic, so ``out`` is ``solve``'s to
rounding — bitwise in practice) when that takes at most ``_STORE_MAX`` bytes (``8 n_sets
(n_nodes-1) (n_steps + n_half_step_pairs + 1)``, 54 KB per set on the reference case grid);
otherwise ``out`` comes from ``solve`` itself and each observation interval is recomputed from
it (one more forward's work, O(substeps x n_nodes x block) memory). Dispatch over sets as
``solve``: one set at a time up to ``solver._SCALAR_MAX`` sets, blocks of sets innermost, the
blocks on numba's threads from ``solver._PARALLEL_MIN`` sets. Measured on the reference case
(560 steps, 11 nodes; serial, best of 15, the machine shared): 2.3x the time of ``solve`` for
1 set, 2.8-3.1x for 16-32 sets, 3.2-3.7x for 256 sets (where the 14 MB of states stream
through memory).

Not supported (``ValueError``): the ``"dff"`` scheme and temperature-dependent conductivity
(``coeffs.beta`` with a nonzero entry), and grids with fewer than 3 nodes. Gradients with respect
to the forcing (``T_air``, ``T_bottom``, ``T0``) are not returned.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from . import forward as solver
from .grid import Grid
from .inputs import Coefficients, Forcing
from .kernels import adjoint as K
from .kernels import adjoint_scalar as KS

_STORE_MAX = 256 * 2**20  # bytes: keep every solver state up to this size, else recompute per interval


def solve_vjp(
    grid: Grid,
    forcing: Forcing,
    coeffs: Coefficients,
    cotangent_fn: Callable[[np.ndarray], np.ndarray],
    scheme: str = "cn",
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Forward Crank–Nicolson solve and the gradient of a loss of its output (reverse sweep).

    Parameters
    ----------
    grid, forcing, coeffs : as :func:`pavement_mcmc.solver.solve` (uniform or stretched grid,
        Robin or Dirichlet top); ``coeffs.beta`` must be ``None`` or all zero (linear conduction).
    cotangent_fn : ``cotangent_fn(out) -> G``; ``out`` is the (n_sets, n_obs, n_nodes) forward
        solution exactly as ``solve`` returns it, ``G`` (same shape) is ``d loss / d out``. The
        entries of ``G`` at ``t_obs[0]`` (the fixed initial profile) and at the bottom node (the
        prescribed ``T_bottom``) do not depend on the coefficients and are ignored. For a sum of
        per-set losses ``G[s]`` is the derivative of set ``s``'s loss, and each set's gradients
        below are those of its own loss.
    scheme : only ``"cn"``.

    Returns
    -------
    out : (n_sets, n_obs, n_nodes) temperatures, degC: ``solve(grid, forcing, coeffs)`` (same
        steps and arithmetic; a transposed view of a sets-innermost buffer, as ``solve``'s).
    grads : dict of ``d loss / d coefficient`` per set, shaped like the coefficients:
        ``"kappa"`` (n_sets, n_nodes-1), per W m-1 K-1; ``"C"`` (n_sets, n_nodes), per J m-3 K-1
        (the bottom node's entry is 0: it is unused); ``"h"`` (n_sets, n_obs-1), per W m-2 K-1;
        ``"q"`` (n_sets, n_obs), per W m-2. With a Dirichlet top ``h``, ``q`` and ``C[:, 0]``
        are 0 (they do not enter the scheme), and the cotangent of the top node is ignored.

    Example
    -------
    Gradient of ``0.5 * sum(W * (out - Y)**2)``::

        out, g = solve_vjp(grid, forcing, coeffs, lambda out: W * (out - Y))
    """
    if scheme != "cn":
        raise ValueError(
            f"solve_vjp supports scheme 'cn' only, got {scheme!r} (no adjoint of Du Fort-Frankel)"
        )
    kappa, C, h, q, beta = solver._check(grid, forcing, coeffs)
    if beta is not None and np.any(beta != 0.0):
        raise ValueError(
            "solve_vjp supports linear conduction only: coeffs.beta must be None or all zero "
            "(no adjoint of the lagged kappa(T))"
        )
    if grid.n_nodes < 3:
        raise ValueError(f"solve_vjp needs a grid with at least 3 nodes, got {grid.n_nodes}")
    S, N = kappa.shape
    n_obs = grid.n_obs
    P = solver._problem(grid, forcing, kappa, C, h, q, beta, coeffs.T_ref, False)
    n_slots = _n_slots(grid, P)
    stored = 8 * S * n_slots * N <= _STORE_MAX
    scalar = stored and S <= solver._SCALAR_MAX
    parallel = solver._parallel(S, grid)
    block = solver._block(S, parallel)
    # 1. forward: keeping every state (stored), or the ordinary solve (recomputed per interval)
    if stored:
        buf = np.empty(S * n_slots * N)
        outT = np.empty((n_obs, N + 1, S))
        if scalar:
            KS.fwd_scalar(P, outT, buf)
        else:
            (K.fwd_parallel if parallel else K.fwd_serial)(P, block, outT, buf)
        out = outT.transpose(2, 0, 1)
    else:
        buf = np.empty(0)
        out = solver.solve(grid, forcing, coeffs, scheme="cn")
        outT = out.transpose(1, 2, 0).copy()  # the checkpoints, safe from the callback
    # 2. cotangent
    G = np.asarray(cotangent_fn(out), dtype=float)
    if G.shape != out.shape:
        raise ValueError(f"cotangent_fn returned shape {G.shape}, expected the output's {out.shape}")
    if not solver._all_finite(G):
        raise ValueError("cotangent_fn returned non-finite values")
    G = np.ascontiguousarray(G)  # the kernels read it as it is: no transposed copy
    # 3. reverse sweep: the scale-free sums of pavement_mcmc.solver.kernels.adjoint, (n, n_sets) each
    acc = (np.empty((N, S)), np.empty((N, S)), np.empty((n_obs - 1, S)), np.empty((n_obs, S)))
    if scalar:
        KS.vjp_scalar(P, G, buf, acc)
    else:
        (K.vjp_parallel if parallel else K.vjp_serial)(P, outT, G, stored, buf, block, acc)
    grads = _gradients(grid, kappa, C, h, q, *(a.T for a in acc))
    if P.top:  # no surface row: C_0, h and q do not enter the scheme
        grads["C"][:, 0] = 0.0
        grads["h"][:] = 0.0
        grads["q"][:] = 0.0
    return out, grads


def _n_slots(grid: Grid, P) -> int:
    """Solver states of a run (the last slot of :func:`.kernels.adjoint.slot_layout`, plus 1),
    worked out once per grid and start-up (the grid is frozen)."""
    memo = grid.__dict__.setdefault("_n_slots", {})
    key = (P.n_start, P.damp)
    if key not in memo:
        memo[key] = int(K.slot_layout(P.substeps, P.n_start, P.damp)[1][-1]) + 1
    return memo[key]


def _gradients(grid, kappa, C, h, q, acc_a, acc_b, acc_h, acc_q) -> dict[str, np.ndarray]:
    """Gradients from the reverse sweep's sums (all (n_sets, n)); see :mod:`.kernels.adjoint`.

    With the geometry of :meth:`Grid._rate_geometry` (``c_k = f_k kappa_k / (C_k Vd_k d_k)``,
    ``f_0 = 2``, else 1; ``a_k+1 = kappa_k / (C_k+1 Vd_k+1 d_k)``):
    ``dL/dkappa_k = (-f_k acc_a[k] / C_k + (Vd_k / Vd_k+1) acc_b[k] / C_k+1) / (Vd_k d_k)`` and
    ``sum mu_i G_i = (f_i kappa_i acc_a[i] - (d_i / d_i-1) kappa_i-1 acc_b[i-1]) / (C_i Vd_i d_i)``.
    On a uniform grid the ratios are exactly 1 and ``Vd d = dx dx``.
    """
    geom = grid._rate_geometry()
    # the two sums over intervals in NumPy (its summation order); the rest compiled, the same
    # operations in the same order as the NumPy expressions in K.gradient_terms' docstring
    sums = np.sum(h * acc_h, axis=1) - np.sum(q * acc_q, axis=1)
    gk, gC, hs = K.gradient_terms(kappa, C, acc_a, acc_b, geom.vol_ratio, geom.inv_rho, geom.Vd,
                                  geom.d, geom.den, geom.dx0, sums)
    return {"kappa": gk, "C": gC, "h": -hs[:, None] * acc_h, "q": hs[:, None] * acc_q}
