"""hmc's guard on a start metric far too narrow or too wide (:mod:`pavement_mcmc.samplers.metric_guard`).

A Laplace covariance scored with a parameter on its bound as outside gave κ an sd of 9e-8
where the posterior's is ~1e-2, and hmc never recovered from that start (54 726 steps, 664 s,
not converged): the metric windows widen a direction only by how far the chains diffuse in one
window. Here a start metric with one parameter's sd scaled by 1e-5 (its correlations kept)
must be widened back before sampling, converge within a budget the unguarded start never met,
and give the normal start's posterior; a sound start is left exactly as it was. A start metric
1e3 too wide in κ cost Case A ~10x the normal start's gradients (108 k against 11 k): it must be
narrowed back (the tests at the end).
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from test_hmc_metric import _cut_gaussian
from test_samplers import LinearGaussian

from pavement_mcmc.diagnostics import ess
from pavement_mcmc.posterior import find_map
from pavement_mcmc.runs import run_sampler
from pavement_mcmc.samplers import get_sampler
from pavement_mcmc.samplers.metric_guard import probe_points, rescaled
from pavement_mcmc.samplers.target import bounded_laplace_cov, cholesky_of
from pavement_mcmc.storage import MemoryStore

SHRINK = 1e-5
WIDE = 1e3


def _shrunk(lap, i: int, factor: float = SHRINK):
    """``lap`` with parameter ``i``'s sd scaled by ``factor``, in the covariance and in the
    working coordinates' one the start points are drawn from."""
    f = np.ones(lap.cov.shape[0])
    f[i] = factor
    fz = f[lap.idx]
    return dataclasses.replace(lap, cov=lap.cov * np.outer(f, f), cov_z=lap.cov_z * np.outer(fz, fz))


