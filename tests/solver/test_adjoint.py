"""The discrete adjoint (:func:`pavement_mcmc.solver.adjoint.solve_vjp`) against the forward solver.

The forward output must be the solver's; the gradients of a random quadratic loss must match
central finite differences of :func:`pavement_mcmc.solver.solve` for every coefficient.
"""

from __future__ import annotations

from pathlib import Path

import numba
import numpy as np
import pytest

from pavement_mcmc.data import read_csv_case
from pavement_mcmc.solver import Coefficients, Forcing, Grid, adjoint, solve, solve_vjp
from pavement_mcmc.solver import forward as solver

CASE = Path(__file__).resolve().parents[2] / "data" / "reference_case" / "measurements.csv"
NAMES = ("kappa", "C", "h", "q")


@pytest.fixture(scope="module")
def ref():
    """The reference case on the default grid (dx 5 mm, dt 180 s, 15-min data, 28 h)."""
    meas = read_csv_case(CASE, sigma=0.25)
    grid = Grid.build(meas)
    return meas, grid, Forcing.from_measurements(meas, grid)


def _random_coeffs(rng, grid, n_sets, q_base):
    """Layered kappa and C (random per cell / node), random positive h per interval, q != 0."""
    n, m = grid.n_nodes, grid.n_obs
    return Coefficients(
        kappa=rng.uniform(0.6, 2.6, (n_sets, n - 1)),
        C=rng.uniform(0.8e6, 2.4e6, (n_sets, n)),
        h=rng.uniform(1.0, 30.0, (n_sets, m - 1)),
        q=q_base + rng.normal(0.0, 30.0, (n_sets, m)),
    )


def _loss_parts(rng, out):
    """Weights W and targets Y of ``loss = 0.5 sum W (out - Y)^2`` (per set)."""
    return rng.uniform(0.5, 2.0, out.shape), out + rng.normal(0.0, 1.0, out.shape)


def _fd_grads(grid, forcing, coeffs, W, Y, rel=1e-5, q_step=1.0):
    """Central differences of the per-set loss for every coefficient, all in ONE batched solve.

    kappa, C, h: relative steps ``rel`` (truncation ~rel^2, rounding ~1e-16/rel, both far below
    the 1e-6 tolerance); q: absolute ``q_step`` (the output is linear in q: exact). The loss
    difference uses ``L+ - L- = 0.5 sum W (o+ - o-)(o+ + o- - 2 Y)`` (no cancellation).
    """
    S = coeffs.n_sets
    base = {k: np.asarray(getattr(coeffs, k), float) for k in NAMES}
    blocks, meta = {k: [] for k in NAMES}, []
    for name in NAMES:
        P = base[name].shape[1] - (1 if name == "C" else 0)  # the bottom C is unused
        for p in range(P):
            step = q_step if name == "q" else rel * base[name][:, p]
            for sign in (1.0, -1.0):
                arrays = {k: v.copy() for k, v in base.items()}
                arrays[name][:, p] += sign * step
                for k in NAMES:
                    blocks[k].append(arrays[k])
            meta.append((name, p, step))
    big = Coefficients(**{k: np.concatenate(v) for k, v in blocks.items()})
    out = solve(grid, forcing, big).reshape(len(meta), 2, S, grid.n_obs, grid.n_nodes)
    fd = {k: np.zeros_like(base[k]) for k in NAMES}
    for n, (name, p, step) in enumerate(meta):
        op, om = out[n, 0], out[n, 1]
        dL = 0.5 * np.sum(W * (op - om) * (op + om - 2.0 * Y), axis=(1, 2))
        fd[name][:, p] = dL / (2.0 * step)
    return fd


def _assert_grads_match(grads, fd, rtol=1e-6, names=NAMES, c_from=0):
    """Per set and coefficient kind: |ad - fd| <= rtol |fd| + rtol max|fd| (the absolute part
    covers the components that are tiny next to the largest of their kind). C from node
    ``c_from`` on (a Dirichlet top's C_0 is unused)."""
    for name in names:
        ad, ref = grads[name], fd[name]
        if name == "C":
            np.testing.assert_array_equal(ad[:, -1], 0.0)
            ad, ref = ad[:, c_from:-1], ref[:, c_from:-1]
        assert ad.shape == ref.shape
        scale = np.abs(ref).max(axis=1, keepdims=True)
        assert np.all(scale > 0), name
        err = np.abs(ad - ref) / (np.abs(ref) + scale)
        assert err.max() < rtol, f"{name}: max scaled error {err.max():.2e} (set, index) = " + str(
            np.unravel_index(err.argmax(), err.shape)
        )


