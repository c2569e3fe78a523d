"""hmc's guard on a start metric far too narrow (:mod:`pavement_mcmc.samplers.metric_guard`).

A Laplace covariance scored with a parameter on its bound as outside gave κ an sd of 9e-8
where the posterior's is ~1e-2, and hmc never recovered from that start (54 726 steps, 664 s,
not converged): the metric windows widen a direction only by how far the chains diffuse in one
window. Here a start metric with one parameter's sd scaled by 1e-5 (its correlations kept)
must be widened back before sampling, converge within a budget the unguarded start never met,
and give the normal start's posterior; a sound start is left exactly as it was.
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
from pavement_mcmc.samplers.metric_guard import probe_points
from pavement_mcmc.samplers.target import bounded_laplace_cov, cholesky_of
from pavement_mcmc.storage import MemoryStore

SHRINK = 1e-5


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
    np.testing.assert_allclose(s.widen, [1e5, 1.0, 1.0], rtol=1e-6)
    sd = np.sqrt(np.diag(post.cov))
    spread = s.theta.std(0) / sd  # the start points are drawn from the widened metric
    assert np.all((spread > 0.3) & (spread < 3.0)), spread  # 16 chains (normal start: 0.5-2.2)


@pytest.mark.parametrize("i", [0, 1])
def test_a_shrunk_metric_at_a_mode_on_a_bound_is_widened_back(i):
    """The Gaussian cut at p0 >= a (its mode on the bound, p1 correlated with p0 at 0.99): with
    the start covariance's p0 (on the bound) or p1 (free) sd scaled by 1e-5, the metric's sds
    come back within 25 % of the normal start's (p0: the squared slope at the bound sets its
    scale, as the normal start's exponential one)."""
    post, _, mode = _cut_gaussian()
    lap = dataclasses.replace(find_map(post), theta=mode, cov=post.cov.copy())
    normal = get_sampler("hmc", post, n_chains=16, seed=1)
    normal.prepare(laplace=lap)
    s = get_sampler("hmc", post, n_chains=16, seed=1)
    with pytest.warns(UserWarning, match=f"'p{i}'"):
        s.prepare(laplace=_shrunk(lap, i))
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
        assert np.all(s.widen == 1.0)
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
    s = get_sampler("hmc", pr.posterior, n_chains=16, seed=1)
    s.prepare(laplace=_shrunk(lap, pr.space.free.index("kappa"), 1e5))
    assert np.all(s.widen == 1.0)  # a metric too wide is left to the windows


def test_the_gamma_marginal_start_metric_is_guarded_too(monkeypatch):
    """The GMRF toy (Case C's form: gamma integrated out, h's metric from the marginal MAP's
    Laplace covariance): with h_3's row and column of that covariance scaled by 1e-5, the metric
    is widened back to within 25 % of the normal start's sds, and hmc meets the stopping rule
    within 2,000 steps with the normal start's posterior."""
    from test_samplers import ToyGMRF

    from pavement_mcmc.samplers import hmc

    post = ToyGMRF(N=10, seed=3)

    class Shrunk(hmc.MarginalTarget):
        def __init__(self, *args, **kw):
            super().__init__(*args, **kw)
            f = np.ones(self.idx.size)
            f[3] = SHRINK
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
