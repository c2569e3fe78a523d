"""hmc's metric. At a mode on a bound the start metric keeps the other coordinates' regression
on the bound one (:func:`pavement_mcmc.samplers.target.bounded_laplace_cov`), checked against
the exact covariance of a truncated Gaussian and by the first metric window's gradients; the
adaptation windows keep a strongly correlated pair's narrow direction."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import stats
from test_samplers import LinearGaussian

from pavement_mcmc.parameters import Flat, Parameter, ParameterSpace
from pavement_mcmc.posterior import find_map
from pavement_mcmc.samplers import get_sampler
from pavement_mcmc.samplers.target import bounded_laplace_cov

#: the Gaussian before the cut: sd 0.316 each, p0 and p1 correlated at RHO, p2 independent
RHO, VAR = 0.99, 0.1
#: the bound p0 >= mean0 + CUT sd0 (the mass lies below it: the mode sits on it)
CUT = 3.0


def _cut_gaussian(rho: float = RHO):
    """A 3-D linear-Gaussian posterior N(m, S) truncated at p0 >= a (flat priors), its
    constrained mode and ``S``: the mode sits on the bound, the posterior of p0 is close to an
    exponential, and p1 follows p0 through their correlation ``rho``."""
    post = LinearGaussian(seed=2, d=3)
    S = VAR * np.eye(3)
    S[0, 1] = S[1, 0] = rho * VAR
    X = post.sigma * np.linalg.cholesky(np.linalg.inv(S)).T  # X^T X / sigma^2 = S^-1
    m = np.array([3.0, 4.5, 6.0])
    post.X, post.y = X, X @ m
    post.obs, post.mean, post.cov = post.y[:, None], m, S
    a = m[0] + CUT * np.sqrt(VAR)
    post.space = ParameterSpace([Parameter(f"p{i}", float(m[i]) + (a - m[0] + 0.1) * (i == 0),
                                           a if i == 0 else -np.inf, np.inf, prior=Flat())
                                 for i in range(3)])
    mode = m + S[:, 0] / S[0, 0] * (a - m[0])
    return post, a, mode


def _exact_cov(m: np.ndarray, S: np.ndarray, a: float) -> np.ndarray:
    """The covariance of N(m, S) truncated at x0 >= a: x0 a truncated normal, and every other
    coordinate ``b x0 + e`` with ``b = S_f0 / S_00`` and ``e`` the untruncated conditional
    spread, whatever the cut on x0."""
    sd0 = np.sqrt(S[0, 0])
    v0 = stats.truncnorm((a - m[0]) / sd0, np.inf, loc=m[0], scale=sd0).var()
    b = S[:, 0] / S[0, 0]
    return S - np.outer(b, S[0]) + np.outer(b, b) * v0


def test_metric_at_a_bound_keeps_the_regression_of_the_others():
    """The start metric is the truncated Gaussian's covariance: p1's sd within 25 % (p0's
    exponential scale is 1.2x its truncated sd; p1's marginal Laplace sd, which the metric
    kept before, is 3.4x too wide) and its correlation with p0 within 0.05 (0 before); p2,
    independent, keeps its sd."""
    post, a, mode = _cut_gaussian()
    S = post.cov
    g = post.loglik_and_grad(mode[None])[1][0]
    M = bounded_laplace_cov(S, mode, g, *post.space.bounds())
    ex = _exact_cov(post.mean, S, a)
    sd, sd_ex = np.sqrt(np.diag(M)), np.sqrt(np.diag(ex))
    assert np.sqrt(S[1, 1]) / sd_ex[1] > 3  # the marginal sd the metric used to keep
    np.testing.assert_allclose(sd[1:], sd_ex[1:], rtol=0.25)
    assert abs(M[0, 1] / (sd[0] * sd[1]) - ex[0, 1] / (sd_ex[0] * sd_ex[1])) < 0.05
    np.testing.assert_allclose(M[2, :2], 0.0, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(M) > 0)


def test_metric_without_an_active_bound_is_the_laplace_one():
    post, _, _ = _cut_gaussian()
    S = post.cov
    inside = post.mean.copy()  # the unconstrained mode, zero gradient: no bound is active
    g = np.zeros(3)
    assert bounded_laplace_cov(S, inside, g, *post.space.bounds()) is S


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_first_metric_window_costs_few_gradients_from_a_mode_on_a_bound(seed):
    """From the exact Laplace approximation at the constrained mode, hmc's first 50
    adaptation steps (the first metric window) spend under 3,500 gradients on 16 chains; with
    p1's marginal sd in the metric (the correlations dropped) the step size had to resolve a
    direction 7x narrower than the metric said: 8,160-9,024 gradients (seeds 1-3)."""
    post, _, mode = _cut_gaussian()
    lap = dataclasses.replace(find_map(post), theta=mode, cov=post.cov.copy())
    s = get_sampler("hmc", post, n_chains=16, seed=seed)
    s.prepare(laplace=lap)
    block = s.step(50, adapt=True)
    assert block.n_evals < 3500, block.n_evals


def test_metric_windows_keep_a_narrow_direction():
    """A Gaussian with a pair correlated at 0.995 (its narrow direction has 0.005 of the
    variance): after the adaptation's metric windows, the posterior's sd along every direction
    of the metric's whitened coordinates is at least 0.75. The windows' covariance shrunk 10 %
    towards its diagonal gave the narrow direction the metric variance 0.9 x 0.005 + 0.1, its
    whitened sd 0.22, and the step size had to resolve it."""
    post = LinearGaussian(seed=2, d=4)
    S = np.eye(4)
    S[0, 1] = S[1, 0] = 0.995
    S[2, 3] = S[3, 2] = 0.9
    X = post.sigma * np.linalg.cholesky(np.linalg.inv(S)).T
    m = np.array([3.0, 4.0, 5.0, 6.0])
    post.X, post.y = X, X @ m
    post.obs, post.mean, post.cov = post.y[:, None], m, S
    lap = dataclasses.replace(find_map(post), theta=m, cov=S.copy())
    s = get_sampler("hmc", post, n_chains=16, seed=1)
    s.prepare(laplace=lap)
    s.step(s.adapt_length(), adapt=True)
    assert s.n_metric == 2
    Li = np.linalg.inv(s.L)
    sd = np.sqrt(np.linalg.eigvalsh(Li @ S @ Li.T))
    assert sd.min() > 0.75, sd


def test_a_window_of_parameters_of_very_different_scales_is_taken():
    """Parameters whose sd span 1e-3 to 1e8 (a depth in m beside a heat capacity in J m-3 K-1):
    the first window's covariance replaces a start metric 2x too wide in sd (relative error
    below 0.5 of sd_i sd_j). Its positive definiteness was checked on the raw eigenvalues, whose
    round-off (1e-16 of 1e16) swamps the smallest (1e-6): on seed 1 the window was refused and
    the wrong metric kept (error 3.0); now it is checked on the correlation matrix."""
    post = LinearGaussian(seed=2, d=3)
    R = np.array([[1.0, 0.6, 0.3], [0.6, 1.0, -0.2], [0.3, -0.2, 1.0]])
    D = np.diag([1e-3, 1.0, 1e8])
    S = D @ R @ D
    X = post.sigma * np.linalg.cholesky(np.linalg.inv(S)).T
    m = np.array([0.01, 4.0, 3e6])
    post.X, post.y = X, X @ m
    post.obs, post.mean, post.cov = post.y[:, None], m, S
    post.space = ParameterSpace([Parameter(f"p{i}", float(m[i]), -np.inf, np.inf, prior=Flat())
                                 for i in range(3)])
    lap = dataclasses.replace(find_map(post), theta=m, cov=4.0 * np.diag(np.diag(S)))
    s = get_sampler("hmc", post, n_chains=16, seed=1)
    s.prepare(laplace=lap)
    s.step(50, adapt=True)
    assert s.n_metric == 1
    sd = np.sqrt(np.diag(S))
    err = np.abs(s.L @ s.L.T - S) / np.outer(sd, sd)
    assert err.max() < 0.5, err.max()
