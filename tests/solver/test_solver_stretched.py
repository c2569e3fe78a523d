"""Verification of the solver on stretched (non-uniform) grids and with a Dirichlet top.

Against answers that do not come from the solver: exact steady states of a layered ground,
analytical periodic solutions, observed orders of convergence, and the independent NumPy
implementation (``solve_numpy`` builds the operator from the cell widths, not from the kernels'
geometry factors). The deep-record default grid is checked on the shared real record.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import GRASS as DEEP

from pavement_mcmc.data import read_csv_case
from pavement_mcmc.solver import Coefficients, Forcing, Grid, solve, solve_numpy

SENSORS = [0.02, 0.05, 0.1, 0.2]  # m, the deep record's observed depths


def _stretched(L=0.3, t=None, dt=300.0, **kw):
    t = np.arange(0.0, 12 * 3600.0 + 1, 1800.0) if t is None else t
    kw = {"dx_top": 0.004, "growth": 1.15, "dx_max": 0.05, "nodes_at": [z for z in SENSORS if z < L], **kw}
    return Grid.stretched(L, t, dt=dt, **kw)


def _with_dt(grid: Grid, dt: float) -> Grid:
    """The same nodes with steps of at most ``dt`` seconds."""
    sub = np.maximum(1, np.ceil(np.diff(grid.t_obs) / dt * (1 - 1e-12))).astype(np.int64)
    return Grid(grid.L, grid.x, grid.t_obs, sub)


# ---------------------------------------------------------------------------------------------
# the stretched grid itself


def test_stretched_grid_places_nodes_and_bounds_cells():
    t = np.arange(0.0, 7200.0 + 1, 1800.0)
    g = Grid.stretched(0.5, t, dx_top=0.004, growth=1.05, dx_max=0.03, dt=1800.0 / 7, nodes_at=SENSORS)
    assert not g.uniform
    for z in [0.0, *SENSORS, 0.5]:  # exactly on nodes: no interpolation of observations
        assert np.any(g.x == z), z
    d = g.dx_cells
    np.testing.assert_allclose(d.sum(), 0.5, rtol=1e-14)
    # no cell exceeds the geometric target at its top, min(dx_top + (growth-1) x, dx_max)
    assert np.all(d <= np.minimum(0.004 + 0.05 * g.x[:-1], 0.03) * (1 + 1e-9))
    assert np.all(d[1:] / d[:-1] < 1.2)  # smooth: the sensor constraints add only mild kinks
    assert g.n_nodes < 0.5 * Grid.from_times(0.5, t).n_nodes
    np.testing.assert_array_equal(g.substeps, 7)
    np.testing.assert_allclose(g.volumes.sum(), 0.5, rtol=1e-14)
    np.testing.assert_allclose(g.volumes[[0, -1]], d[[0, -1]] / 2)
    with pytest.raises(ValueError, match="non-uniform.*dx_cells"):
        _ = g.dx
    fine = g.refined(4)
    np.testing.assert_array_equal(fine.x[::4], g.x)
    np.testing.assert_array_equal(fine.substeps, 4 * g.substeps)
    assert Grid.stretched(0.05, t, dx_top=0.005, growth=1.0).uniform  # growth 1: uniform dx_top
    with pytest.raises(ValueError, match="nodes_at"):
        Grid.stretched(0.5, t, nodes_at=[0.6])
    with pytest.raises(ValueError, match="growth >= 1"):
        Grid.stretched(0.5, t, growth=0.9)
    with pytest.raises(ValueError, match="strictly increasing"):
        Grid(0.05, np.array([0.0, 0.03, 0.02, 0.05]), t, np.ones(t.size - 1, int))


def test_uniform_grid_api_unchanged():
    g = Grid.from_times(0.05, np.arange(0.0, 3601.0, 900.0))
    assert g.uniform and g.dx == 0.005 and g.n_nodes == 11
    np.testing.assert_array_equal(g.dx_cells, np.full(10, 0.005))
    assert Grid(0.05, np.linspace(0.0, 0.05, 11), g.t_obs, g.substeps).uniform


# ---------------------------------------------------------------------------------------------
# 1. exact steady states of a layered ground (interfaces on nodes)


def _layered(grid):
    """kappa 0.8 above 5 cm, 2.5 from 5 to 10 cm, 1.4 below; C varies (irrelevant at steady state)."""
    xc = grid.x[:-1]
    kappa = np.where(xc < 0.05 - 1e-12, 0.8, np.where(xc < 0.1 - 1e-12, 2.5, 1.4))
    C = np.linspace(1.2e6, 2.4e6, grid.n_nodes)
    return kappa, C


@pytest.mark.parametrize("top", [False, True], ids=["robin", "dirichlet"])
def test_steady_state_layered_stretched_is_exact(top):
    L, Ta, Tb, Tt, h, q0 = 0.2, 25.0, 15.0, 31.0, 12.0, 150.0
    t = np.arange(0.0, 12 * 86400.0 + 1, 6 * 3600.0)
    grid = Grid.stretched(L, t, dx_top=0.003, growth=1.3, dx_max=0.04, dt=1800.0, nodes_at=[0.05, 0.1])
    assert not grid.uniform
    kappa, C = _layered(grid)
    n = grid.n_obs
    T_top = np.full(n, Tt) if top else None
    forcing = Forcing(np.full(n, Ta), np.full(n, Tb), np.full(grid.n_nodes, 20.0), T_top)
    coeffs = Coefficients(kappa[None], C[None], np.full((1, n - 1), h), np.full((1, n), q0))
    resist = np.r_[0.0, np.cumsum(grid.dx_cells / kappa)]  # m2 K W-1 from the surface
    if top:
        Ts = Tt
    else:
        Ts = (Tb + (h * Ta + q0) * resist[-1]) / (1.0 + h * resist[-1])
    exact = Ts - (Ts - Tb) * resist / resist[-1]  # piecewise linear, kinks at the interfaces
    T = solve(grid, forcing, coeffs)[0, -1]
    np.testing.assert_allclose(T, exact, rtol=0, atol=1e-9)
    # the exact steady state of a different layering is not reproduced
    wrong = Coefficients(np.full((1, grid.n_nodes - 1), 1.4), C[None], coeffs.h, coeffs.q)
    assert np.abs(solve(grid, forcing, wrong)[0, -1] - exact).max() > 0.1


# ---------------------------------------------------------------------------------------------
# 2. analytical transients on stretched grids


def _periodic_dirichlet_exact(x, t, L, kappa, C, amp, omega):
    """T(0, t) = amp cos(omega t), T(L) = 0: the periodic state Re[amp sinh(m (L-x)) / sinh(m L)
    e^{i omega t}], m = sqrt(i omega C / kappa)."""
    m = np.sqrt(1j * omega * C / kappa)
    A = amp * np.sinh(m * (L - x)) / np.sinh(m * L)
    return np.real(A[None, :] * np.exp(1j * omega * t)[:, None])


def test_dirichlet_top_periodic_surface_temperature_matches_analytic():
    """A daily surface-temperature wave (the shallowest sensor as the top) into a 48 cm column."""
    L, kappa, C, amp = 0.48, 1.2, 2.6e6, 8.0
    omega = 2 * np.pi / 86400.0
    t = np.arange(0.0, 86400.0 + 1, 300.0)  # 5-min samples: T_top is linear in between
    grid = Grid.stretched(L, t, dx_top=0.002, growth=1.05, dx_max=0.005, dt=20.0, nodes_at=[0.03, 0.08, 0.18])
    exact = _periodic_dirichlet_exact(grid.x, t, L, kappa, C, amp, omega)
    n = grid.n_obs
    forcing = Forcing(np.zeros(n), np.zeros(n), exact[0], T_top=amp * np.cos(omega * t))
    coeffs = Coefficients.uniform(kappa, C, np.full(n - 1, 10.0), np.full(n, 500.0), grid.n_nodes)
    T = solve(grid, forcing, coeffs)[0]
    np.testing.assert_allclose(T[:, 0], amp * np.cos(omega * t), rtol=0, atol=1e-12)
    err = np.abs(T - exact).max()
    # amplitude 8 degC; measured 4.6e-4, of which ~3e-4 is the linear-in-time interpolation of the
    # cosine between samples (amplitude loss amp (omega dt_obs)^2 / 12); 2 cm cells at 15 cm: 2e-3
    assert err < 1e-3, err
    wrong = Coefficients.uniform(1.1 * kappa, C, coeffs.h, coeffs.q, grid.n_nodes)
    assert np.abs(solve(grid, forcing, wrong)[0] - exact).max() > 20 * err


def test_dirichlet_top_ignores_surface_coefficients():
    grid = _stretched()
    n = grid.n_obs
    rng = np.random.default_rng(5)
    T0 = np.linspace(18, 12, grid.n_nodes)
    forcing = Forcing(rng.normal(20, 5, n), np.full(n, 12.0), T0, T_top=rng.normal(20, 3, n))
    kw = dict(kappa=1.1, C=2e6, n_nodes=grid.n_nodes)
    a = solve(grid, forcing, Coefficients.uniform(h=np.full(n - 1, 5.0), q=np.zeros(n), **kw))
    b = solve(grid, forcing, Coefficients.uniform(h=rng.uniform(1, 50, n - 1), q=rng.normal(0, 300, n), **kw))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(a[0, :, 0], forcing.T_top, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(a[0, :, -1], forcing.T_bottom)


# ---------------------------------------------------------------------------------------------
# 3. observed orders of convergence on a stretched grid


def _smooth(grid, top):
    L, omega, t = grid.L, 2 * np.pi / 86400.0, grid.t_obs
    forcing = Forcing(
        20 + 8 * np.sin(omega * t),
        np.full(t.size, 15.0),
        15.0 + 5.0 * np.cos(0.5 * np.pi * grid.x / L),
        20 + 5 * np.sin(omega * t) if top else None,
    )
    q = 300.0 * np.sin(omega * t)
    coeffs = Coefficients.uniform(1.31, 0.99e6, np.full(t.size - 1, 10.0), q, grid.n_nodes)
    return solve(grid, forcing, coeffs)[0]


def _order(u1, u2, u4):
    return np.log2(np.abs(u1 - u2).max() / np.abs(u2 - u4).max())


@pytest.mark.parametrize("top", [False, True], ids=["robin", "dirichlet"])
def test_second_order_in_space_and_time_on_stretched_grid(top):
    """Space: every cell split in 2 and 4 (nodes kept, dt = 5 s); time: dt 600/300/150 s on the
    4x refined grid. Measured 2.00 and 2.00 for both tops."""
    grid = _stretched(L=0.3, dt=5.0)
    assert not grid.uniform and grid.dx_cells.max() / grid.dx_cells.min() > 10
    p_x = _order(*(_smooth(grid.refined(k), top)[:, ::k] for k in (1, 2, 4)))
    fine = grid.refined(4)
    p_t = _order(*(_smooth(_with_dt(fine, dt), top) for dt in (600.0, 300.0, 150.0)))
    assert 1.85 < p_x < 2.15, p_x
    assert 1.85 < p_t < 2.15, p_t


# ---------------------------------------------------------------------------------------------
# 4. compiled kernels == plain NumPy on stretched grids


def _random_problem(rng, n_sets, top, beta, irregular=False):
    if irregular:
        t = np.cumsum(np.r_[0.0, rng.choice([600.0, 1200.0, 1800.0, 2700.0], 12)])
    else:
        t = np.arange(0.0, 8 * 3600.0 + 1, 1800.0)
    grid = _stretched(L=0.5, t=t, dt=700.0, growth=1.25)
    n = grid.n_obs
    depth = rng.uniform(0.02, 0.3, (n_sets, 1))
    kappa = np.where(grid.x[None, :-1] < depth, rng.uniform(0.4, 2.0, (n_sets, 1)), 1.5)
    forcing = Forcing(
        20 + 8 * np.sin(t / 7000.0),
        15 + 0.5 * np.cos(t / 9000.0),
        np.linspace(22.0, 15.0, grid.n_nodes) + 0.5 * np.sin(40.0 * grid.x),
        18 + 4 * np.sin(t / 5000.0) if top else None,
    )
    coeffs = Coefficients(
        kappa=kappa * rng.uniform(0.9, 1.1, (1, grid.n_nodes - 1)),
        C=np.where(grid.x[None] < depth, 1.2e6, 2.4e6) * rng.uniform(0.8, 1.2, (n_sets, 1)),
        h=np.clip(10 + np.cumsum(rng.normal(0, 3, (n_sets, n - 1)), 1), 0.5, 60),
        q=rng.normal(50, 150, (n_sets, n)),
        beta=rng.uniform(-5e-3, 5e-3, n_sets) if beta else None,
    )
    return grid, forcing, coeffs


@pytest.mark.parametrize("n_sets", [1, 3, 7, 70])  # scalar, scalar, serial blocks, parallel
@pytest.mark.parametrize("top", [False, True], ids=["robin", "dirichlet"])
@pytest.mark.parametrize("beta", [False, True], ids=["linear", "beta"])
def test_kernels_match_numpy_on_stretched_grid(n_sets, top, beta):
    rng = np.random.default_rng(100 * n_sets + 10 * top + beta)
    grid, forcing, coeffs = _random_problem(rng, n_sets, top, beta, irregular=n_sets == 3)
    T = solve(grid, forcing, coeffs)
    np.testing.assert_allclose(T, solve_numpy(grid, forcing, coeffs), rtol=0, atol=1e-10)
    if beta:  # beta changes the answer; beta = 0 gives the linear kernels' result
        coeffs.beta = np.zeros(n_sets)
        assert np.abs(solve(grid, forcing, coeffs) - T).max() > 1e-3


def test_dff_refuses_stretched_grids_and_dirichlet_top():
    rng = np.random.default_rng(0)
    grid, forcing, coeffs = _random_problem(rng, 2, False, False)
    with pytest.raises(ValueError, match="uniform grid with a Robin top"):
        solve(grid, forcing, coeffs, scheme="dff")
    u = Grid.from_times(0.05, grid.t_obs, dt=30.0)
    f = Forcing(forcing.T_air, forcing.T_bottom, np.full(u.n_nodes, 18.0), T_top=forcing.T_air)
    c = Coefficients.uniform(1.0, 1e6, coeffs.h[0], coeffs.q[0], u.n_nodes)
    with pytest.raises(ValueError, match="uniform grid with a Robin top"):
        solve(u, f, c, scheme="dff")
    with pytest.raises(ValueError, match="T_top"):
        solve(u, Forcing(f.T_air, f.T_bottom, f.T0, T_top=f.T_top[:-1]), c)


# ---------------------------------------------------------------------------------------------
# 5. the recommended deep-record grid, on the shared real record


@pytest.fixture(scope="module")
def deep():
    if not DEEP.exists():
        pytest.skip(f"shared real record not found at {DEEP} (it is not shipped with the project)")
    return read_csv_case(DEEP, sigma=0.1, window_hours=[168, 240])


def _deep_error(meas, grid, kappa=1.2, C=2.6e6):
    sols = []
    for g in (grid, grid.refined(4)):
        c = Coefficients.uniform(kappa, C, np.full(g.n_obs - 1, 10.0), meas.q_net, g.n_nodes)
        sols.append(solve(g, Forcing.from_measurements(meas, g), c)[0])
    return np.abs(sols[0] - sols[1][:, ::4]).max()


def test_recommended_deep_grid_within_a_hundredth_of_a_degree(deep):
    """72 h, 30-min data, 50 cm, kappa 1.2, C 2.6e6, h 10: the default stretched grid is within
    0.01 degC of its 4x refinement (measured 0.0085) with under half the uniform grid's nodes;
    faster growth (x1.3, too coarse at 10-20 cm where the daily wave is still large) is not."""
    grid = Grid.build_stretched(deep)
    assert grid.n_nodes < 0.5 * Grid.build(deep).n_nodes
    assert all(np.any(grid.x == z) for z in deep.depths)
    assert _deep_error(deep, grid) <= 0.01
    assert _deep_error(deep, Grid.build_stretched(deep, growth=1.3)) > 0.02
    # shallowest sensor as a Dirichlet top: the grid starts at 2 cm
    d0 = deep.depths[0]
    top = deep.with_measured_top()
    top_grid = Grid.build_stretched(top)
    assert top_grid.L == deep.bottom_depth - d0 and all(np.any(top_grid.x == z) for z in deep.depths - d0)
    assert _deep_error(top, top_grid) <= 0.002  # measured 0.0008
    forcing = Forcing.from_measurements(top, top_grid)
    np.testing.assert_array_equal(forcing.T_top, deep.T_obs[:, 0])
    np.testing.assert_allclose(forcing.T0[np.searchsorted(top_grid.x, deep.depths - d0)], deep.T_obs[0])
    assert Grid.build(top).L == top_grid.L
    with pytest.raises(ValueError, match="differs from bottom_depth"):
        Forcing.from_measurements(top, grid)


def test_long_solves_of_16_sets_use_the_threads_and_give_the_serial_answer(monkeypatch):
    """A long solve (sets x steps x nodes above forward._PARALLEL_WORK) of 16 sets runs its two
    blocks of 8 on numba's threads: the temperatures and the adjoint's gradients are the serial
    blocks' bit for bit (each set's arithmetic does not depend on the block it is in)."""
    import numba

    from pavement_mcmc.solver import forward, solve_vjp

    if numba.get_num_threads() < 2:
        pytest.skip("one numba thread on this machine")
    rng = np.random.default_rng(7)
    grid, forcing, coeffs = _random_problem(rng, 16, False, False)
    work = 16 * grid.substeps.sum() * grid.n_nodes
    monkeypatch.setattr(forward, "_PARALLEL_WORK", work)  # this problem counts as long
    assert forward._parallel(16, grid) and not forward._parallel(8, grid)

    def run():
        return solve_vjp(grid, forcing, coeffs, lambda T: np.sin(T))

    T_par, g_par = run()
    monkeypatch.setattr(forward, "_PARALLEL_WORK", np.inf)
    assert not forward._parallel(16, grid)
    T_ser, g_ser = run()
    assert np.array_equal(T_par, T_ser)
    for k in g_ser:
        assert np.array_equal(g_par[k], g_ser[k]), k
    assert np.array_equal(solve(grid, forcing, coeffs), T_ser)
