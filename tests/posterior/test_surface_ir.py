"""The infrared surface temperature as an observation stream (posterior/surface_ir.py), on a twin
whose IR reading is the independent simulator's own surface temperature plus a known offset."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem, find_map
from pavement_mcmc.synthetic import SyntheticSpec, simulate
from pavement_mcmc.synthetic.io import write_case

OFFSET, IR_SD = 1.5, 0.2


def _twin(tmp_path: Path, plates: tuple = (), model: str = 'h = { kind = "uniform", n = 4 }\n',
          **spec_kw) -> Path:
    """A 12-h twin (no hidden effect) and its extras.csv: T_surf_IR = the simulated surface
    temperature (the top node of the simulator's fine column) + OFFSET + N(0, IR_SD)."""
    spec = SyntheticSpec(hours=12, step_minutes=15, seed=3, flux_depths_cm=plates, **spec_kw)
    write_case(spec, tmp_path)
    cols, truth = simulate(spec)  # deterministic in the seed: the same record again
    rng = np.random.default_rng(7)
    ir = truth.profiles[:, 0] + OFFSET + IR_SD * rng.standard_normal(truth.t.size)
    (tmp_path / "extras.csv").write_text(
        "time,T_surf_IR\n" + "".join(f"{s},{v:.3f}\n" for s, v in zip(cols["time"], ir, strict=True)))
    toml = tmp_path / "case.toml"
    toml.write_text(f'[data]\ncsv = "measurements.csv"\nsigma = {spec.sigma}\n'
                    f'extras = "extras.csv"\nir_sigma = {IR_SD}\n'
                    f'[model]\n{model}'
                    '[parameters.kappa]\nprior = { dist = "flat" }\n'
                    '[parameters.C]\nprior = { dist = "flat" }\n')
    return toml


def _central(post, theta, eps=1e-6):
    g = np.zeros_like(theta)
    for j in range(theta.shape[1]):
        e = np.zeros(theta.shape[1])
        e[j] = eps * max(abs(theta[0, j]), 1e-3)
        g[:, j] = (post.loglik_blobs(theta + e)[0] - post.loglik_blobs(theta - e)[0]) / (2 * e[j])
    return g


def test_ir_gradient_against_finite_differences(tmp_path):
    """The adjoint gradient with temperatures, a plate and the IR stream (its offset and its
    pull on the top node) equals central differences of whole solves."""
    pb = build_problem(load_case(_twin(tmp_path, plates=(3.0,))))
    post = pb.posterior
    assert [s.name for s in post.streams] == ["temperatures", "plates", "surface_ir"]
    rng = np.random.default_rng(1)
    th = np.repeat(pb.space.initial()[None], 2, 0) * (1 + 0.02 * rng.standard_normal((2, len(pb.space.free))))
    th[:, pb.space.free.index("ir_offset")] = [0.7, 2.1]
    ll, g, blobs = post.loglik_and_grad(th, "adjoint")
    ref = _central(post, th)
    np.testing.assert_allclose(ll, post.loglik_blobs(th)[0], rtol=1e-12)
    np.testing.assert_allclose(g, ref, rtol=0, atol=1e-6 * np.abs(ref).max())
    j = pb.space.free.index("ir_offset")  # the offset's own term: sum(T_IR - pred) / sd^2
    assert abs(g[0, j]) > 1.0 and abs(g[0, j] - ref[0, j]) < 1e-5 * abs(ref[0, j])
    np.testing.assert_allclose(blobs, post(th)[1], rtol=1e-12)


@pytest.mark.parametrize("model", [
    'h = { kind = "uniform", n = 4 }\nextensions = ["surface_layer"]\n',
    'extensions = ["energy_balance", "surface_layer"]\n[parameters.ir_view]\nvary = true\n'])
def test_ir_gradient_through_the_canopy_skin(tmp_path, model):
    """Above a surface layer the IR reads the skin T_0 + R G (physics/skin.py), seen over a
    footprint fraction ir_view: its adjoint, through R, the surface coefficients (free h or the
    energy balance's laws), ir_view and the top node, equals central differences of whole
    solves."""
    pb = build_problem(load_case(_twin(tmp_path, plates=(3.0,), model=model)))
    post = pb.posterior
    rng = np.random.default_rng(2)
    th = np.repeat(pb.space.initial()[None], 2, 0) * (1 + 0.02 * rng.standard_normal((2, len(pb.space.free))))
    th[:, pb.space.free.index("R_surface")] = [0.1, 0.4]
    ll, g, _ = post.loglik_and_grad(th, "adjoint")
    ref = _central(post, th)
    np.testing.assert_allclose(g, ref, rtol=0, atol=1e-6 * np.abs(ref).max())
    j = pb.space.free.index("R_surface")
    np.testing.assert_allclose(g[:, j], ref[:, j], rtol=1e-5)


@pytest.mark.parametrize("layer", ["canopy", "surface_layer"])
def test_ir_gradient_with_the_soil_seen_between_the_leaves(tmp_path, layer):
    """Under a layer the footprint's part outside the skin reads the soil surface below it
    (node 1 under canopy's skin node, the top node under surface_layer): the adjoint through
    that node and ir_view equals central differences of whole solves, and the view is the
    skin's share between the soil and the skin."""
    model = (f'extensions = ["energy_balance", "{layer}"]\n'
             '[parameters.ir_view]\nvary = true\nvalue = 0.7\n')
    pb = build_problem(load_case(_twin(tmp_path, model=model)))
    post = pb.posterior
    rng = np.random.default_rng(4)
    th = np.repeat(pb.space.initial()[None], 2, 0) * (1 + 0.02 * rng.standard_normal((2, len(pb.space.free))))
    if layer == "surface_layer":  # its start is the null, no layer: give it one
        th[:, pb.space.free.index("R_surface")] = [0.1, 0.4]
    ll, g, _ = post.loglik_and_grad(th, "adjoint")
    ref = _central(post, th)
    np.testing.assert_allclose(g, ref, rtol=0, atol=1e-6 * np.abs(ref).max())
    j = pb.space.free.index("ir_view")
    assert abs(ref[0, j]) > 1.0
    np.testing.assert_allclose(g[:, j], ref[:, j], rtol=1e-5)
    p = pb.space.expand(th[:1])
    model_ = pb.model
    coeffs = model_.coefficients(p)
    from pavement_mcmc.physics.skin import skin_temperature
    from pavement_mcmc.solver import solve
    T_nodes = solve(model_.grid, model_.forcing, coeffs, scheme=model_.scheme)
    ir = post.stream("surface_ir").predict(model_, T_nodes, coeffs, p)[0, :, 0] - p["ir_offset"][0]
    skin, soil = skin_temperature(model_, T_nodes, coeffs, p)[0], T_nodes[0, :, 1 if layer == "canopy" else 0]
    f = p["ir_view"][0]
    np.testing.assert_allclose(ir, f * skin + (1 - f) * soil, rtol=1e-12)
    assert np.max(np.abs(skin - soil)) > 0.5  # the layer separates them: the test can fail


@pytest.mark.parametrize("model", [
    'extensions = ["energy_balance", "canopy"]\n[parameters.ir_view]\nvary = true\nvalue = 0.7\n',
    'h = { kind = "uniform", n = 4 }\n'])
def test_ir_gradient_with_a_lead(tmp_path, model):
    """The surface the IR sees leads the skin by ir_lead minutes (T + tau dT/dt at the rows):
    its adjoint, through the skin (a canopy node, or the top node) and the lead itself, equals
    central differences of whole solves, and the reading is the skin plus tau times its
    backward difference."""
    pb = build_problem(load_case(_twin(tmp_path, model=model + '[parameters.ir_lead]\nvary = true\n')))
    post = pb.posterior
    rng = np.random.default_rng(5)
    th = np.repeat(pb.space.initial()[None], 2, 0) * (1 + 0.02 * rng.standard_normal((2, len(pb.space.free))))
    j = pb.space.free.index("ir_lead")
    th[:, j] = [12.0, 40.0]
    ll, g, _ = post.loglik_and_grad(th, "adjoint")
    ref = _central(post, th)
    np.testing.assert_allclose(g, ref, rtol=0, atol=1e-6 * np.abs(ref).max())
    assert abs(ref[0, j]) > 1e-3
    np.testing.assert_allclose(g[:, j], ref[:, j], rtol=1e-5)
    p = pb.space.expand(th[:1])
    m = pb.model
    coeffs = m.coefficients(p)
    T_nodes = m.solve(p)
    from pavement_mcmc.physics.skin import skin_temperature

    skin = skin_temperature(m, T_nodes, coeffs, p)[0]
    ir = post.stream("surface_ir")
    p0 = dict(p, ir_lead=np.zeros(1))
    led = ir.predict(m, T_nodes, coeffs, p)[0, :, 0] - ir.predict(m, T_nodes, coeffs, p0)[0, :, 0]
    want = p["ir_view"][0] * 60.0 * p["ir_lead"][0] * np.diff(skin) / np.diff(m.meas.t)
    np.testing.assert_allclose(led[1:], want, rtol=1e-9, atol=1e-12)
    assert led[0] == 0.0 and np.max(np.abs(want)) > 0.1  # the skin moves: the test can fail


def test_the_ir_parameters_can_be_set_in_a_case_whose_grid_is_chosen(tmp_path):
    """A bottom deeper than 10 cm makes the auto grid compare predictions at the case's values,
    which configured the model's parameters without the stream's: ``[parameters.ir_view]``, as
    the stream's docstring says to set it, was refused as unknown."""
    toml = _twin(tmp_path, depths_cm=(0.0, 2.0, 5.0, 10.0), bottom_cm=20.0,
                 model='h = { kind = "uniform", n = 4 }\n[parameters.ir_view]\nvary = true\n'
                       '[parameters.ir_offset]\nvalue = 1.0\n')
    pb = build_problem(load_case(toml))
    assert pb.grid_chosen["kind"] == "stretched" and "ir_view" in pb.space.free
    assert pb.space["ir_offset"].value == 1.0
    from pavement_mcmc.posterior.surface_ir import PARAMETER_NAMES  # what the criticism drops

    assert {p.name for p in pb.posterior.stream("surface_ir").parameters()} == set(PARAMETER_NAMES)


def test_fit_recovers_the_ir_offset(tmp_path):
    """The MAP of the twin with the IR stream finds the offset the reading was made with, and
    its IR misfit is the reading's noise."""
    pb = build_problem(load_case(_twin(tmp_path)))
    lap = find_map(pb.posterior)
    values = dict(zip(pb.space.free, lap.theta, strict=True))
    assert values["ir_offset"] == pytest.approx(OFFSET, abs=0.15)
    rmse_ir = pb.posterior.loglik_blobs(lap.theta[None])[1][0, -1]
    assert rmse_ir < 1.5 * IR_SD
    # without the offset (fixed at 0) the IR stream is fitted much worse
    fixed = build_problem(load_case(_twin(tmp_path),
                                    {"parameters": {"ir_offset": {"vary": False, "value": 0.0}}}))
    lap0 = find_map(fixed.posterior)
    assert fixed.posterior.loglik_blobs(lap0.theta[None])[1][0, -1] > 3 * rmse_ir


def test_the_forecasts_training_refit_keeps_the_ir_stream(tmp_path):
    """The forecast refits the start of the window with the run's own likelihood: the IR stream
    (restricted to the training rows) and its ir_offset stay in it, and its MAP finds the offset."""
    from pavement_mcmc.criticism.forecast import training_problem

    pb = build_problem(load_case(_twin(tmp_path)))
    n_train = 36  # 9 of the 12 h
    tr = training_problem(pb, n_train)
    ir = tr.posterior.stream("surface_ir")
    assert ir is not None and "ir_offset" in tr.space.free
    assert ir.data.shape[0] == n_train
    lap = find_map(tr.posterior)
    assert dict(zip(tr.space.free, lap.theta, strict=True))["ir_offset"] == pytest.approx(OFFSET, abs=0.2)
    # the reading's form goes with it: a storage-free reading stays storage-free (it was
    # rebuilt without it, so rolling forecasts of runs/grass_energy.toml read the node itself)
    model = 'extensions = ["energy_balance", "canopy"]\n'
    toml = _twin(tmp_path / "sf", model=model)
    toml.write_text(toml.read_text().replace("ir_sigma = ", "ir_storage_free = true\nir_sigma = "))
    pb = build_problem(load_case(toml))
    assert pb.posterior.stream("surface_ir").storage_free
    assert training_problem(pb, n_train).posterior.stream("surface_ir").storage_free


def test_a_view_into_the_sward_is_weighed_and_ignoring_it_inflates_the_soil(tmp_path):
    """Grass-like twins from the independent simulator (a resolved thatch, not the inversion's
    lumped node; synthetic/ir_view.py). A thermometer that looks down into the thatch (60 % of
    its view stopped in it, Beer's law, radiances averaged): with ``ir_view`` free the MAP finds
    the soil, held at 1 (the reading all skin) kappa and C come out about twice the truth. One
    over tiles (60 % thatch, 40 % a bare sunlit patch, which the form does not describe): the
    free weight stays near 1 and the soil is found either way."""
    from pavement_mcmc.criticism import refit
    from pavement_mcmc.synthetic.ir_view import HELD, ir_view_case, tiled_case

    toml, spec = ir_view_case(tmp_path / "into", 0.6, 1)
    v = refit(build_problem(load_case(toml))).values()
    assert 0.2 < v["ir_view"] < 0.6  # a weight, not the share stopped in the layer
    assert v["kappa"] == pytest.approx(spec.kappa, rel=0.25)
    assert v["C"] == pytest.approx(spec.C, rel=0.25)
    held = refit(build_problem(load_case(toml, HELD))).values()
    assert held["kappa"] > 1.6 * spec.kappa and held["C"] > 1.6 * spec.C
    toml, spec = tiled_case(tmp_path / "tiles", 0.6, 1)
    v = refit(build_problem(load_case(toml))).values()
    assert v["ir_view"] > 0.85
    assert v["kappa"] == pytest.approx(spec.kappa, rel=0.25)
    assert v["C"] == pytest.approx(spec.C, rel=0.25)


def test_a_lead_is_found_where_the_radiometer_sees_the_top_of_a_heat_storing_thatch(tmp_path):
    """Twins from the independent simulator (a resolved thatch, not the inversion's lumped
    node; synthetic/ir_view.py). A thatch that stores 30 kJ m-2 K-1, read at its top: the top
    leads the bulk the inversion lumps into its canopy node, and the MAP finds a lead of about
    25 min, fits the IR better, recovers the layer's heat capacity (held at 0 it finds a third
    of it) and the soil better. A thin thatch that stores little, seen into: no lead is found
    (no false lead), and the soil is found as without one."""
    from pavement_mcmc.criticism import refit
    from pavement_mcmc.synthetic.ir_view import STORING_C, ir_view_case, storing_thatch_case

    toml, spec = storing_thatch_case(tmp_path / "storing", 1)
    stored = STORING_C * spec.effects["surface_layer"].get("layer_thickness", 0.015)

    def fit(toml, overrides=None):
        pb = build_problem(load_case(toml, overrides))
        f = refit(pb)
        ir = dict(zip(pb.posterior.blob_names, pb.posterior.loglik_blobs(f.theta[None])[1][0]))
        return f.values(), ir["rmse_IR"]

    v, ir = fit(toml)
    v0, ir0 = fit(toml, {"parameters": {"ir_lead": {"vary": False, "value": 0.0}}})
    assert 10.0 < v["ir_lead"] < 45.0
    assert ir < 0.8 * ir0
    assert v["c_canopy"] == pytest.approx(stored, rel=0.35) and v0["c_canopy"] < 0.5 * stored
    assert abs(v["kappa"] / spec.kappa - 1) < abs(v0["kappa"] / spec.kappa - 1)
    toml, spec = ir_view_case(tmp_path / "thin", 0.6, 1)
    v, _ = fit(toml, {"parameters": {"ir_lead": {"vary": True}}})
    assert v["ir_lead"] < 8.0
    assert v["kappa"] == pytest.approx(spec.kappa, rel=0.25)
    assert v["C"] == pytest.approx(spec.C, rel=0.25)


def test_a_storage_free_reading_finds_a_heat_storing_thatch_and_no_lead_under_a_thin_one(tmp_path):
    """The same twins read with ``[data] ir_storage_free`` (the lead is the node's relaxation
    time, no parameter; the weight free): over the storing thatch the IR fits better than the
    node read directly and the thatch's heat capacity is found; over the thin thatch the node's
    relaxation time stays short and the soil is found as without it."""
    from pavement_mcmc.criticism import refit
    from pavement_mcmc.synthetic.ir_view import STORING_C, ir_view_case, storing_thatch_case

    def fit(toml, storage_free):
        if storage_free:
            toml.write_text(toml.read_text().replace("ir_sigma = ", "ir_storage_free = true\nir_sigma = "))
        pb = build_problem(load_case(toml))
        f = refit(pb)
        ir = dict(zip(pb.posterior.blob_names, pb.posterior.loglik_blobs(f.theta[None])[1][0]))
        v = f.values()
        tau = v["c_canopy"] / (v["eb_h0"] + 1.0 / v["R_canopy"]) / 60.0  # min, at no wind
        return v, ir["rmse_IR"], tau

    toml, spec = storing_thatch_case(tmp_path / "storing", 1, free=("ir_view",))
    v, ir, tau = fit(toml, True)
    toml0, _ = storing_thatch_case(tmp_path / "direct", 1, free=("ir_view",))
    v0, ir0, _ = fit(toml0, False)
    assert ir < 0.85 * ir0 and tau > 15.0
    assert v["c_canopy"] == pytest.approx(STORING_C * 0.015, rel=0.35)
    assert abs(v["kappa"] / spec.kappa - 1) < 0.3
    toml, spec = ir_view_case(tmp_path / "thin", 0.6, 1)
    v, _, tau = fit(toml, True)
    assert tau < 8.0
    assert v["kappa"] == pytest.approx(spec.kappa, rel=0.25)
    assert v["C"] == pytest.approx(spec.C, rel=0.25)


def test_a_storage_free_reading_leads_the_canopy_node_by_its_relaxation_time(tmp_path):
    """``[data] ir_storage_free``: the IR reads T + tau dT/dt with tau = c_canopy / (h + 1/R)
    over each interval, no lead parameter; its adjoint through c_canopy, R_canopy and the
    energy balance's h law equals central differences of whole solves. Without a canopy or
    without the IR the case is refused."""
    model = ('extensions = ["energy_balance", "canopy"]\n[parameters.ir_view]\nvary = true\n'
             'value = 0.7\n')
    toml = _twin(tmp_path, model=model)
    toml.write_text(toml.read_text().replace("ir_sigma = ", "ir_storage_free = true\nir_sigma = "))
    pb = build_problem(load_case(toml))
    post = pb.posterior
    assert "ir_lead" not in pb.space.names
    rng = np.random.default_rng(6)
    th = np.repeat(pb.space.initial()[None], 2, 0) * (1 + 0.02 * rng.standard_normal((2, len(pb.space.free))))
    ll, g, _ = post.loglik_and_grad(th, "adjoint")
    ref = _central(post, th)
    np.testing.assert_allclose(g, ref, rtol=0, atol=1e-6 * np.abs(ref).max())
    for name in ("c_canopy", "R_canopy", "eb_h0", "eb_h1"):
        j = pb.space.free.index(name)
        np.testing.assert_allclose(g[:, j], ref[:, j], rtol=1e-4, atol=1e-9 * np.abs(ref).max())
    p = pb.space.expand(th[:1])
    m = pb.model
    coeffs = m.coefficients(p)
    T_nodes = m.solve(p)
    from pavement_mcmc.physics.skin import skin_temperature

    skin = skin_temperature(m, T_nodes, coeffs, p)[0]
    tau = p["c_canopy"][0] / (coeffs.h[0] + 1.0 / p["R_canopy"][0])
    ir = post.stream("surface_ir")
    f, Tb = p["ir_view"][0], T_nodes[0, :, 1]
    want = Tb[1:] + f * (skin[1:] + tau * np.diff(skin) / np.diff(m.meas.t) - Tb[1:]) + p["ir_offset"][0]
    np.testing.assert_allclose(ir.predict(m, T_nodes, coeffs, p)[0, 1:, 0], want, rtol=1e-10)
    assert np.max(np.abs(tau * np.diff(skin) / np.diff(m.meas.t))) > 0.1  # the lead matters
    for bad in ('h = { kind = "uniform", n = 4 }\n', 'extensions = ["energy_balance", "surface_layer"]\n'):
        t2 = _twin(tmp_path / "bad", model=bad)
        t2.write_text(t2.read_text().replace("ir_sigma = ", "ir_storage_free = true\nir_sigma = "))
        with pytest.raises(ValueError, match="ir_storage_free needs"):
            build_problem(load_case(t2))
