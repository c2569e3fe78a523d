"""Verification of the forward solver against answers that do not come from the solver.

Analytical steady and transient solutions, observed orders of convergence, grid convergence on
the shipped reference case, and the compiled kernels against the independent NumPy baseline.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.data import Measurements, read_csv_case
from pavement_mcmc.solver import (
    SCHEMES,
    Coefficients,
    Forcing,
    Grid,
    solve,
    solve_numpy,
)

CASE = Path(__file__).resolve().parents[2] / "data" / "reference_case" / "measurements.csv"
KAPPA, C_VOL, H = 1.31, 0.99e6, 10.0  # the reference case's truth (paper Case C)


def _read_case(drop: tuple[int, ...] = ()) -> Measurements:
    meas = read_csv_case(CASE, sigma=0.25)
    return meas.select_rows(np.setdiff1d(np.arange(meas.n_obs), drop)) if drop else meas


@pytest.fixture(scope="module")
def case() -> Measurements:
    return _read_case()


def _ref_solve(
    meas: Measurements, dx: float | None = None, dt: float | None = None, scheme: str = "cn", h: float = H
) -> tuple[Grid, np.ndarray]:
    kw = {k: v for k, v in (("dx", dx), ("dt", dt)) if v is not None}
    grid = Grid.build(meas, **kw)
    c = Coefficients.uniform(KAPPA, C_VOL, np.full(grid.n_obs - 1, h), meas.q_net, grid.n_nodes)
    return grid, solve(grid, Forcing.from_measurements(meas, grid), c, scheme=scheme)[0]


def _problem(L, n_cells, t_obs, dt, T_air, T_bottom, T0, kappa, C, h, q, beta=None):
    """A synthetic problem: grid, forcing and coefficients (scalars broadcast)."""
    grid = Grid.from_times(L, t_obs, dx=L / n_cells, dt=dt)
    n = grid.n_obs
    forcing = Forcing(
        T_air=np.broadcast_to(np.asarray(T_air, float), (n,)).copy(),
        T_bottom=np.broadcast_to(np.asarray(T_bottom, float), (n,)).copy(),
        T0=T0(grid.x) if callable(T0) else np.full(grid.n_nodes, float(T0)),
    )
    h = np.broadcast_to(np.asarray(h, float), (n - 1,)) if np.ndim(h) < 2 else h
    q = np.broadcast_to(np.asarray(q, float), (n,)) if np.ndim(q) < 2 else q
    return grid, forcing, Coefficients.uniform(kappa, C, h, q, grid.n_nodes, beta=beta)


# ---------------------------------------------------------------------------------------------
# 1. exact steady state: Robin top, Dirichlet bottom


@pytest.mark.parametrize("scheme", SCHEMES)
def test_steady_state_is_exact_linear_profile(scheme):
    L, Ta, Tb, h, q0 = 0.05, 25.0, 15.0, 12.0, 150.0
    t = np.arange(0.0, 3 * 86400.0 + 1, 3600.0)
    grid, forcing, coeffs = _problem(L, 10, t, 60.0, Ta, Tb, 20.0, [0.8, 2.0], [1.5e6, 1e6], h, q0)
    # two-layer ground in the second set: kappa 0.8 above 2 cm, 2.5 below (exact for FV)
    coeffs.kappa[1] = np.where(grid.x[:-1] < 0.02 - 1e-12, 0.8, 2.5)
    T = solve(grid, forcing, coeffs, scheme=scheme)[:, -1]
    for s in range(2):
        resist = np.concatenate([[0.0], np.cumsum(grid.dx / coeffs.kappa[s])])  # m2 K W-1
        Ts = (Tb + (h * Ta + q0) * resist[-1]) / (1.0 + h * resist[-1])
        flux = h * (Ta - Ts) + q0  # W m-2 into the ground, constant with depth
        exact = Ts - flux * resist
        np.testing.assert_allclose(T[s], exact, rtol=1e-6)


# ---------------------------------------------------------------------------------------------
# 2. analytical transients


def _periodic_exact(x, t, L, kappa, C, h, amp, omega):
    """Periodic steady state for T_air = amp cos(omega t), q = 0, T(L) = 0 (complex amplitude)."""
    m = np.sqrt(1j * omega * C / kappa)
    alpha = h * amp / (h + kappa * m / np.tanh(m * L))
    A = alpha * (np.cosh(m * x) - np.sinh(m * x) / np.tanh(m * L))
    return np.real(A[None, :] * np.exp(1j * omega * t)[:, None])


def test_insulated_top_fourier_modes_decay():
    """h = q = 0, T(L) = 0: cos((n+1/2) pi x / L) decays as exp(-kappa/C ((n+1/2) pi/L)^2 t)."""
    L, kappa, C = 0.05, 1.31, 0.99e6
    lam = (np.array([0.5, 1.5]) * np.pi / L) ** 2 * kappa / C  # 1/s

    def T0(x):
        return 10 * np.cos(0.5 * np.pi * x / L) + 4 * np.cos(1.5 * np.pi * x / L)

    t = np.arange(0.0, 4 * 3600.0 + 1, 900.0)
    grid, forcing, coeffs = _problem(L, 40, t, 5.0, 0.0, 0.0, T0, kappa, C, 0.0, 0.0)
    T = solve(grid, forcing, coeffs)[0]
    exact = 10 * np.exp(-lam[0] * t)[:, None] * np.cos(0.5 * np.pi * grid.x / L) + 4 * np.exp(-lam[1] * t)[
        :, None
    ] * np.cos(1.5 * np.pi * grid.x / L)
    err = np.abs(T - exact).max()
    assert err < 1e-3  # amplitudes 10, 4 degC; measured 5e-4; a full surface cell gives 0.14
    coeffs2 = Coefficients.uniform(2 * kappa, C, np.zeros(grid.n_obs - 1), np.zeros(grid.n_obs), grid.n_nodes)
    assert np.abs(solve(grid, forcing, coeffs2)[0] - exact).max() > 100 * err


@pytest.mark.parametrize("scheme, dt", [("cn", 30.0), ("dff", 2.0)])
def test_periodic_robin_forcing_matches_analytic(scheme, dt):
    """Daily air temperature wave through a Robin surface (h = 15) on a Dirichlet-0 bottom."""
    L, kappa, C, h, amp = 0.05, 1.31, 0.99e6, 15.0, 10.0
    omega = 2 * np.pi / 86400.0
    t = np.arange(0.0, 86400.0 + 1, 300.0)

    def T0(x):
        return _periodic_exact(x, np.zeros(1), L, kappa, C, h, amp, omega)[0]

    grid, forcing, coeffs = _problem(L, 40, t, dt, amp * np.cos(omega * t), 0.0, T0, kappa, C, h, 0.0)
    exact = _periodic_exact(grid.x, t, L, kappa, C, h, amp, omega)
    err = np.abs(solve(grid, forcing, coeffs, scheme=scheme)[0] - exact).max()
    assert err < 5e-4  # surface amplitude 3.6 degC; measured 1e-4; a full surface cell: 4e-3
    wrong = Coefficients.uniform(kappa, C, np.full(grid.n_obs - 1, 2 * h), np.zeros(grid.n_obs), grid.n_nodes)
    assert np.abs(solve(grid, forcing, wrong, scheme=scheme)[0] - exact).max() > 100 * err


# ---------------------------------------------------------------------------------------------
# 3. observed orders of convergence


def _smooth_problem(n_cells, dt):
    L = 0.05
    omega = 2 * np.pi / 86400.0
    t = np.arange(0.0, 43200.0 + 1, 3600.0)
    return _problem(
        L,
        n_cells,
        t,
        dt,
        20 + 8 * np.sin(omega * t),
        15.0,
        lambda x: 15.0 + 5.0 * np.cos(0.5 * np.pi * x / L),
        1.31,
        0.99e6,
        10.0,
        300.0 * np.sin(omega * t),
    )


def _order(sols, stride):
    """Observed order from three solutions refined by 2: log2(|u1-u2| / |u2-u4|)."""
    u1, u2, u4 = sols[0], sols[1][..., ::stride], sols[2][..., :: stride * stride]
    return np.log2(np.abs(u1 - u2).max() / np.abs(u2 - u4).max())


def test_cn_second_order_in_dt_and_dx():
    sols = [solve(*_smooth_problem(20, dt))[0] for dt in (600.0, 300.0, 150.0)]
    p_t = _order(sols, 1)
    sols = [solve(*_smooth_problem(n, 2.0))[0] for n in (5, 10, 20)]
    p_x = _order(sols, 2)
    assert 1.8 < p_t < 2.2, p_t
    assert 1.8 < p_x < 2.2, p_x


def test_dff_inconsistent_unless_dt_over_dx_vanishes():
    """Du Fort-Frankel: second order in dt at fixed dx, but refining dt and dx together at a
    fixed dt/dx does not converge (it approximates a different equation)."""
    sols = [solve(*_smooth_problem(20, dt), scheme="dff")[0] for dt in (10.0, 5.0, 2.5)]
    assert 1.8 < _order(sols, 1) < 2.2
    exact = solve(*_smooth_problem(80, 2.0))[0][:, ::8]
    errs = []
    for n in (10, 20, 40):  # dt / dx fixed at 30 s / 2.5 mm
        sol = solve(*_smooth_problem(n, 600.0 / n), scheme="dff")[0]
        errs.append(np.abs(sol[:, :: n // 10] - exact).max())
    assert errs[2] > 0.8 * errs[0]  # stalls (~0.01 degC) instead of falling 16x
    cn = solve(*_smooth_problem(40, 15.0))[0][:, ::4]
    assert np.abs(cn - exact).max() < errs[2] / 20  # CN on the same grid has converged


# ---------------------------------------------------------------------------------------------
# 4. the default grid on the reference case


def test_default_grid_converged_on_reference_case(case):
    _, T = _ref_solve(case)
    grid = Grid.build(case)
    _, T_fine = _ref_solve(case, dx=grid.dx / 4, dt=grid.step_dt.max() / 4)
    err = np.abs(T - T_fine[:, ::4]).max()
    assert err < case.sigma / 10, err


def test_dff_needs_tiny_steps(case):
    _, T_cn = _ref_solve(case)
    _, T_900 = _ref_solve(case, dt=900.0, scheme="dff")
    _, T_5 = _ref_solve(case, dt=5.0, scheme="dff")
    assert np.abs(T_900 - T_cn).max() > 1.0  # the paper's scheme at 15-min steps: badly wrong
    assert np.abs(T_5 - T_cn).max() < case.sigma / 10


# ---------------------------------------------------------------------------------------------
# 5. compiled kernels == plain NumPy


@pytest.mark.parametrize("n_sets", [1, 3, 7, 70])  # scalar, scalar, serial blocks, parallel
@pytest.mark.parametrize("with_beta", [False, True])
def test_kernels_match_numpy(case, n_sets, with_beta):
    rng = np.random.default_rng(42 + n_sets)
    grid = Grid.build(case)
    n_cells = grid.n_nodes - 1
    top = rng.uniform(0.6, 2.5, (n_sets, 1))
    bottom = rng.uniform(0.6, 2.5, (n_sets, 1))
    depth = rng.uniform(0.01, 0.04, (n_sets, 1))
    kappa = np.where(grid.x[None, :-1] < depth, top, bottom) * rng.uniform(0.9, 1.1, (1, n_cells))
    C = np.where(grid.x[None] < depth, 1.0e6, 2.0e6) * rng.uniform(0.8, 1.2, (n_sets, 1))
    h = np.clip(10 + np.cumsum(rng.normal(0, 2, (n_sets, grid.n_obs - 1)), 1), 0.5, 60)
    q = case.q_net[None] * rng.uniform(0.8, 1.2, (n_sets, 1))
    beta = rng.uniform(-4e-3, 4e-3, n_sets) if with_beta else None
    coeffs = Coefficients(kappa=kappa, C=C, h=h, q=q, beta=beta)
    forcing = Forcing.from_measurements(case, grid)
    T = solve(grid, forcing, coeffs)
    assert T.shape == (n_sets, grid.n_obs, grid.n_nodes)
    np.testing.assert_allclose(T, solve_numpy(grid, forcing, coeffs), rtol=0, atol=1e-10)
    if with_beta:  # beta changes the answer, beta = 0 reproduces the linear kernel
        coeffs.beta = np.zeros(n_sets)
        assert np.abs(solve(grid, forcing, coeffs) - T).max() > 1e-3


def test_dff_kernel_block_paths_agree(case):
    grid = Grid.build(case, dt=30.0)
    rng = np.random.default_rng(3)
    c = Coefficients.uniform(
        rng.uniform(1, 2, 70),
        rng.uniform(0.8e6, 2e6, 70),
        np.full(grid.n_obs - 1, 10.0),
        case.q_net,
        grid.n_nodes,
    )
    forcing = Forcing.from_measurements(case, grid)
    T70 = solve(grid, forcing, c, scheme="dff")
    sub = Coefficients(c.kappa[5:6], c.C[5:6], c.h[5:6], c.q[5:6])
    np.testing.assert_allclose(solve(grid, forcing, sub, scheme="dff")[0], T70[5], atol=1e-12)


# ---------------------------------------------------------------------------------------------
# 6. irregular observation times


def test_irregular_times_agree_with_regular(case):
    drop = (3, 10, 11, 12, 40, 77, 78)
    full = _read_case()
    irr = _read_case(drop)
    keep = np.setdiff1d(np.arange(full.n_obs), drop)
    # make the regular forcing the same piecewise-linear function of time as the irregular one
    interp = {k: np.interp(full.t, irr.t, getattr(irr, k)) for k in ("T_air", "q_net", "T_bottom")}
    reg = Measurements(**{**full.__dict__, **interp})
    grid_r, T_r = _ref_solve(reg)
    grid_i, T_i = _ref_solve(irr)
    assert set(np.unique(grid_i.substeps)) == {5, 10, 15, 20}
    assert np.abs(T_r[keep] - T_i).max() < case.sigma / 10
    # a non-multiple interval (1000 s then 800 s): different step lengths, refactorised
    t = case.t.copy()
    t[20] += 100.0
    odd = Measurements(**{**case.__dict__, "t": t})
    grid_o = Grid.build(odd)
    assert len(np.unique(np.round(grid_o.step_dt, 6))) == 3
    c = Coefficients.uniform(
        [1.0, 1.31, 2.0],
        C_VOL,
        np.full(grid_o.n_obs - 1, H),
        odd.q_net,
        grid_o.n_nodes,
        beta=[0.0, 2e-3, 0.0],
    )
    f = Forcing.from_measurements(odd, grid_o)
    np.testing.assert_allclose(solve(grid_o, f, c), solve_numpy(grid_o, f, c), atol=1e-10)
    c.beta = None
    np.testing.assert_allclose(solve(grid_o, f, c), solve_numpy(grid_o, f, c), atol=1e-10)


# ---------------------------------------------------------------------------------------------
# API and validation


def test_grid_build_and_forcing(case):
    grid = Grid.build(case, dx=0.005, dt=60.0)
    assert grid.n_nodes == 11 and grid.x[-1] == case.bottom_depth
    assert np.all(grid.substeps == 15) and np.allclose(grid.step_dt, 60.0)
    assert Grid.build(case, dx=0.0045).dx <= 0.0045
    f = Forcing.from_measurements(case, grid)
    np.testing.assert_allclose(f.T0[::2], np.append(case.T_obs[0], case.T_bottom[0]))
    T = _ref_solve(case)[1]
    np.testing.assert_allclose(T[0], Forcing.from_measurements(case, Grid.build(case)).T0)
    np.testing.assert_allclose(T[:, -1], case.T_bottom)


def test_invalid_input_raises(case):
    grid = Grid.build(case)
    forcing = Forcing.from_measurements(case, grid)
    c = Coefficients.uniform(KAPPA, C_VOL, np.full(grid.n_obs - 1, H), case.q_net, grid.n_nodes)
    with pytest.raises(ValueError, match="valid schemes: cn, dff"):
        solve(grid, forcing, c, scheme="euler")
    bad = Coefficients(c.kappa, c.C, c.h[:, :-1], c.q)
    with pytest.raises(ValueError, match=r"Coefficients.h has shape"):
        solve(grid, forcing, bad)
    with pytest.raises(ValueError, match="beta"):
        solve(grid, forcing, Coefficients(c.kappa, c.C, c.h, c.q, beta=np.zeros(3)))
    with pytest.raises(ValueError, match="positive"):
        solve(grid, forcing, Coefficients(-c.kappa, c.C, c.h, c.q))
    with pytest.raises(ValueError, match="T0"):
        solve(grid, Forcing(forcing.T_air, forcing.T_bottom, forcing.T0[:-1]), c)
    with pytest.raises(ValueError, match="strictly increasing"):
        Grid(L=0.05, x=grid.x, t_obs=np.array([0.0, 0.0, 1.0]), substeps=np.array([1, 1]))
    with pytest.raises(ValueError, match="inconsistent"):
        Coefficients.uniform([1.0, 2.0], [1e6, 1e6, 1e6], 10.0, 0.0, 5)
