"""The vector CN kernel (``kernels.cn_simd`` on ``kernels.simd``) against the loop-over-sets steps.

The vector steps must give the loop steps' numbers bit for bit (same operations, same fused
multiply-adds): the adjoint's forward pass runs the loop steps, and its gradients are those of the
solver's output only if both integrate the same numbers; the adjoint's own vector steps (forward
and reverse) must give its loop steps' numbers. Checked against a reference driver
written here from the loop pieces of ``kernels.cn`` and against ``solve_vjp``'s stored forward
pass, with set counts that are not multiples of the vector width (padding), a Dirichlet top, the
lagged kappa(T), and step lengths that change between intervals.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from numba import njit

from pavement_mcmc.solver import Coefficients, Forcing, Grid, adjoint, solve, solve_vjp
from pavement_mcmc.solver import forward as solver
from pavement_mcmc.solver.kernels import cn as K
from pavement_mcmc.solver.kernels import simd


def _problem(rng, n_sets, top=False, beta=False):
    """Irregular observation times (1-4 substeps, changing step length), two layers, q != 0."""
    t = np.cumsum(np.r_[0.0, rng.choice([300.0, 600.0, 900.0, 2400.0], 12)])
    grid = Grid.from_times(0.05, t, dx=0.05 / 7, dt=700.0)
    forcing = Forcing(
        T_air=20.0 + 8.0 * np.sin(t / 7000.0),
        T_bottom=15.0 + 0.5 * np.cos(t / 9000.0),
        T0=np.linspace(22.0, 15.0, grid.n_nodes) + 0.5 * np.sin(40.0 * grid.x),
    )
    if top:
        forcing = dataclasses.replace(forcing, T_top=24.0 + 3.0 * np.sin(t / 5000.0))
    upper = grid.x < 0.02 - 1e-12
    coeffs = Coefficients(
        kappa=np.where(upper[:-1], 0.9, 2.2) * rng.uniform(0.8, 1.2, (n_sets, 1)),
        C=np.where(upper, 1.2e6, 2.0e6) * rng.uniform(0.8, 1.2, (n_sets, 1)),
        h=rng.uniform(2.0, 40.0, (n_sets, grid.n_obs - 1)),
        q=rng.normal(50.0, 80.0, (n_sets, grid.n_obs)),
        beta=rng.uniform(-0.02, 0.02, n_sets) if beta else None,
    )
    return grid, forcing, coeffs


def _loop_reference(P):
    """The forward CN integration from ``kernels.cn``'s loop steps, driven from Python (the
    factorisation redone every step: the same numbers)."""
    N, S = P.kappaT.shape
    kap0, CB, T = K._block_inputs(P, 0, S)
    w, z = np.zeros((8, N, S)), np.zeros((6, S))
    out = np.empty((P.t_obs.size, N + 1, S))
    K._store(out, 0, 0, T, P.T_bot[0])
    nstep = 0
    for j, ns in enumerate(P.substeps):
        r = 0.5 * (P.t_obs[j + 1] - P.t_obs[j]) / ns
        qa, qb = P.qT[j], P.qT[j + 1]
        for m in range(ns):
            w0, w1, wh = m / ns, (m + 1) / ns, (m + 0.5) / ns
            ends = (P.T_air, P.T_bot, P.T_top)
            at = {v: tuple(K._lin(a[j], a[j + 1], v) for a in ends) for v in (w0, w1, wh)}
            K._prepare(P.geo, P.dx0, P.T_ref, P.top, P.nonlin, kap0, CB, P.beta, r, P.hT[j].copy(), T,
                       at[w0][1], w, z)
            if nstep < P.n_start or (m == 0 and P.damp):
                (Tah, Tbh, Tth), (Ta1, Tb1, Tt1) = at[wh], at[w1]
                K._be_pair(T, w, z, Tah, Tbh, Ta1, Tb1, qa, qb, wh, w1, Tth, Tt1)
            else:
                z[5] = [z[2, s] * (K._lin(qa[s], qb[s], w0) + K._lin(qa[s], qb[s], w1)) for s in range(S)]
                K._cn_step(T, w[7], w[3], w[4], w[5], z[4], z[3], at[w0][0] + at[w1][0],
                           at[w0][1] + at[w1][1], z[5], w[6], at[w1][2])
            nstep += 1
        K._store(out, j + 1, 0, T, P.T_bot[j + 1])
    return out.transpose(2, 0, 1)


@pytest.mark.parametrize("n_sets", [5, 8, 13])
@pytest.mark.parametrize("top, beta", [(False, False), (True, False), (False, True), (True, True)])
def test_vector_kernel_equals_loop_steps_bit_for_bit(n_sets, top, beta):
    rng = np.random.default_rng(10 + n_sets)
    grid, forcing, coeffs = _problem(rng, n_sets, top, beta)
    out = solve(grid, forcing, coeffs)
    P = solver._problem(grid, forcing, *solver._check(grid, forcing, coeffs), coeffs.T_ref, beta)
    np.testing.assert_array_equal(out, _loop_reference(P))
    assert np.isfinite(out).all() and out.std() > 0.5


@pytest.mark.parametrize("n_sets", [5, 21])
def test_vector_kernel_equals_adjoint_forward_pass(n_sets):
    """``solve_vjp``'s stored forward pass (the loop steps, compiled) gives ``solve``'s numbers."""
    grid, forcing, coeffs = _problem(np.random.default_rng(n_sets), n_sets, top=n_sets > 5)
    out, _ = solve_vjp(grid, forcing, coeffs, np.zeros_like)
    np.testing.assert_array_equal(out, solve(grid, forcing, coeffs))


@njit
def _fma_lanes(a, b, c, out):
    """Row 1 of ``out`` = fma(a, b, c) + 0 * ..., one 16-wide vector then two 8-wide ones."""
    v = simd.vfma(simd.vload(a, 0, 0, 16), simd.vload(b, 0, 0, 16), simd.vload(c, 0, 0, 16))
    simd.vstore(out, 1, 0, simd.vadd(simd.vsub(v, simd.vsplat(0.0, v)), simd.vmul(v, simd.vsplat(0, v))))
    for s in range(16, a.shape[1], simd.W):
        v = simd.vfma(simd.vload(a, 0, s, 8), simd.vload(b, 0, s, 8), simd.vload(c, 0, s, 8))
        simd.vstore(out, 1, s, v)


def test_simd_fma_rounds_once_and_lanes_land_in_place():
    """``(1 + e)(1 - e) - 1 = -e^2`` exactly with one rounding (0 with two), in vectors of 16
    and of 8; row 1 of ``out`` gets the lanes in order, rows 0 and 2 stay untouched."""
    e = 2.0**-30
    n = 32
    scale = np.repeat([1.0, 2.0, 1.0, 2.0], 8)
    a = (np.full(n, 1.0 + e) * scale)[None]
    b, c = np.full((1, n), 1.0 - e), -scale[None]
    out = np.full((3, n), 7.0)
    _fma_lanes(a, b, c, out)
    np.testing.assert_array_equal(out[1], -(e**2) * scale)
    assert (a[0, 0] * b[0, 0] + c[0, 0]) == 0.0  # the product rounded first loses it
    np.testing.assert_array_equal(out[[0, 2]], 7.0)


def test_simd_refuses_non_contiguous_arrays():
    @njit
    def load(a):
        return simd.vstore(a, 0, 0, simd.vload(a, 0, 0, 8))

    with pytest.raises(Exception, match="C-contiguous 2-D float64"):
        load(np.zeros((4, 16))[:, ::2])


@pytest.mark.parametrize("store", [True, False], ids=["stored", "recomputed"])
@pytest.mark.parametrize("top", [False, True])
def test_adjoint_on_vectors_equals_adjoint_on_loops(store, top, monkeypatch):
    """8 sets run the adjoint's vector steps (forward and reverse), 9 sets (no whole number of
    vectors) its loop steps: the 8 sets' outputs and gradients agree bit for bit."""
    if not store:
        monkeypatch.setattr(adjoint, "_STORE_MAX", 0)
    grid, forcing, coeffs = _problem(np.random.default_rng(7), 9, top=top)
    eight = Coefficients(**{k: getattr(coeffs, k)[:8] for k in ("kappa", "C", "h", "q")})
    out9, g9 = solve_vjp(grid, forcing, coeffs, lambda o: o - 20.0)
    out8, g8 = solve_vjp(grid, forcing, eight, lambda o: o - 20.0)
    np.testing.assert_array_equal(out8, out9[:8])
    for name, g in g8.items():
        np.testing.assert_array_equal(g, g9[name][:8])
        assert name in ("h", "q") and top or np.abs(g).max() > 0
