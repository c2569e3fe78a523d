"""Priors and parameter spaces against closed-form answers."""

import warnings

import numpy as np
import pytest
from scipy.integrate import quad

from pavement_mcmc.parameters import Parameter, ParameterSpace
from pavement_mcmc.priors import (
    GMRFSmoothness,
    Normal,
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