def _vjp(grid, forcing, coeffs, W, Y):
    return solve_vjp(grid, forcing, coeffs, lambda out: W * (out - Y))


# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("store", [True, False], ids=["stored", "recomputed"])
def test_gradients_match_finite_differences_on_reference_case(ref, store, monkeypatch):
    """Every kappa cell, C node, h_j and q_j, three layered sets, random h, nonzero q; the
    forward output equals solve's. Both state sources: stored, and recomputed per interval."""
    if not store:
        monkeypatch.setattr(adjoint, "_STORE_MAX", 0)
    meas, grid, forcing = ref
    rng = np.random.default_rng(1)
    coeffs = _random_coeffs(rng, grid, 3, meas.q_net)
    W, Y = _loss_parts(rng, solve(grid, forcing, coeffs))
    out, grads = _vjp(grid, forcing, coeffs, W, Y)
    np.testing.assert_allclose(out, solve(grid, forcing, coeffs), rtol=0, atol=1e-10)
    assert set(grads) == set(NAMES)
    for name in NAMES:
        assert grads[name].shape == np.shape(getattr(coeffs, name))
    _assert_grads_match(grads, _fd_grads(grid, forcing, coeffs, W, Y))


def _irregular_problem(rng, n_sets, n_cells=6):
    """Irregular observation times: step lengths change between intervals, 1 to 4 substeps,
    two-layer ground (kappa and C jump at 2 cm), smooth forcing."""
    t = np.cumsum(np.r_[0.0, rng.choice([300.0, 600.0, 900.0, 1500.0, 2400.0], 16)])
    grid = Grid.from_times(0.05, t, dx=0.05 / n_cells, dt=700.0)
    assert len(set(np.round(grid.step_dt, 6))) > 2 and grid.substeps.max() > 1
    forcing = Forcing(
        T_air=20.0 + 8.0 * np.sin(t / 7000.0),
        T_bottom=15.0 + 0.5 * np.cos(t / 9000.0),
        T0=np.linspace(22.0, 15.0, grid.n_nodes) + 0.5 * np.sin(40.0 * grid.x),
    )
    upper = grid.x < 0.02 - 1e-12
    kappa = np.where(upper[:-1], 0.9, 2.2) * rng.uniform(0.8, 1.2, (n_sets, 1))
    C = np.where(upper, 1.2e6, 2.0e6) * rng.uniform(0.8, 1.2, (n_sets, 1))
    coeffs = Coefficients(
        kappa=kappa,
        C=C,
        h=rng.uniform(2.0, 40.0, (n_sets, grid.n_obs - 1)),
        q=rng.normal(50.0, 80.0, (n_sets, grid.n_obs)),
    )
    return grid, forcing, coeffs


@pytest.mark.parametrize("n_start, damp", [(1, True), (3, False), (0, False)])
def test_gradients_irregular_layered_grid(n_start, damp, monkeypatch):
    """Step length changing between intervals (refactorisation in the reverse sweep), a layered
    ground, and the start-up variants (solve reads the same module constants)."""
    monkeypatch.setattr(solver, "_N_START", n_start)
    monkeypatch.setattr(solver, "_DAMP", damp)
    rng = np.random.default_rng(2)
    grid, forcing, coeffs = _irregular_problem(rng, 5)
    W, Y = _loss_parts(rng, solve(grid, forcing, coeffs))
    out, grads = _vjp(grid, forcing, coeffs, W, Y)
    np.testing.assert_allclose(out, solve(grid, forcing, coeffs), rtol=0, atol=1e-10)
    _assert_grads_match(grads, _fd_grads(grid, forcing, coeffs, W, Y))
    monkeypatch.setattr(adjoint, "_STORE_MAX", 0)  # recomputed states: the same numbers
    out2, grads2 = _vjp(grid, forcing, coeffs, W, Y)
    np.testing.assert_array_equal(out2, out)
    for name in NAMES:
        np.testing.assert_allclose(grads2[name], grads[name], rtol=1e-12, atol=0)


