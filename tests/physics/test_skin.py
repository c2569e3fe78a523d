"""The canopy skin of ``energy_balance`` + ``surface_layer`` (physics/skin.py): its steady state
against the closed-form solution of the skin balance, and the IR reading it gives."""

from __future__ import annotations

import numpy as np
import pytest

from pavement_mcmc.data import Measurements
from pavement_mcmc.physics import Model
from pavement_mcmc.physics.catalogue.surface import priestley_taylor_weight
from pavement_mcmc.physics.hbasis import HBasis
from pavement_mcmc.physics.skin import skin_temperature
from pavement_mcmc.solver import Grid

RN, TA, U, TB, L = 300.0, 15.0, 2.0, 8.0, 0.3
P = {"kappa": 1.1, "C": 2.4e6, "eb_h0": 4.0, "eb_h1": 3.0, "R_surface": 0.25}


def _steady_model() -> Model:
    """Ten days of constant forcing (R_n, T_air, wind) over a 30 cm column."""
    t = np.arange(0.0, 10 * 86400.0 + 1, 3600.0)
    n = t.size
    meas = Measurements(t=t, time0="2020-01-01T00:00:00Z", T_air=np.full(n, TA),
                        q_net=np.full(n, RN), wind=np.full(n, U), rain=None,
                        depths=np.array([0.05]), T_obs=np.full((n, 1), TB), bottom_depth=L,
                        T_bottom=np.full(n, TB), sigma=0.1)
    grid = Grid.build(meas, dx=0.005, dt=900.0)
    return Model(meas, grid, HBasis.from_config(t, {"kind": "per_interval"}),
                 ["energy_balance", "surface_layer"])


def test_skin_balance_steady_state_is_the_closed_form():
    r"""At steady state the model's skin T_k, soil top T_0 and flux G solve
    R_n - LE - h_H (T_k - T_a) = G = (T_k - T_0)/R = kappa (T_0 - T_b)/L (three linear
    equations, LE = alpha s/(s+gamma) R_n), and the flux split closes: R_n = H + LE + G."""
    model = _steady_model()
    n_days = len([q for q in model.parameter_space().names if q.startswith("eb_alpha_")])
    p = {k: np.array([v]) for k, v in P.items()} | {
        f"eb_alpha_{d + 1}": np.array([0.9]) for d in range(n_days)}
    coeffs = model.coefficients(p)
    T_nodes = model.solve(p)
    Tk = skin_temperature(model, T_nodes, coeffs, p)[0, -1]
    G = model.surface_flux(T_nodes, coeffs)[0, -1]
    LE = 0.9 * priestley_taylor_weight(np.array([TA]))[0] * RN
    h, R, k = P["eb_h0"] + P["eb_h1"] * U, P["R_surface"], P["kappa"]
    # unknowns (T_k, T_0, G)
    A = np.array([[h, 0.0, 1.0], [1.0, -1.0, -R], [0.0, k / L, -1.0]])
    b = np.array([RN - LE + h * TA, 0.0, k * TB / L])
    Tk_ref, T0_ref, G_ref = np.linalg.solve(A, b)
    assert T_nodes[0, -1, 0] == pytest.approx(T0_ref, abs=1e-3)
    assert G == pytest.approx(G_ref, rel=1e-3)
    assert Tk == pytest.approx(Tk_ref, abs=1e-3)
    assert Tk - T_nodes[0, -1, 0] > 5.0  # the layer matters: the skin is well above the soil
    H = h * (Tk - TA)
    assert H + LE + G == pytest.approx(RN, rel=1e-6)


def test_canopy_steady_state_is_the_closed_form():
    """``canopy`` (a storing skin node joined to the soil by R_canopy) at steady state: the skin
    is a node the model puts 1 mm above the case's grid and solves the same three equations over
    the whole soil column; the canopy's heat capacity drops out, and the 5 cm sensor is read 5 cm
    below the soil surface, not below the skin (0.03 degC apart here)."""
    model0 = _steady_model()
    meas = model0.meas
    grid = Grid.build(meas, dx=0.005, dt=900.0)
    model = Model(meas, grid, model0.h_basis, ["energy_balance", "canopy"])
    assert model.grid.soil_top == 0.001 and model.grid.L == pytest.approx(L + 0.001)
    assert np.allclose(model.grid.x[1:], grid.x + 0.001)
    names = model.parameter_space().names
    base = {"kappa": P["kappa"], "C": P["C"], "eb_h0": P["eb_h0"], "eb_h1": P["eb_h1"],
            "R_canopy": P["R_surface"], "c_canopy": 8e3}
    p = {k: np.array([v]) for k, v in base.items()} | {
        n: np.array([0.9]) for n in names if n.startswith("eb_alpha_")}
    T_nodes = model.solve(p)
    LE = 0.9 * priestley_taylor_weight(np.array([TA]))[0] * RN
    h, R, k = P["eb_h0"] + P["eb_h1"] * U, P["R_surface"], P["kappa"]
    A = np.array([[h, 0.0, 1.0], [1.0, -1.0, -R], [0.0, k / L, -1.0]])
    b = np.array([RN - LE + h * TA, 0.0, k * TB / L])
    Tk_ref, T0_ref, _ = np.linalg.solve(A, b)
    assert T_nodes[0, -1, 0] == pytest.approx(Tk_ref, abs=1e-3)
    assert T_nodes[0, -1, 1] == pytest.approx(T0_ref, abs=1e-3)
    sensor = T0_ref + (TB - T0_ref) * 0.05 / L
    assert abs((T0_ref - TB) * 0.001 / L) > 0.02  # what reading 1 mm off would miss
    assert model.predict(p)[0, -1, 0] == pytest.approx(sensor, abs=2e-3)


