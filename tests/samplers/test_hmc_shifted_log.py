"""hmc's log coordinates shifted by a Laplace sd, ``w = log(x + c)`` (option ``log_shift``):
the map and its Jacobian, and a posterior with mass near its bound 0 that plain ``log x``
(``log_shift = 0``) turns into an infinite tail (issue 25: a Göttingen h 2.8 sd above 0 kept a
chain near 0 for ~80 steps)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pavement_mcmc.diagnostics import ess
from pavement_mcmc.parameters import Parameter, ParameterSpace
from pavement_mcmc.parameters.priors import Flat
from pavement_mcmc.runs import run_sampler
from pavement_mcmc.samplers import get_sampler
from pavement_mcmc.samplers.coords import LOG, Coords, log_metric
from pavement_mcmc.storage import MemoryStore


def test_shifted_log_map_bounds_and_jacobian():
    """``w = log(x + c)``: the inverse map, the lower bound (maps back to x > 0, within a
    few ulp of 0), the log-density gaining ``w`` and the gradient ``(x + c) df/dx + 1``
    against central differences of ``f(x(w)) + log dx/dw``, and the delta-method metric."""
    c = np.array([0.7, 0.0])
    co = Coords(np.array([LOG, LOG, 0]), np.array([0.7, 0.0, 0.0]))
    x = np.array([[0.3, 2.0, -1.0], [5.0, 0.1, 4.0]])
    w = co.to_w(x)
    np.testing.assert_allclose(w[:, :2], np.log(x[:, :2] + c))
    np.testing.assert_allclose(co.to_x(w), x, rtol=1e-14)
    lo, hi = co.bounds(np.array([0.0, 0.0, -np.inf]), np.array([np.inf, 9.0, np.inf]))
    x_lo = co.to_x(lo[None])[0]
    assert 0.0 < x_lo[0] < 1e-15 and lo[1] == np.log(1e-300) and co.to_x(hi[None])[0, 1] <= 9.0
    # the lower bound maps back to x > 0, never onto 0 (a kappa reflected onto 0 ended a daily
    # desert fit: the solver refuses it); c = 1 has exp(log c) - c == 0 exactly
    cs = np.r_[1.0, 0.5, 2.0, np.random.default_rng(0).lognormal(0.0, 3.0, 2000)]
    lo_c, _ = Coords(np.full(cs.size, LOG), cs).bounds(np.zeros(cs.size), np.full(cs.size, np.inf))
    assert np.all(np.exp(lo_c) - cs > 0.0)

    def f_x(x):  # a smooth log-density in x and its gradient
        return -np.sum((x - 1.0) ** 2 / (1.0 + x * x), axis=1), \
            -(2 * (x - 1.0) * (1 + x * x) - 2 * x * (x - 1.0) ** 2) / (1 + x * x) ** 2

    f, g = co.in_log(*f_x(x), w, x)
    for j in range(3):
        e = np.zeros(3)
        e[j] = 1e-6

        def total(wv):
            xv = co.to_x(wv)
            return f_x(xv)[0] + np.sum(wv[:, :2], axis=1)  # log dx/dw = w for log(x + c)

        num = (total(w + e) - total(w - e)) / 2e-6
        np.testing.assert_allclose(g[:, j], num, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(f, f_x(x)[0] + w[:, 0] + w[:, 1])
    cov = np.array([[0.04, 0.01], [0.01, 0.09]])
    out = log_metric(cov, np.array([2.0, 3.0]), np.array([LOG, LOG]), np.array([1.0, 0.0]))
    np.testing.assert_allclose(out, cov / np.outer([3.0, 3.0], [3.0, 3.0]))


class Shelf:
    """p0 >= 0 with density 0.8 N(3, 1) + 0.2 N(0.4, 0.4) (truncated at 0: a bump with a
    second, smaller one against the bound, as a daytime h with a low-h ridge), p1 ~ N(0, 1)."""

    W, M, S = np.array([0.8, 0.2]), np.array([3.0, 0.4]), np.array([1.0, 0.4])

    def __init__(self):
        self.space = ParameterSpace([Parameter("p0", 3.0, 0.0, np.inf, prior=Flat()),
                                     Parameter("p1", 0.0, -np.inf, np.inf, prior=Flat())])
        self.ndim, self.blob_names = 2, ["rmse"]

    def loglik_and_grad(self, th):
        th = np.atleast_2d(th)
        x = th[:, :1]
        lc = np.log(self.W) - 0.5 * ((x - self.M) / self.S) ** 2 - np.log(self.S)
        ll = np.logaddexp(lc[:, 0], lc[:, 1])
        g = np.zeros_like(th)
        g[:, 0] = np.sum(np.exp(lc - ll[:, None]) * (self.M - x) / self.S**2, axis=1)
        g[:, 1] = -th[:, 1]
        return ll - 0.5 * th[:, 1] ** 2, g, np.zeros((th.shape[0], 1))

    def __call__(self, th):
        ll, _, bl = self.loglik_and_grad(th)
        return np.where(np.atleast_2d(th)[:, 0] >= 0.0, ll, -np.inf), bl

    def below(self, x):
        """P(p0 < x), exactly."""
        mass = self.W * stats.norm.sf(-self.M / self.S)
        return float(np.sum(mass * stats.truncnorm(-self.M / self.S, np.inf, self.M, self.S).cdf(x))
                     / mass.sum())


class _Laplace:
    theta, cov, sd, n_evals = np.array([3.0, 0.0]), np.eye(2), np.ones(2), 0


@pytest.mark.parametrize("shift, max_per_draw", [(None, 25.0), (0.0, np.inf)])
def test_shifted_log_coordinates_cross_to_the_bound_cheaply_and_exactly(shift, max_per_draw):
    """On :class:`Shelf` (mode 3 sd above 0, 18 % of the mass below 1) in log coordinates:
    with the default shift (one Laplace sd) the chains keep P(p0 < 1) within Monte Carlo error
    and spend fewer than 25 gradients per effective draw of p0 (measured 18, seeds
    1-2); in plain ``log x`` (``log_shift = 0``, the coordinates before) the region near 0 is
    an infinite tail the trajectories cross with small steps: ~36 gradients per effective draw
    (77.6k gradients for 1000 steps against 47.5k), still exact."""
    post = Shelf()
    opts = {"log_positive": True, **({} if shift is None else {"log_shift": shift})}
    s = get_sampler("hmc", post, n_chains=16, seed=1, options=opts)
    s.prepare(laplace=_Laplace())
    assert list(s.tlog) == [LOG, 0] and s.shift[0] == (1.0 if shift is None else shift)
    store = MemoryStore.create(post.space.free, post.blob_names, 16, {"sampler": "hmc"})
    with np.errstate(over="ignore", invalid="ignore"):
        res = run_sampler(s, store, ess_target=1e9, max_steps=1000, n_adapt=150)
    kept = store.read().chain[res.burn_in:]
    n_eff = ess(kept)[0]
    low = float(np.mean(kept[..., 0] < 1.0))
    p = post.below(1.0)
    assert abs(low - p) < 4.0 * np.sqrt(p * (1 - p) / n_eff), (low, p, n_eff)
    per_draw = res.n_evals / n_eff  # gradients (all chains) per effective draw
    assert per_draw < max_per_draw, per_draw
    if shift == 0.0:  # what the shift gains: the plain log needs more than 30
        assert per_draw > 30.0, per_draw


def test_a_chain_stranded_by_its_start_rejoins_the_others_before_the_metric_window():
    """A chain placed far in a log coordinate's right tail (p0 at 3x its mode, ~70 sd out,
    where the curvature in ``log p0`` is ~9x the mode's) rejects every trajectory at the step
    size the others tune; at step ``metric_skip`` it continues from another chain's state
    (:mod:`pavement_mcmc.samplers.strays`), so the first metric window pools no stuck draws
    and every chain ends the adaptation in the bulk. Chains in the bulk are never moved."""
    from test_samplers import LinearGaussian

    from pavement_mcmc.posterior import find_map
    from pavement_mcmc.samplers.strays import strays

    post = LinearGaussian(seed=2, d=3, lower=[0.0, -np.inf, -np.inf])
    s = get_sampler("hmc", post, n_chains=8, seed=4, options={"log_positive": True})
    s.prepare(laplace=find_map(post))
    assert list(s.tlog) == [LOG, 0, 0]
    far = s.theta[0].copy()
    far[0] = 10.0 * post.mean[0]
    s.theta[0] = far
    s.f, s.g, s.loglik, s.blobs = s._value_grad_w(s.coords.to_w(s.theta[:, s.idx]))
    s.logp = s._joint_logp(s.theta)
    assert strays(s.f, 3).tolist() == [True] + [False] * 7  # the others: within 10 of the median
    with np.errstate(over="ignore", invalid="ignore"):  # trajectories flung far out: rejected
        b = s.step(150, adapt=True)
    sd0 = np.sqrt(post.cov[0, 0])
    assert np.all(np.abs(b.chain[-1, :, 0] - post.mean[0]) < 5 * sd0), b.chain[-1, :, 0]
    assert np.all(np.abs(b.chain[20:, :, 0] - post.mean[0]) < 6 * sd0)  # the first window's draws
    rng = np.random.default_rng(0)  # a Gaussian's bulk: never a stray (chi2_d / 2 spread)
    for d in (3, 30, 150):
        f = -0.5 * rng.chisquare(d, size=(200, 16))
        assert not any(strays(row, d).any() for row in f)