def test_sets_are_independent_and_blocks_agree(ref):
    """Many sets (several blocks; numba's threads when available): each set's gradient equals
    the one computed for that set alone, so set s only sees G[s]."""
    meas, grid, forcing = ref
    rng = np.random.default_rng(3)
    S = 70
    coeffs = _random_coeffs(rng, grid, S, meas.q_net)
    W, Y = _loss_parts(rng, solve(grid, forcing, coeffs))
    out, grads = _vjp(grid, forcing, coeffs, W, Y)
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)  # serial kernels, one block
        out1, grads1 = _vjp(grid, forcing, coeffs, W, Y)
    finally:
        numba.set_num_threads(threads)
    np.testing.assert_array_equal(out1, out)
    for s in (0, 33, S - 1):
        one = Coefficients(**{k: getattr(coeffs, k)[s : s + 1] for k in NAMES})
        o, g = _vjp(grid, forcing, one, W[s : s + 1], Y[s : s + 1])
        np.testing.assert_allclose(o[0], out[s], rtol=0, atol=1e-12)
        for name in NAMES:
            np.testing.assert_allclose(g[name][0], grads[name][s], rtol=1e-10, atol=0)
            np.testing.assert_allclose(grads1[name][s], grads[name][s], rtol=1e-10, atol=0)


def test_ignored_cotangent_entries(ref):
    """The cotangent of the initial row and of the Dirichlet bottom node changes nothing."""
    meas, grid, forcing = ref
    rng = np.random.default_rng(4)
    coeffs = _random_coeffs(rng, grid, 2, meas.q_net)
    G = rng.normal(size=(2, grid.n_obs, grid.n_nodes))
    G2 = G.copy()
    G2[:, 0, :] = 7.0
    G2[:, :, -1] = -3.0
    g1 = solve_vjp(grid, forcing, coeffs, lambda out: G)[1]
    g2 = solve_vjp(grid, forcing, coeffs, lambda out: G2)[1]
    for name in NAMES:
        np.testing.assert_array_equal(g1[name], g2[name])


def test_unsupported_inputs_raise(ref):
    meas, grid, forcing = ref
    coeffs = Coefficients.uniform(1.3, 1e6, np.full(grid.n_obs - 1, 10.0), meas.q_net, grid.n_nodes)

    def zero(out):
        return np.zeros_like(out)

    with pytest.raises(ValueError, match="scheme 'cn' only"):
        solve_vjp(grid, forcing, coeffs, zero, scheme="dff")
    nonlin = Coefficients.uniform(
        1.3, 1e6, np.full(grid.n_obs - 1, 10.0), meas.q_net, grid.n_nodes, beta=[-0.005]
    )
    with pytest.raises(ValueError, match="beta"):
        solve_vjp(grid, forcing, nonlin, zero)
    zero_beta = Coefficients.uniform(
        1.3, 1e6, np.full(grid.n_obs - 1, 10.0), meas.q_net, grid.n_nodes, beta=[0.0]
    )
    solve_vjp(grid, forcing, zero_beta, zero)  # beta all zero is linear: accepted
    with pytest.raises(ValueError, match="cotangent_fn returned shape"):
        solve_vjp(grid, forcing, coeffs, lambda out: out[:, 1:])
    with pytest.raises(ValueError, match="Coefficients.h"):
        bad = Coefficients.uniform(1.3, 1e6, np.full(grid.n_obs, 10.0), meas.q_net, grid.n_nodes)
        solve_vjp(grid, forcing, bad, zero)
    tiny = Grid.from_times(0.01, np.arange(0.0, 3601.0, 900.0), dx=0.01)
    with pytest.raises(ValueError, match="at least 3 nodes"):
        solve_vjp(
            tiny,
            Forcing(np.full(5, 20.0), np.full(5, 15.0), np.full(2, 18.0)),
            Coefficients.uniform(1.3, 1e6, np.full(4, 10.0), np.zeros(5), 2),
            zero,
        )


# ---------------------------------------------------------------------------------------------
# stretched grids and a Dirichlet top