def test_the_canopy_s_heat_is_on_the_skin_and_the_soil_s_in_the_soil():
    """The skin node stores c_canopy per m2 and the soil top only its soil half-cell: the 1 mm
    skin cell's lower half is not soil (it stored C x 0.5 mm, 1.2 kJ m-2 K-1 at C 2.4 MJ, a
    quarter of a thin thatch's 4.5 kJ)."""
    model0 = _steady_model()
    model = Model(model0.meas, model0.grid, model0.h_basis, ["energy_balance", "canopy"])
    p = {"kappa": np.array([1.1]), "C": np.array([2.4e6]), "R_canopy": np.array([0.25]),
         "c_canopy": np.array([4.5e3]), "eb_h0": np.array([4.0]), "eb_h1": np.array([3.0])}
    p |= {n: np.array([0.9]) for n in model.parameter_space().names if n.startswith("eb_alpha_")}
    coeffs = model.coefficients(p)
    vol = model.grid.volumes
    assert coeffs.C[0, 0] * vol[0] == pytest.approx(4.5e3)
    assert coeffs.C[0, 1] * vol[1] == pytest.approx(2.4e6 * model0.grid.dx_cells[0] / 2)
    assert coeffs.C[0, 2] == 2.4e6


def test_a_skin_grid_needs_its_skin_and_a_surface_top():
    """A grid with a skin node is refused for a model without one, a measured top refuses the
    canopy, and a skin grid is not refined (its lumped node is not a cell to split)."""
    model0 = _steady_model()
    meas, grid = model0.meas, model0.grid
    with pytest.raises(ValueError, match="no extension puts one"):
        Model(meas, grid.with_skin(0.001), model0.h_basis, ["energy_balance"])
    with pytest.raises(ValueError, match="measured top"):
        top = meas.with_measured_top()
        Model(top, Grid.build(top, dx=0.005, dt=900.0), model0.h_basis, ["canopy"])
    with pytest.raises(ValueError, match="refine the soil"):
        grid.with_skin(0.001).refined(2)


def test_canopy_stores_heat_energy_is_conserved():
    """Over a day of a stepped net radiation the energy that entered the surface (R_n - H - LE,
    the model's surface flux) equals the heat stored in the canopy node and the soil plus what
    left at the bottom, to the time discretisation's accuracy; a heavier canopy stores more."""
    model0 = _steady_model()
    meas = model0.meas
    t = meas.t[:25]
    q = np.where((t > 6 * 3600) & (t < 18 * 3600), 400.0, -60.0)
    from dataclasses import replace
    meas = replace(meas.select_rows(np.arange(25)), q_net=q)
    grid = Grid.stretched(L, t, dx_top=0.001, growth=1.08, dt=300.0, nodes_at=[0.05])
    stored = []
    for c in (2e3, 2e4):
        model = Model(meas, grid, HBasis.from_config(t, {"kind": "per_interval"}),
                      ["energy_balance", "canopy"])
        p = {"kappa": np.array([1.1]), "C": np.array([2.4e6]), "eb_h0": np.array([4.0]),
             "eb_h1": np.array([3.0]), "eb_alpha_1": np.array([0.8]),
             "R_canopy": np.array([0.25]), "c_canopy": np.array([c])}
        coeffs = model.coefficients(p)
        T = model.solve(p)[0]
        x = model.grid.x
        dx = np.diff(x)
        vol = np.r_[dx[0] / 2, 0.5 * (dx[1:] + dx[:-1]), dx[-1] / 2]  # nodal control volumes
        heat = (coeffs.C[0] * vol * (T[-1] - T[0]))[:-1].sum()  # the bottom node is fixed
        G = model.surface_flux(T[None], coeffs)[0]
        k_last = coeffs.kappa[0, -1]
        bottom = k_last * (T[:, -2] - T[:, -1]) / dx[-1]
        dts = np.diff(t)
        inflow = np.sum(0.5 * (G[1:] + G[:-1]) * dts) - np.sum(0.5 * (bottom[1:] + bottom[:-1]) * dts)
        assert heat == pytest.approx(inflow, rel=0.02)
        stored.append(coeffs.C[0, 0] * vol[0] * (T[:, 0].max() - T[:, 0].min()))
    assert stored[1] > 3 * stored[0]


def test_a_skin_without_its_adjoint_turns_the_gradient_to_finite_differences():
    """An extension that places the skin but gives no ``skin_vjp`` leaves the model without an
    adjoint (the IR stream's gradient would be wrong), and the shipped surface_layer keeps it."""
    from pavement_mcmc.physics.base import Extension

    class Plain(Extension):
        name = "plain_skin"

        def skin(self, T, G, p, model):
            return T + 0.1 * G

    model = _steady_model()
    assert model.has_gradient
    assert not Model(model.meas, model.grid, model.h_basis, ["energy_balance", Plain()]).has_gradient
