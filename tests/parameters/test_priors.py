"""Priors and parameter spaces against closed-form answers."""

import warnings

import numpy as np
import pytest
from scipy.integrate import quad

from pavement_mcmc.parameters import (
    GMRFSmoothness,
    Normal,
    Parameter,
    ParameterSpace,
    Rayleigh,
    TruncatedNormal,
    Uniform,
    prior_from_config,
)


@pytest.mark.parametrize(
    "prior, lo, hi",
    [
        (TruncatedNormal(2.27, 0.1135), 0, np.inf),
        (TruncatedNormal(0.0, 50.0), 0, np.inf),  # half-normal: truncation halves the mass
        (TruncatedNormal(3.0, 3.0, 0.25, 10.0), 0.25, 10.0),
        (Rayleigh(2.22), 0, np.inf),
        (Uniform(-1.0, 3.0), -1, 3),
        (Normal(1.0, 2.0), -np.inf, np.inf),
    ],
)
def test_densities_integrate_to_one(prior, lo, hi):
    total, _ = quad(lambda x: np.exp(prior.logpdf(np.array([x]))[0]), lo, hi, limit=200)
    assert total == pytest.approx(1.0, abs=1e-6)


def test_half_normal_density_is_twice_the_normal():
    x = np.array([1.0, 20.0])
    assert np.allclose(TruncatedNormal(0, 50).logpdf(x), Normal(0, 50).logpdf(x) + np.log(2))


def test_out_of_support_is_minus_inf_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.all(np.isneginf(TruncatedNormal(10, 5).logpdf(np.array([-1.0, -1e9]))))
        assert np.all(np.isneginf(Rayleigh(2.22).logpdf(np.array([0.0, -3.0]))))
        assert np.isneginf(Uniform(0, 1).logpdf(np.array([1.5]))[0])


def test_rayleigh_sampling_matches_its_moments():
    rng = np.random.default_rng(1)
    r = Rayleigh(2.22)
    s = r.sample(rng, 200_000)
    assert s.mean() == pytest.approx(r.mean, rel=0.01)
    assert s.std() == pytest.approx(r.sd, rel=0.01)


def test_gmrf_matches_the_quadratic_form():
    rng = np.random.default_rng(2)
    N = 7
    h = rng.uniform(5, 15, size=(4, N))
    g = np.array([0.5, 2.22, 3.3, 22.2])
    D = np.diff(np.eye(N), axis=0)
    expected = 0.5 * (N - 1) * np.log(g) - 0.5 * g * np.einsum("si,ij,sj->s", h, D.T @ D, h)
    names = tuple(f"h_{i}" for i in range(N))
    p = {n: h[:, i] for i, n in enumerate(names)} | {"gamma": g}
    assert np.allclose(GMRFSmoothness(names).logpdf(p), expected)
    # rank N-1: adding a constant to every h leaves the density unchanged
    p2 = {n: h[:, i] + 3.0 for i, n in enumerate(names)} | {"gamma": g}
    assert np.allclose(GMRFSmoothness(names).logpdf(p2), expected)


def _space():
    return ParameterSpace([
        Parameter("kappa", 1.0, 0.0, 10.0, prior=TruncatedNormal(2.27, 0.1135)),
        Parameter("h_1", 10.0, 0.0, 100.0, group="h"),
        Parameter("h_2", 10.0, 0.0, 100.0, group="h"),
    ])


def test_expand_and_fixed_parameters():
    sp = _space().configure({"h": {"value": 7.0}, "h_2": {"vary": False, "value": 3.0}})
    assert sp.free == ["kappa", "h_1"]
    p = sp.expand(np.array([[1.5, 8.0], [2.0, 9.0]]))
    assert np.allclose(p["h_2"], 3.0) and np.allclose(p["h_1"], [8.0, 9.0])
    assert sp["h_1"].value == 7.0


def test_configure_errors_list_valid_names():
    with pytest.raises(ValueError, match="valid: .*kappa"):
        _space().configure({"kapa": {"value": 1.0}})
    with pytest.raises(ValueError, match="keys among"):
        _space().configure({"kappa": {"mean": 1.0}})