def _stretched_problem(rng, n_sets, top):
    """A stretched grid (cells 3 mm to 8 cm, nodes at 2, 5, 10, 20 cm), irregular observation
    times (1 to 4 substeps, step length changing), layered ground, Robin or Dirichlet top."""
    t = np.cumsum(np.r_[0.0, rng.choice([600.0, 1200.0, 1800.0, 2700.0], 12)])
    depths = [0.02, 0.05, 0.1, 0.2]
    grid = Grid.stretched(0.5, t, dx_top=0.003, growth=1.35, dx_max=0.08, dt=500.0, nodes_at=depths)
    assert not grid.uniform and len(set(np.round(grid.step_dt, 6))) > 2
    forcing = Forcing(
        T_air=20.0 + 8.0 * np.sin(t / 7000.0),
        T_bottom=15.0 + 0.5 * np.cos(t / 9000.0),
        T0=np.linspace(22.0, 15.0, grid.n_nodes) + 0.5 * np.sin(20.0 * grid.x),
        T_top=18.0 + 4.0 * np.sin(t / 5000.0) if top else None,
    )
    upper = grid.x < 0.1 - 1e-12
    coeffs = Coefficients(
        kappa=np.where(upper[:-1], 0.9, 2.2) * rng.uniform(0.8, 1.2, (n_sets, grid.n_nodes - 1)),
        C=np.where(upper, 1.2e6, 2.0e6) * rng.uniform(0.8, 1.2, (n_sets, grid.n_nodes)),
        h=rng.uniform(2.0, 40.0, (n_sets, grid.n_obs - 1)),
        q=rng.normal(50.0, 80.0, (n_sets, grid.n_obs)),
    )
    return grid, forcing, coeffs


@pytest.mark.parametrize("n_sets", [2, 9], ids=["scalar", "blocks"])
@pytest.mark.parametrize("top", [False, True], ids=["robin", "dirichlet"])
def test_gradients_stretched_grid(n_sets, top, monkeypatch):
    """Every kappa cell and C node (and h_j, q_j with a Robin top) against central differences
    on a stretched grid; with a Dirichlet top the h, q and C_0 gradients are exactly zero (they
    do not enter the scheme). Stored and recomputed states give the same numbers."""
    rng = np.random.default_rng(10 + n_sets + top)
    grid, forcing, coeffs = _stretched_problem(rng, n_sets, top)
    W, Y = _loss_parts(rng, solve(grid, forcing, coeffs))
    out, grads = _vjp(grid, forcing, coeffs, W, Y)
    np.testing.assert_allclose(out, solve(grid, forcing, coeffs), rtol=0, atol=1e-10)
    fd = _fd_grads(grid, forcing, coeffs, W, Y)
    if top:
        _assert_grads_match(grads, fd, names=("kappa", "C"), c_from=1)
        for name in ("h", "q"):
            np.testing.assert_array_equal(grads[name], 0.0)
            np.testing.assert_array_equal(fd[name], 0.0)
        np.testing.assert_array_equal(grads["C"][:, 0], 0.0)
    else:
        _assert_grads_match(grads, fd)
    monkeypatch.setattr(adjoint, "_STORE_MAX", 0)
    out2, grads2 = _vjp(grid, forcing, coeffs, W, Y)
    np.testing.assert_allclose(out2, out, rtol=0, atol=1e-12)
    for name in NAMES:
        np.testing.assert_allclose(grads2[name], grads[name], rtol=1e-10, atol=0)


def test_dirichlet_top_many_sets_and_ignored_cotangent():
    """70 sets (numba's threads when available) on a stretched grid with a Dirichlet top: each
    set's gradient equals its own single-set gradient, and the cotangent of the top node (a
    prescribed temperature, like the bottom) changes nothing."""
    rng = np.random.default_rng(7)
    grid, forcing, coeffs = _stretched_problem(rng, 70, True)
    G = rng.normal(size=(70, grid.n_obs, grid.n_nodes))
    out, grads = solve_vjp(grid, forcing, coeffs, lambda o: G)
    G2 = G.copy()
    G2[:, :, 0] = 5.0
    grads2 = solve_vjp(grid, forcing, coeffs, lambda o: G2)[1]
    for name in NAMES:
        np.testing.assert_array_equal(grads2[name], grads[name])
    for s in (0, 41, 69):
        one = Coefficients(**{k: getattr(coeffs, k)[s : s + 1] for k in NAMES})
        o, g = solve_vjp(grid, forcing, one, lambda o, s=s: G[s : s + 1])
        np.testing.assert_allclose(o[0], out[s], rtol=0, atol=1e-12)
        for name in NAMES:
            np.testing.assert_allclose(g[name][0], grads[name][s], rtol=1e-10, atol=1e-300)