def _run(post, lap, seed: int, max_steps: int):
    s = get_sampler("hmc", post, n_chains=16, seed=seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s.prepare(laplace=lap)
    st = MemoryStore.create(post.space.free, post.blob_names, s.n_chains, {"sampler": "hmc"})
    res = run_sampler(s, st, ess_target=1000, max_steps=max_steps)
    return res, st.read().chain[res.burn_in:]


def _agree(a: np.ndarray, b: np.ndarray, sd_rtol: float = 0.1) -> None:
    """Two kept chains (steps, chains, d) with the same posterior: means within 4.5 Monte Carlo
    standard errors of their difference, sds within ``sd_rtol``."""
    fa, fb = a.reshape(-1, a.shape[-1]), b.reshape(-1, b.shape[-1])
    se = np.sqrt(fa.var(0) / ess(a) + fb.var(0) / ess(b))
    z = (fa.mean(0) - fb.mean(0)) / se
    assert np.all(np.abs(z) < 4.5), z
    np.testing.assert_allclose(fa.std(0), fb.std(0), rtol=sd_rtol)


def test_a_metric_shrunk_along_one_parameter_is_widened_back_with_a_warning():
    """Gaussian target, p0 correlated with p1 (-0.33): the start metric with p0's sd 1e-5 of
    the posterior's is the posterior covariance again after the guard (the forward difference
    of a linear gradient is exact, and so is matching the conditional sds within this family);
    the warning names p0 and the factor. Before the guard the metric kept the 1e-5."""
    post = LinearGaussian(seed=2, d=3)
    lap = find_map(post)
    s = get_sampler("hmc", post, n_chains=16, seed=1)
    with pytest.warns(UserWarning, match=r"'p0': 'x1e\+05'"):
        s.prepare(laplace=_shrunk(lap, 0))
    np.testing.assert_allclose(s.M, post.cov, rtol=1e-6, atol=1e-9 * post.cov.max())
    np.testing.assert_allclose(s.rescale, [1e5, 1.0, 1.0], rtol=1e-6)
    sd = np.sqrt(np.diag(post.cov))
    spread = s.theta.std(0) / sd  # the start points are drawn from the widened metric
    assert np.all((spread > 0.3) & (spread < 3.0)), spread  # 16 chains (normal start: 0.5-2.2)


@pytest.mark.parametrize("i, factor", [(0, SHRINK), (1, SHRINK), (0, 1e3), (1, 1e3)])
def test_a_shrunk_metric_at_a_mode_on_a_bound_is_widened_back(i, factor):
    """The Gaussian cut at p0 >= a (its mode on the bound, p1 correlated with p0 at 0.99): with
    the start covariance's p0 (on the bound) or p1 (free) sd scaled by 1e-5, the metric's sds
    come back within 25 % of the normal start's (p0: the squared slope at the bound sets its
    scale, as the normal start's exponential one). Scaled by 1e3 instead, either is narrowed
    back (p0 to its curvature's scale, then capped by :func:`bounded_laplace_cov` as the
    normal start's: a first version left p0 to that cap alone, and p1 came out at 0.39 of the
    normal start's sd, its regression on p0 cut by the 1e3)."""
    post, _, mode = _cut_gaussian()
    lap = dataclasses.replace(find_map(post), theta=mode, cov=post.cov.copy())
    normal = get_sampler("hmc", post, n_chains=16, seed=1)
    normal.prepare(laplace=lap)
    s = get_sampler("hmc", post, n_chains=16, seed=1)
    with pytest.warns(UserWarning, match=f"'p{i}'"):
        s.prepare(laplace=_shrunk(lap, i, factor))
    np.testing.assert_allclose(np.sqrt(np.diag(s.M)), np.sqrt(np.diag(normal.M)), rtol=0.25)


def test_a_sound_start_metric_is_left_exactly_as_it_was():
    """No warning, no factor: the metric is the bounded Laplace covariance's factor bit for bit,
    on an unbounded Gaussian and at a mode on a bound."""
    post = LinearGaussian(seed=2, d=3)
    cut, _, mode = _cut_gaussian()
    for p, lap in ((post, find_map(post)),
                   (cut, dataclasses.replace(find_map(cut), theta=mode, cov=cut.cov.copy()))):
        s = get_sampler("hmc", p, n_chains=16, seed=1)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            s.prepare(laplace=lap)
        assert np.all(s.rescale == 1.0)
        g = p.loglik_and_grad(lap.theta[None])[1][0]
        B = bounded_laplace_cov(lap.cov, lap.theta, g, *p.space.bounds())
        np.testing.assert_array_equal(s.L, cholesky_of(0.5 * (B + B.T)))


@pytest.mark.parametrize("seed", [1, 2])
def test_a_shrunk_start_converges_to_the_normal_starts_posterior(seed):
    """Gaussian target: from p0's sd shrunk 1e-5 hmc meets the stopping rule within 1,000 steps
    (the normal start: 270-350 steps on seeds 1-3) and agrees with the normal start and with the
    exact posterior. Before the guard it had not converged after 5,000 steps, p0's sd at
    0.08-0.09 of the truth."""
    post = LinearGaussian(seed=2, d=3)
    lap = find_map(post)
    res, kept = _run(post, _shrunk(lap, 0), seed, max_steps=1000)
    assert res.converged, res.reason
    res0, kept0 = _run(post, lap, seed, max_steps=1000)
    assert res0.converged
    _agree(kept, kept0)
    np.testing.assert_allclose(kept.reshape(-1, 3).std(0), np.sqrt(np.diag(post.cov)), rtol=0.1)


def test_case_a_from_a_kappa_sd_shrunk_1e5_converges_like_the_normal_start():
    """Case A (paper priors) under hmc, seed 1: from the Laplace covariance with κ's sd scaled
    by 1e-5 (correlations kept) the stopping rule holds within 2,000 steps (609; the normal
    start 330) with the normal start's means and sds; unguarded it had not converged after 38k
    steps (R-hat 2.8 on κ, κ's sd 1.3e-3 against 1.2e-2)."""
    from conftest import REPO

    from pavement_mcmc.data import load_case
    from pavement_mcmc.posterior import build_problem

    pr = build_problem(load_case(REPO / "runs" / "caseA.toml"))
    lap = find_map(pr.posterior)
    res, kept = _run(pr.posterior, _shrunk(lap, pr.space.free.index("kappa")), 1, max_steps=2000)
    assert res.converged, res.reason
    res0, kept0 = _run(pr.posterior, lap, 1, max_steps=2000)
    assert res0.converged
    _agree(kept, kept0)


def test_the_probe_points_stay_inside_the_bounds():
    """The guard's forward differences never leave [lo, hi] (the solver refuses kappa <= 0): a
    step of one sd forwards, backwards when the upper bound is within it, half-way to the
    farther bound when both are. Case A from κ's sd 1e5 too wide (its bounds 1e-3 and 50):
    the backward step of 1,400 W m-1 K-1 reached the solver with κ < 0 and raised."""
    lo, hi = np.array([0.0, 0.0, 0.0, -np.inf]), np.array([10.0, 10.0, 1.0, np.inf])
    mode = np.array([1.0, 9.5, 0.3, 0.0])
    T = probe_points(mode, np.arange(4), np.array([2.0, 2.0, 5.0, 3.0]), lo, hi)
    assert np.all((T >= lo) & (T <= hi))
    np.testing.assert_allclose(np.diag(T[1:] - mode), [2.0, -2.0, 0.35, 3.0])

    from conftest import REPO

    from pavement_mcmc.data import load_case
    from pavement_mcmc.posterior import build_problem

    pr = build_problem(load_case(REPO / "runs" / "caseA.toml"))
    lap = find_map(pr.posterior)
    k = pr.space.free.index("kappa")
    normal = get_sampler("hmc", pr.posterior, n_chains=16, seed=1)
    normal.prepare(laplace=lap)
    s = get_sampler("hmc", pr.posterior, n_chains=16, seed=1)
    with pytest.warns(UserWarning, match="'kappa': 'x1e-05'"):  # narrowed back
        s.prepare(laplace=_shrunk(lap, k, 1e5))
    np.testing.assert_allclose(np.sqrt(s.M[k, k] / normal.M[k, k]), 1.0, rtol=0.05)


@pytest.mark.parametrize("factor", [SHRINK, WIDE])
def test_the_gamma_marginal_start_metric_is_guarded_too(monkeypatch, factor):
    """The GMRF toy (Case C's form: gamma integrated out, h's metric from the marginal MAP's
    Laplace covariance, whose heavy-tailed marginal prior of h makes the posterior non-Gaussian):
    with h_3's row and column of that covariance scaled by 1e-5 or 1e3, the metric is widened
    or narrowed back to within 25 % of the normal start's sds, and hmc meets the stopping rule
    within 2,000 steps with the normal start's posterior."""
    from test_samplers import ToyGMRF

    from pavement_mcmc.samplers import hmc

    post = ToyGMRF(N=10, seed=3)

    class Shrunk(hmc.MarginalTarget):
        def __init__(self, *args, **kw):
            super().__init__(*args, **kw)
            f = np.ones(self.idx.size)
            f[3] = factor
            self.mmap = dataclasses.replace(self.mmap, cov=self.mmap.cov * np.outer(f, f))

    def run(seed):
        s = get_sampler("hmc", post, n_chains=16, seed=seed)
        s.prepare()
        st = MemoryStore.create(post.space.free, post.blob_names, s.n_chains, {"sampler": "hmc"})
        res = run_sampler(s, st, ess_target=1000, max_steps=2000)
        return s, res, st.read().chain[res.burn_in:]

    normal, res0, kept0 = run(1)
    monkeypatch.setattr(hmc, "MarginalTarget", Shrunk)
    with pytest.warns(UserWarning, match="'h_3'"):
        s, res, kept = run(1)
    np.testing.assert_allclose(np.sqrt(np.diag(s.M)), np.sqrt(np.diag(normal.M)), rtol=0.25)
    assert res0.converged and res.converged, res.reason
    _agree(kept, kept0)


def _gaussian_probe(S: np.ndarray, cov: np.ndarray, mode: np.ndarray, lo=None, hi=None):
    """The guard's probe rows for N(mode, S) from the metric ``cov``, the log-density there and
    its gradient, -S^-1 (x - mode), written out here (not the posterior's code)."""
    d = mode.size
    lo = np.full(d, -np.inf) if lo is None else lo
    hi = np.full(d, np.inf) if hi is None else hi
    X = probe_points(mode, np.arange(d), np.sqrt(np.diag(cov)), lo, hi)
    P = np.linalg.inv(S)
    G = -(X - mode) @ P
    return X, 0.5 * np.sum((X - mode) * G, axis=1), G


def test_a_metric_too_wide_along_one_parameter_is_narrowed_to_the_posteriors_conditional_sd():
    """Gaussian N(m, S), p0 correlated with p1 (-0.33 in LinearGaussian(2)): the metric with
    p0's sd 100x S's is S again (the conditional sds agree: (Sigma^-1)_00 = (S^-1)_00, the
    correlations kept); one 5x too wide or too narrow is returned as it is (within RATIO).
    Before: ``widened`` left the 100x (factor 1)."""
    post = LinearGaussian(seed=2, d=3)
    S, m = post.cov, post.mean
    for fac, expect in ((100.0, 0.01), (5.0, 1.0), (0.2, 1.0)):
        f = np.array([fac, 1.0, 1.0])
        cov = S * np.outer(f, f)
        X, lp, G = _gaussian_probe(S, cov, m)
        out, factor = rescaled(cov, X, lp, G)
        np.testing.assert_allclose(factor, [expect, 1.0, 1.0], rtol=1e-6)
        if expect == 1.0:
            assert out is cov
            continue
        np.testing.assert_allclose(out, S, rtol=1e-6)
        np.testing.assert_allclose(np.linalg.inv(out)[0, 0], np.linalg.inv(S)[0, 0], rtol=1e-6)
        sd, sd0 = np.sqrt(np.diag(out)), np.sqrt(np.diag(cov))
        np.testing.assert_allclose(out / np.outer(sd, sd), cov / np.outer(sd0, sd0), atol=1e-12)


def test_a_parameter_pushed_against_its_bound_is_narrowed_by_its_curvature_alone():
    """p0's mode on its lower bound, the data pushing it below (slope^2 900x the curvature,
    the grass window's night h have up to 140x): a metric at the curvature's scale is left as
    it is (the slope's scale is :func:`bounded_laplace_cov`'s cap, applied next; compared with
    max(curvature, slope^2) it would be narrowed 30x), and one 1e3 too wide is narrowed to the
    curvature's scale, not to the slope's."""
    post = LinearGaussian(seed=2, d=3)
    S, m = post.cov, post.mean
    lo = np.array([m[0], -np.inf, -np.inf])
    for fac, expect in ((1.0, 1.0), (WIDE, 1.0 / WIDE)):
        f = np.array([fac, 1.0, 1.0])
        cov = S * np.outer(f, f)
        X, lp, G = _gaussian_probe(S, cov, m, lo)
        G[:, 0] -= 30.0 * np.sqrt(np.linalg.inv(S)[0, 0])  # a constant slope: same curvature
        out, factor = rescaled(cov, X, lp, G)
        np.testing.assert_allclose(factor, [expect, 1.0, 1.0], rtol=1e-6)


def test_a_widened_metric_start_on_a_gaussian_is_narrowed_with_a_warning():
    """hmc's preparation on the Gaussian from p0's sd 1e3 too wide: a warning names p0 and
    the factor, the metric is the posterior covariance, the start points spread as the normal
    start's."""
    post = LinearGaussian(seed=2, d=3)
    lap = find_map(post)
    s = get_sampler("hmc", post, n_chains=16, seed=1)
    with pytest.warns(UserWarning, match=r"'p0': 'x0.001'.*narrowed"):
        s.prepare(laplace=_shrunk(lap, 0, WIDE))
    np.testing.assert_allclose(s.M, post.cov, rtol=1e-6, atol=1e-9 * post.cov.max())
    spread = s.theta.std(0) / np.sqrt(np.diag(post.cov))
    assert np.all((spread > 0.3) & (spread < 3.0)), spread


def test_case_a_from_a_kappa_sd_1e3_too_wide_converges_on_the_normal_starts_gradients():
    """Case A (paper priors) under hmc, seed 1: from the Laplace covariance with κ's sd 1e3
    times too wide (correlations kept) the stopping rule holds on fewer than 25 k gradients
    (18,776 in 580 steps; the normal start: 10,886 in 330), with the normal start's means and
    sds. Unguarded it stopped at 330 steps too, but on 108,022 gradients (20 leapfrog steps a
    trajectory instead of 2 until the windows shrank the metric)."""
    from conftest import REPO

    from pavement_mcmc.data import load_case
    from pavement_mcmc.posterior import build_problem

    pr = build_problem(load_case(REPO / "runs" / "caseA.toml"))
    lap = find_map(pr.posterior)
    res, kept = _run(pr.posterior, _shrunk(lap, pr.space.free.index("kappa"), WIDE), 1, max_steps=2000)
    assert res.converged, res.reason
    assert res.n_evals < 25_000, res.n_evals
    res0, kept0 = _run(pr.posterior, lap, 1, max_steps=2000)
    assert res0.converged
    _agree(kept, kept0)