def test_name_clash_is_refused():
    with pytest.raises(ValueError, match="clash"):
        ParameterSpace([Parameter("a", 1.0), Parameter("a", 2.0)])


def test_log_prior_bounds_and_config_priors():
    sp = _space().configure({"h": {"prior": {"dist": "truncnormal", "mean": 10, "sd": 5}}})
    lp = sp.log_prior(np.array([[2.27, 10.0, 10.0], [2.27, -1.0, 10.0], [11.0, 10.0, 10.0]]))
    assert np.isfinite(lp[0]) and np.isneginf(lp[1]) and np.isneginf(lp[2])
    expected = TruncatedNormal(2.27, 0.1135).logpdf(2.27) + 2 * TruncatedNormal(10, 5).logpdf(10.0)
    assert lp[0] == pytest.approx(float(expected))
    with pytest.raises(ValueError, match="unknown prior dist"):
        prior_from_config({"dist": "cauchy"})


def test_log_prior_gradient_matches_finite_differences():
    """ParameterSpace.grad_log_prior (univariate priors' grad_logpdf + the GMRF's gradient in h
    and gamma) against central differences of log_prior."""
    names = ("h_1", "h_2", "h_3", "h_4")
    params = [
        Parameter("kappa", 1.3, 0.0, 50.0, prior=TruncatedNormal(2.27, 0.1135)),
        Parameter("C", 1.0, 0.0, 10.0, prior=Normal(1.5, 0.5)),
        Parameter("u", 0.5, -1.0, 3.0, prior=Uniform(-1.0, 3.0)),
        Parameter("gamma", 1.7, 0.0, 1e4, prior=Rayleigh(2.22)),
    ] + [Parameter(n, 10.0, 0.0, 500.0, group="h") for n in names]
    space = ParameterSpace(params, [GMRFSmoothness(names, "gamma")])
    rng = np.random.default_rng(0)
    theta = np.array([1.3, 1.1, 0.4, 1.7, 9.0, 11.0, 7.5, 8.0]) + 0.1 * rng.normal(size=(3, 8))
    g = space.grad_log_prior(theta)
    eps = 1e-6
    for j in range(theta.shape[1]):
        tp, tm = theta.copy(), theta.copy()
        tp[:, j] += eps
        tm[:, j] -= eps
        fd = (space.log_prior(tp) - space.log_prior(tm)) / (2 * eps)
        np.testing.assert_allclose(g[:, j], fd, rtol=1e-6, atol=1e-6)
    # without the joint prior: only the univariate terms (h has flat priors)
    assert np.all(space.grad_log_prior(theta, joint=False)[:, 4:] == 0.0)


def test_the_smoothness_prior_is_found_in_one_place():
    """``ParameterSpace.smoothness`` is what the MAP, the marginal (gamma integrated out), the
    prior residuals and the sensitivity's hyperparameters all read: they agree on Case C's
    space, and with gamma fixed the marginal route is off while the prior rows stay."""
    from pavement_mcmc.posterior import gmrf_of

    names = ("h_1", "h_2", "h_3")
    params = [Parameter("kappa", 1.3, 0.0, 50.0), Parameter("gamma", 1.7, 0.0, 1e4)]
    params += [Parameter(n, 10.0, 0.0, 500.0, group="h") for n in names]
    gmrf = GMRFSmoothness(names, "gamma")
    space = ParameterSpace(params, [gmrf])
    assert space.smoothness() is gmrf and ParameterSpace(params).smoothness() is None
    assert gmrf_of(space) == ("gamma", list(names))
    rows = space.prior_residuals()
    theta = np.array([[1.3, 4.0, 10.0, 12.0, 9.0]])
    np.testing.assert_allclose(rows(theta), [[2.0 * 2.0, 2.0 * -3.0]])  # sqrt(gamma) D h
    fixed = space.configure({"gamma": {"vary": False, "value": 9.0}})
    assert gmrf_of(fixed) is None
    np.testing.assert_allclose(fixed.prior_residuals()(theta[:, [0, 2, 3, 4]]), [[3.0 * 2.0, -9.0]])
