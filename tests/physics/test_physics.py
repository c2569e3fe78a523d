"""The forward model and its extensions: checked against the independent simulator and against
exact identities of each extension (no answer here comes from the code under test alone)."""

import warnings

import numpy as np
import pytest

from pavement_mcmc.data import load_case
from pavement_mcmc.physics import Extension, HBasis, Model, extension_names, get_extension
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.solver import Grid
from pavement_mcmc.synthetic import SyntheticSpec, simulate, to_measurements

RUNS = __import__("pathlib").Path(__file__).parents[2] / "runs"


@pytest.fixture(scope="module")
def twin():
    """Noise-free twin data from the independent simulator with linear-in-time forcing."""
    spec = SyntheticSpec(sigma=0.0, forcing="linear", emission=False, forcing_noise=False, seed=5)
    cols, truth = simulate(spec)
    meas = to_measurements(cols, sigma=0.2)
    return meas, truth


def _true_point(model, truth, **extra):
    h_int = 0.5 * (truth.h_obs[:-1] + truth.h_obs[1:])
    p = {"kappa": np.array([truth.kappa]), "C": np.array([truth.C])}
    p |= {n: np.array([h_int[i]]) for i, n in enumerate(model.h_basis.names)}
    p |= {k: np.atleast_1d(np.asarray(v, float)) for k, v in extra.items()}
    return p


def test_model_agrees_with_independent_simulator_within_sigma_over_10(twin):
    meas, truth = twin
    model = Model(meas, Grid.build(meas), HBasis.per_interval(meas.t))
    pred = model.predict(_true_point(model, truth))[0]
    err = pred - meas.T_obs
    assert np.sqrt(np.mean(err**2)) < 0.025  # sigma/10 for the paper's sigma
    # a 10 % error in kappa is far outside that: the comparison has teeth
    p = _true_point(model, truth)
    p["kappa"] = p["kappa"] * 1.1
    assert np.sqrt(np.mean((model.predict(p)[0] - meas.T_obs) ** 2)) > 0.05


def test_reference_case_at_truth_is_at_the_noise_level():
    cfg = load_case(RUNS / "caseC.toml")
    prob = build_problem(cfg)
    truth = cfg.truth
    h = np.asarray(truth["h_true_obs"])
    p = {"kappa": [truth["kappa"]], "C": [truth["C"]], "gamma": [2.0]}
    p |= {n: [0.5 * (h[i] + h[i + 1])] for i, n in enumerate(prob.model.h_basis.names)}
    theta = np.array([[np.asarray(p[n])[0] for n in prob.space.free]])
    logp, rmse = prob.posterior(theta)
    assert np.isfinite(logp[0])
    # misfit floor: noisy boundary and initial profile put it at ~1.1-1.2 sigma overall
    overall = np.sqrt(np.mean(rmse[0] ** 2))
    assert 1.0 * 0.25 < overall < 1.25 * 0.25 and np.all(rmse[0] < 1.5 * 0.25)


def test_posterior_is_minus_inf_without_warnings_or_nan():
    prob = build_problem(load_case(RUNS / "caseA.toml"))
    th = np.tile(prob.space.initial(), (3, 1))
    th[1, prob.space.free.index("kappa")] = -1.0
    th[2, prob.space.free.index("h_2")] = -5.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        logp, blobs = prob.posterior(th)
    assert np.isfinite(logp[0]) and np.all(np.isneginf(logp[1:]))
    assert not np.isnan(blobs).any() and np.all(np.isinf(blobs[1:]))


def test_h_pieces_cover_intervals_with_overlap_weights():
    t = np.arange(0, 28 * 3600 + 1, 900.0)
    b = HBasis.pieces(t, [0, 6, 18, 28])
    assert b.W.shape == (112, 3) and np.allclose(b.W.sum(axis=1), 1.0)
    # an edge at 6.1 h splits the 6.0-6.25 h interval 40/60
    b2 = HBasis.pieces(t, [0, 6.1, 28])
    assert np.allclose(b2.W[24], [0.4, 0.6])
    with pytest.raises(ValueError, match="do not cover"):
        HBasis.pieces(t, [0, 6, 18])


@pytest.fixture(scope="module")
def ref():
    cfg = load_case(RUNS / "caseA.toml")
    return cfg.measurements


def _model(meas, exts=()):
    return Model(meas, Grid.build(meas), HBasis.pieces(meas.t, [0, 6, 18, 28]), exts)


def _base_point(model, n=1):
    sp = model.parameter_space()
    return sp.expand(np.tile(sp.initial(), (n, 1)))


def test_two_layer_reduces_to_homogeneous(ref):
    base = _model(ref)
    two = _model(ref, ["two_layer"])
    p = _base_point(two, 2)
    p["kappa2"] = p["kappa"].copy()
    p["C2"] = p["C"].copy()
    p["d_layer"] = np.array([0.01, 0.037])
    assert np.allclose(two.predict(p), base.predict(_base_point(base, 2)), atol=1e-10)
    # a less conductive lower layer changes every sensor by a detectable amount
    p["kappa2"] = p["kappa"] * 0.5
    diff = np.abs(two.predict(p) - base.predict(_base_point(base, 2)))[0].mean(axis=0)
    assert np.all(diff > 0.1)


def test_sensor_extensions_exact_identities(ref):
    base = _model(ref)
    ext = _model(ref, ["sensor_depth", "sensor_bias"])
    p = _base_point(ext)
    ref_pred = base.predict(_base_point(base))
    assert np.allclose(ext.predict(p), ref_pred, atol=1e-12)
    p["bias_2cm"] = np.array([0.7])
    p["dz_1cm"] = np.array([0.01])  # the 1 cm sensor really at 2 cm
    pred = ext.predict(p)
    assert np.allclose(pred[..., 2], ref_pred[..., 2] + 0.7)
    assert np.allclose(pred[..., 1], ref_pred[..., 2], atol=1e-12)


def test_surface_extensions_null_values_change_nothing(ref):
    base = _model(ref)
    ext = _model(ref, ["radiation_factor", "evaporation", "conductivity_temperature"])
    p = _base_point(ext)
    for e in ext.extensions:
        for k, v in (e.null_values(ref) or {}).items():
            p[k] = np.array([v])
    assert np.allclose(ext.predict(p), base.predict(_base_point(base)), atol=1e-10)
    p["rad_factor"] = np.array([1.2])
    assert np.abs(ext.predict(p) - base.predict(_base_point(base)))[..., 0].max() > 0.3


def test_wind_convection_replaces_h(ref):
    m = _model(ref, ["wind_convection"])
    names = m.parameter_space().names
    assert "h_a" in names and not any(n.startswith("h_") and n[2:].isdigit() for n in names)
    p = _base_point(m)
    p["h_a"], p["h_b"] = np.array([10.0]), np.array([0.0])
    base = _model(ref)
    pb = _base_point(base)  # every h piece at 10
    assert np.allclose(m.predict(p), base.predict(pb), atol=1e-10)


def test_registry_errors_and_clashes(ref):
    with pytest.raises(ValueError, match="valid: .*two_layer"):
        get_extension("two_layers")
    assert "sensor_bias" in extension_names()

    class Clash(Extension):
        name = "clash"

        def parameters(self, meas):
            from pavement_mcmc.parameters import Parameter

            return [Parameter("kappa2", 1.0)]

    with pytest.raises(ValueError, match="clash.*kappa2"):
        _model(ref, ["two_layer", Clash()]).parameter_space()


def test_parameter_columns_are_a_block_of_the_matrix_unless_replaced():
    """``columns`` (h(t)'s pieces as one block, no per-name stacking) gives exactly the stacked
    values, and falls back to stacking when a value was replaced after ``expand`` (the finite
    differences of an extension's coefficients do that) or a name is fixed."""
    from pavement_mcmc.parameters import Parameter
    from pavement_mcmc.parameters.space import ParameterSpace, columns

    space = ParameterSpace([Parameter(n, 1.0, 0.0, 10.0) for n in ("a", "h_1", "h_2", "h_3")]
                           + [Parameter("h_4", 2.0, 0.0, 10.0, vary=False)])
    theta = np.arange(12.0).reshape(3, 4)
    p = space.expand(theta)
    names = ("h_1", "h_2", "h_3")
    block = columns(p, names)
    np.testing.assert_array_equal(block, theta[:, 1:])
    assert np.shares_memory(block, theta)  # a slice, not a copy
    np.testing.assert_array_equal(columns(p, ("h_3", "a")), theta[:, [3, 0]])
    q = {**p, "h_2": p["h_2"] + 1.0}  # a plain dict: stacked
    np.testing.assert_array_equal(columns(q, names)[:, 1], theta[:, 2] + 1.0)
    p["h_2"] = p["h_2"] + 1.0  # replaced in place: no longer the matrix's column
    np.testing.assert_array_equal(columns(p, names)[:, 1], theta[:, 2] + 1.0)
    np.testing.assert_array_equal(columns(p, ("h_3", "h_4"))[:, 1], 2.0)
