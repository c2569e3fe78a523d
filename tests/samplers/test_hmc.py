"""The reflective HMC sampler on a truncated Gaussian and the log-likelihood gradient it uses
(adjoint, finite-difference fallback). The GMRF toy and resume: tests/samplers/test_samplers.py."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import stats
from test_samplers import LinearGaussian

from pavement_mcmc.diagnostics import ess
from pavement_mcmc.posterior import find_map
from pavement_mcmc.runs import run_sampler
from pavement_mcmc.samplers import get_sampler
from pavement_mcmc.storage import MemoryStore


def _store(post, n):
    return MemoryStore.create(post.space.free, post.blob_names, n, {"sampler": "hmc"})


def _straight_and_resumed(post, opts, seed, n, k, n_adapt=50):
    """``hmc`` run ``n`` steps straight, and run ``k`` steps then restored into a new sampler
    and continued to ``n``: the straight sampler, the stopped one, the restored one and the
    two runs' data."""

    def prep():
        s = get_sampler("hmc", post, n_chains=16, seed=seed, options=opts)
        s.prepare(laplace=find_map(post))
        return s

    a = prep()
    st_a = _store(post, a.n_chains)
    run_sampler(a, st_a, ess_target=1e9, max_steps=n, n_adapt=n_adapt)
    b = prep()
    st_b = _store(post, b.n_chains)
    run_sampler(b, st_b, ess_target=1e9, max_steps=k, n_adapt=n_adapt)
    c = get_sampler("hmc", post, options=opts)
    c.set_state(st_b.state)
    st_c = MemoryStore.open_append(st_b)
    run_sampler(c, st_c, ess_target=1e9, max_steps=n, n_adapt=n_adapt)
    return a, b, c, st_a.read(), st_c.read()


def _truncated(cut_sd=-0.3, seed=5):
    """A correlated 3-D Gaussian posterior with p0 >= mean0 + cut_sd * sd0: the bound cuts
    through the bulk, so the chains reflect off it all the time."""
    post = LinearGaussian(seed=seed)
    sd0 = np.sqrt(post.cov[0, 0])
    a = post.mean[0] + cut_sd * sd0
    return LinearGaussian(seed=seed, lower=[a, -np.inf, -np.inf]), a


def test_recovers_a_gaussian_truncated_through_its_bulk():
    """Reflection at the bound keeps the chain exact: p0 follows the truncated normal and the
    others its linear regression on p0 (E[p_j] = m_j + S_j0/S_00 (E[p0] - m0))."""
    post, a = _truncated()
    s = get_sampler("hmc", post, n_chains=16, seed=2)
    s.prepare(laplace=find_map(post))
    store = _store(post, s.n_chains)
    res = run_sampler(s, store, ess_target=1e9, max_steps=1500, n_adapt=150)
    kept = store.read().chain[res.burn_in:]
    flat = kept.reshape(-1, post.ndim)
    assert flat[:, 0].min() >= a
    m, S = post.mean, post.cov
    sd0 = np.sqrt(S[0, 0])
    tn = stats.truncnorm((a - m[0]) / sd0, np.inf, loc=m[0], scale=sd0)
    mean = m + S[:, 0] / S[0, 0] * (tn.mean() - m[0])
    n_eff = ess(kept)
    assert np.all(n_eff > 2000), n_eff
    sd = np.sqrt(np.diag(S))
    z = (flat.mean(0) - mean) / (sd / np.sqrt(n_eff))
    assert np.all(np.abs(z) < 4.5), z
    np.testing.assert_allclose(flat[:, 0].std(), tn.std(), rtol=0.05)
    # Kolmogorov-Smirnov on a thinned p0 sample against the truncated normal
    thin = flat[:: max(1, int(flat.shape[0] / n_eff[0])), 0]
    assert stats.kstest(thin, tn.cdf).pvalue > 1e-3


def _near_zero(k_sd=1.5, seed=5):
    """The posterior of :func:`_truncated` moved so that p0's mean is ``k_sd`` sd above 0,
    with the bound p0 >= 0: hmc samples p0 in log coordinates (mode more than one sd inside)."""
    post = LinearGaussian(seed=seed, lower=[0.0, -np.inf, -np.inf])
    shift = post.mean[0] - k_sd * np.sqrt(post.cov[0, 0])
    post.y = post.y - post.X[:, 0] * shift
    post.obs = post.y[:, None]
    post.mean = np.linalg.solve(post.X.T @ post.X, post.X.T @ post.y)
    return post


@pytest.mark.parametrize("option, k_sd, kind", [
    ("log_positive", 1.5, 1), ("sqrt_at_zero", -0.5, 2), ("sqrt_shift", -0.5, 2), (None, 1.5, 0),
    (None, -0.5, 0)])
def test_working_coordinates_keep_the_chain_exact(option, k_sd, kind):
    """A parameter bounded at 0 sampled in working coordinates still follows its truncated
    normal (the Jacobian in the target, the metric carried over), and so it does in linear
    ones. Log: mode 1.5 sd inside the bound; without the Jacobian p0 would follow that density
    divided by p0 (mean 10 % lower). Sqrt: mode on the bound (untruncated mean 0.5 sd below
    it); without the Jacobian the density times 1 / (2 sqrt p0) (mean about 40 % lower); with
    hmc's default shift ``c`` of the sqrt (``sqrt_at_zero``) and without it (``sqrt_shift``: c = 0)."""
    post = _near_zero(k_sd=k_sd)
    opts = {"sqrt_shift": {"sqrt_at_zero": True, "sqrt_shift": 0.0}}.get(option, {option: True})
    s = get_sampler("hmc", post, n_chains=16, seed=3, options=opts if option else {})
    s.prepare(laplace=find_map(post))
    assert list(s.tlog) == [kind, 0, 0]
    store = _store(post, s.n_chains)
    res = run_sampler(s, store, ess_target=1e9, max_steps=1200, n_adapt=150)
    kept = store.read().chain[res.burn_in:]
    p0 = kept[..., 0].ravel()
    assert p0.min() >= 0.0
    m0, sd0 = post.mean[0], np.sqrt(post.cov[0, 0])
    tn = stats.truncnorm(-m0 / sd0, np.inf, loc=m0, scale=sd0)
    n_eff = ess(kept)[0]
    assert n_eff > 2000, n_eff
    assert abs(p0.mean() - tn.mean()) < 4.5 * tn.std() / np.sqrt(n_eff)
    np.testing.assert_allclose(p0.std(), tn.std(), rtol=0.06)
    thin = p0[:: max(1, int(p0.size / n_eff))]
    assert stats.kstest(thin, tn.cdf).pvalue > 1e-3


@pytest.mark.parametrize("c", [0.0, 0.04, 0.37])
def test_sqrt_coordinates_metric_and_upper_bound(c):
    """In sqrt coordinates ``w = sqrt(x + c) - sqrt c`` the metric of a variable of exponential
    scale s is the variance of w (checked on draws; (1 - pi/4) s for c = 0), uncorrelated, the
    upper bound maps back inside it, and ``to_w`` inverts ``to_x``."""
    from pavement_mcmc.samplers.coords import SQRT, bounds_w, log_metric, to_w, to_x

    rng = np.random.default_rng(1)
    cov = np.array([[0.37**2, 0.01], [0.01, 0.5]])
    out = log_metric(cov, np.zeros(2), np.array([SQRT, 0]), shift=np.array([c, 0.0]))
    w = np.sqrt(rng.exponential(0.37, 400_000) + c)
    np.testing.assert_allclose(out[0, 0], np.var(w), rtol=0.01)
    if c == 0.0:
        np.testing.assert_allclose(out[0, 0], (1.0 - np.pi / 4.0) * 0.37, rtol=1e-12)
    assert out[0, 1] == out[1, 0] == 0.0 and out[1, 1] == 0.5
    hi = np.array([0.1, 2.0, 3.0, 10.0, 0.7, np.inf])
    kind, shift = np.full(hi.size, SQRT), np.full(hi.size, c)
    lo_w, hi_w = bounds_w(np.zeros(hi.size), hi, kind, shift)
    assert np.all(to_x(hi_w[None], kind, shift)[0] <= hi) and np.all(lo_w == 0.0)
    np.testing.assert_allclose(to_x(hi_w[None], kind, shift)[0][:-1], hi[:-1], rtol=1e-14)
    assert hi_w[-1] == np.inf
    # bounds far below c: back within the rounding of (w + sqrt c)^2 - c, about 1e-16 c
    tiny = np.array([1e-4, 1e-3, 0.01, 3e-7]) * max(c, 1e-300)
    _, hi_t = bounds_w(np.zeros(4), tiny, kind[:4], shift[:4])
    assert np.all(to_x(hi_t[None], kind[:4], shift[:4])[0] <= tiny + 4e-16 * c)
    x = rng.exponential(0.37, (5, hi.size)) * np.logspace(-12, 0, hi.size)
    back = to_x(to_w(x, kind, shift), kind, shift)
    assert np.all(np.abs(back - x) <= 1e-14 * x + 4e-16 * c)


@pytest.mark.parametrize("c", [0.0, 0.3])
def test_working_coordinates_carry_density_and_gradient(c):
    """``in_log`` turns a log-density of x and its gradient into those of w, Jacobian included:
    central differences of ``F(w) = f(x(w)) + log |dx/dw|`` (written out here: w for log,
    log 2(w + sqrt c) for sqrt) match its gradient for linear, log and sqrt coordinates, with
    and without a shift c; without one a sqrt coordinate at or below 0 has density 0 without a
    NaN."""
    from pavement_mcmc.samplers.coords import LOG, SQRT, in_log, to_x

    kind, shift = np.array([0, LOG, SQRT, SQRT]), np.array([0.0, 0.0, c, c])
    a, b = np.array([0.3, -1.2, -0.7, 2.0]), np.array([-0.5, -0.2, -1.5, -0.4])

    def f_and_g(x):
        return np.sum(a * x + b * x * x, axis=1), a + 2.0 * b * x

    def F(w):
        x, r = to_x(w, kind, shift), np.sqrt(c)
        return f_and_g(x)[0] + w[:, 1] + np.log(2.0 * (w[:, 2] + r)) + np.log(2.0 * (w[:, 3] + r))

    w = np.array([[0.4, -0.3, 0.8, 0.05], [-1.1, 0.9, 0.2, 1.7]])
    x = to_x(w, kind, shift)
    np.testing.assert_allclose(x[:, 2:], (w[:, 2:] + np.sqrt(c)) ** 2 - c, rtol=1e-14)
    f, g = in_log(*f_and_g(x), w, x, kind, shift)
    np.testing.assert_allclose(f, F(w), rtol=1e-14)
    fd = np.zeros_like(w)
    for j in range(4):
        e = np.zeros(4)
        e[j] = 1e-6
        fd[:, j] = (F(w + e) - F(w - e)) / 2e-6
    np.testing.assert_allclose(g, fd, rtol=1e-6)
    if c > 0.0:
        return
    w0 = np.array([[0.4, -0.3, 0.0, 0.5], [0.4, -0.3, -0.1, 0.5]])
    with np.errstate(all="raise"):
        f0, g0 = in_log(*f_and_g(to_x(w0, kind)), w0, to_x(w0, kind), kind)
    assert np.all(f0 == -np.inf) and np.all(g0 == 0.0)


def test_sqrt_coordinates_start_half_a_metric_sd_above_zero():
    """Start points of a sqrt coordinate lie at least half its metric sd above 0 (closer, the
    Jacobian's 1/w pull rejects every trajectory): the floor binds for some of 16 chains, which
    |N(0, 1.2^2)| draws would put below it about a third of the time."""
    post = _near_zero(k_sd=-0.5)
    s = get_sampler("hmc", post, n_chains=16, seed=3, options={"sqrt_at_zero": True})
    s.prepare(laplace=find_map(post))
    from pavement_mcmc.samplers.coords import to_w

    floor = 0.5 * np.sqrt(s.M[0, 0])
    assert s.shift[0] > 0.0 and np.all(s.shift[1:] == 0.0)
    w0 = to_w(s.theta[:, s.idx], s.tlog, s.shift)[:, 0]
    assert np.all(w0 >= floor * (1 - 1e-12)), (w0.min(), floor)
    assert np.any(np.isclose(w0, floor, rtol=1e-12))


def test_sqrt_coordinates_resume_bit_for_bit():
    """The coordinate kinds and the sqrt shift are part of hmc's state: a run stopped inside the
    adaptation and resumed with sqrt coordinates gives the uninterrupted run's chain bit for bit."""
    post = _near_zero(k_sd=-0.5)
    a, _, c, A, B = _straight_and_resumed(post, {"sqrt_at_zero": True, "metric_at": 40},
                                          seed=7, n=120, k=35)
    assert list(a.tlog) == [2, 0, 0] == list(c.tlog) and c.shift[0] == a.shift[0] > 0.0
    assert A.chain.shape[0] == 120
    for field in ("chain", "log_prob", "accepted"):
        np.testing.assert_array_equal(getattr(A, field), getattr(B, field))


def test_log_metric_delta_method_and_exponential_at_the_bound():
    """Carried to log coordinates, the covariance of a variable with small relative spread is
    cov / (x x) (checked on draws of a near-Gaussian pair), and that of a variable on the bound
    0 is pi^2/6: the variance of the log of an exponential draw, whatever its scale."""
    from pavement_mcmc.samplers.coords import log_metric

    rng = np.random.default_rng(0)
    x = np.array([5.0, 0.0, 2.0])
    cov = np.array([[0.04, 0.0, 0.01], [0.0, 0.3, 0.0], [0.01, 0.0, 0.0225]])
    out = log_metric(cov, x, np.array([True, True, False]))
    draws = rng.multivariate_normal(x[[0, 2]], cov[np.ix_([0, 2], [0, 2])], size=400_000)
    np.testing.assert_allclose(out[0, 0], np.var(np.log(draws[:, 0])), rtol=0.01)
    np.testing.assert_allclose(out[0, 2], np.cov(np.log(draws[:, 0]), draws[:, 1])[0, 1], rtol=0.02)
    assert out[2, 2] == cov[2, 2]
    e = rng.exponential(0.37, size=400_000)
    np.testing.assert_allclose(out[1, 1], np.var(np.log(e)), rtol=0.01)
    assert out[1, 0] == out[1, 2] == 0.0


def test_log_coordinates_never_step_over_a_finite_upper_bound():
    """The upper bound in log coordinates maps back inside the bound (exp(log 3) > 3 in
    floating point: a chain reflected there would have left the support)."""
    from pavement_mcmc.samplers.coords import bounds_w, to_x

    hi = np.array([0.1, 2.0, 3.0, 10.0, 100.0, 500.0, np.inf, 7.0])
    tlog = np.array([True] * 7 + [False])
    assert np.any(np.exp(np.log(hi[:6])) > hi[:6])  # the rounding the bound must avoid
    lo_w, hi_w = bounds_w(np.zeros(8), hi, tlog)
    assert np.all(to_x(hi_w[None], tlog)[0] <= hi)
    assert np.all(lo_w[:7] == np.log(1e-300)) and lo_w[7] == 0.0 and hi_w[6] == np.inf
    assert hi_w[7] == 7.0
    np.testing.assert_allclose(np.exp(hi_w[:6]), hi[:6], rtol=1e-15)


def test_log_coordinates_keep_every_point_inside_the_bounds_positive():
    """Every position inside the working bounds of a log coordinate maps to x > 0. With a lower
    bound of -inf a divergent leapfrog (w about -800 on a daily desert window, where only kappa/C
    is measured) underflowed to x = 0 and the solver's "kappa and C must be positive" ended the
    fit (6 of 30 July days, runs/desert_daily.toml without upper bounds)."""
    from pavement_mcmc.samplers.coords import LOG, bounds_w, to_w, to_x

    kind = np.array([LOG, LOG])
    lo_w, hi_w = bounds_w(np.zeros(2), np.array([3.0, np.inf]), kind)
    w = np.array([[lo_w[0], lo_w[1]], [-800.0, -2000.0], [0.5, 700.0]])
    inside = np.clip(w, lo_w, hi_w)
    x = to_x(inside, kind)
    assert np.all(x > 0.0) and np.all(np.isfinite(x))
    np.testing.assert_allclose(to_w(x, kind)[:1], inside[:1], rtol=1e-12)


def _central_grad(post, theta, rel=1e-6):
    """Central differences of the log-likelihood through the posterior's own residual path."""
    def ll(th):
        return post.log_likelihood_from_residuals(post.residuals(th))

    out = np.zeros_like(theta)
    for j in range(theta.shape[1]):
        e = rel * np.maximum(np.abs(theta[:, j]), 1e-3)
        tp, tm = theta.copy(), theta.copy()
        tp[:, j] += e
        tm[:, j] -= e
        out[:, j] = (ll(tp) - ll(tm)) / (2 * e)
    return ll(theta), out


@pytest.mark.parametrize("case, noisy", [("caseC", False), ("caseA", True)])
def test_adjoint_loglik_gradient_matches_finite_differences(case, noisy):
    """LogPosterior.loglik_and_grad by the solver's adjoint: the log-likelihood of the plain
    path and its central differences, for Case C (114 parameters, gamma's column 0) and for
    Case A with the inputs' noise integrated out (whitened residuals)."""
    from conftest import REPO

    from pavement_mcmc.data import load_case
    from pavement_mcmc.posterior import attach_input_noise, build_problem

    pr = build_problem(load_case(REPO / "runs" / f"{case}.toml"))
    post = pr.posterior
    rng = np.random.default_rng(1)
    theta = post.space.initial() * (1 + 0.05 * rng.standard_normal((3, post.ndim)))
    theta[:, post.space.free.index("kappa")] = [1.2, 1.4, 1.6]
    if noisy:
        attach_input_noise(post, 0.25, theta_ref=theta[0])
    assert post.has_gradient
    ll, g, blobs = post.loglik_and_grad(theta)
    ll_ref, g_ref = _central_grad(post, theta)
    np.testing.assert_allclose(ll, ll_ref, rtol=1e-12)
    scale = np.abs(g_ref).max(axis=1, keepdims=True)
    np.testing.assert_allclose(g, g_ref, rtol=0, atol=2e-5 * scale.max())
    if "gamma" in post.space.free:
        assert np.all(g[:, post.space.free.index("gamma")] == 0.0)
    np.testing.assert_allclose(blobs, post(theta)[1], rtol=1e-12)


def test_models_without_adjoint_fall_back_to_finite_differences():
    from conftest import REPO

    from pavement_mcmc.data import load_case
    from pavement_mcmc.posterior import build_problem

    pr = build_problem(load_case(REPO / "runs" / "caseA.toml"), extensions=["conductivity_temperature"])
    post = pr.posterior
    assert not post.has_gradient
    theta = post.space.initial()[None]
    with pytest.raises(NotImplementedError):
        post.loglik_and_grad(theta, "adjoint")
    ll, g, _ = post.loglik_and_grad(theta)  # auto: central differences
    ll_ref, g_ref = _central_grad(post, theta)
    np.testing.assert_allclose(ll, ll_ref, rtol=1e-12)
    np.testing.assert_allclose(g, g_ref, rtol=1e-3, atol=1e-4 * np.abs(g_ref).max())


@pytest.mark.parametrize("windows, adapt", [(1, True), (2, True), (2, False)])
def test_metric_windows_replace_a_wrong_laplace_metric(windows, adapt, monkeypatch):
    """Started from a metric 10x too wide in sd with the correlations dropped, the pooled
    adaptation windows (steps 10-50, then 50-100) bring L L^T to the target's covariance
    (relative error < 0.2 of sd_i sd_j); without metric adaptation it stays ~100x off.
    The start-metric guard is off here: its conditional sds are 11-13x the target's, and the
    guard would narrow them first (then 1 / 2 / 3 windows leave 0.20 / 0.13 / 0.088, against
    0.12 / 0.18 / 0.089 from the unnarrowed metric)."""
    from pavement_mcmc.samplers import metric_guard

    monkeypatch.setattr(metric_guard, "RATIO", np.inf)
    post = LinearGaussian(seed=3, d=6)
    lap = find_map(post)
    wrong = dataclasses.replace(lap, cov=100.0 * np.diag(np.diag(lap.cov)))
    s = get_sampler("hmc", post, n_chains=16, seed=4,
                    options={"metric_windows": windows, "adapt_metric": adapt})
    s.prepare(laplace=wrong)
    for _ in range(6):
        s.step(25, adapt=True)
    assert s.n_metric == (windows if adapt else 0)
    sd = np.sqrt(np.diag(post.cov))
    err = np.abs(s.L @ s.L.T - post.cov) / np.outer(sd, sd)
    assert (err.max() < 0.2) if adapt else (err.max() > 50), err.max()


def test_proposals_piling_up_at_a_bound_are_rejected_not_raised(monkeypatch):
    """A trajectory that keeps reflecting (a refit parameter piling up at its bound) used to
    raise "more than 1000 reflections" mid-run; now that chain's proposal is rejected."""
    from pavement_mcmc.samplers import hmc

    monkeypatch.setattr(hmc, "_MAX_REFLECTIONS", 0)  # every bound hit counts as stuck
    post, a = _truncated(cut_sd=0.5)
    s = get_sampler("hmc", post, n_chains=8, seed=4)
    s.prepare(laplace=find_map(post))
    store = _store(post, s.n_chains)
    run_sampler(s, store, ess_target=1e9, max_steps=200, n_adapt=50)
    data = store.read()
    assert np.all(np.isfinite(data.chain)) and data.chain[..., 0].min() >= a
    assert 0.0 < data.accepted.mean() < 1.0


def test_a_laplace_precision_that_is_not_positive_definite_is_regularised_with_a_note():
    """``fit --add sensor_depth`` on a 3-piece case raised "Matrix is not positive definite"
    when drawing the chains' starts from the Laplace approximation."""
    from pavement_mcmc.posterior.map import regularised_inverse

    post = LinearGaussian(seed=3)
    lap = find_map(post)
    k = lap.idx.size
    bad = np.ones((k, k)) - 1e-3 * np.eye(k)  # indefinite (an offset at its bound, round-off)
    cov, note = regularised_inverse(bad)
    assert "not positive definite" in note and np.all(np.linalg.eigvalsh(cov) > 0)
    assert regularised_inverse(np.eye(k))[1] == ""
    lap.cov_z = bad  # what the old inverse could hand to the start draws
    draws = lap.draw(np.random.default_rng(0), 50)
    assert np.all(np.isfinite(draws))


def _reference_drift(x, p, L, lo, hi, eps):
    """The reflecting drift written plainly, one chain and one reflection at a time."""
    x, p = x.copy(), p.copy()
    for c in range(x.shape[0]):
        t_left = eps[c]
        while True:
            v = L @ p[c]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = np.where(v < 0, np.maximum((lo - x[c]) / v, 0), np.inf)
                t = np.minimum(t, np.where(v > 0, np.maximum((hi - x[c]) / v, 0), np.inf))
            k = int(np.argmin(t))
            if t[k] >= t_left:
                x[c] = x[c] + t_left * v
                break
            x[c] = x[c] + t[k] * v
            x[c, k] = lo[k] if v[k] < 0 else hi[k]
            t_left -= t[k]
            n = L[k]
            p[c] = p[c] - 2 * (p[c] @ n) / (n @ n) * n
    return x, p


def test_compiled_reflecting_drift_matches_the_plain_one_and_is_reversible():
    """Many reflections in a narrow box with a correlated metric: the compiled drift gives the
    plain algorithm's positions and momenta, stays inside the box, keeps |p| (specular
    reflection), and drifting back with -p returns to the start (reversibility, which the
    Metropolis test needs)."""
    from pavement_mcmc.samplers.reflect import reflect_drift

    rng = np.random.default_rng(7)
    m, d = 12, 9
    A = rng.standard_normal((d, d))
    L = np.linalg.cholesky(A @ A.T / d + 0.2 * np.eye(d))
    lo, hi = -0.5 * np.ones(d), np.r_[0.4 * np.ones(d - 2), np.inf, np.inf]
    lo[0] = -np.inf
    x0 = rng.uniform(-0.4, 0.3, (m, d))
    p0 = rng.standard_normal((m, d))
    eps = rng.uniform(1.0, 3.0, m)  # long flights: tens of reflections each
    x, p = x0.copy(), p0.copy()
    stuck = reflect_drift(x, p, p @ L.T, L, L @ L.T, lo, hi, eps, 10_000)
    xr, pr = _reference_drift(x0, p0, L, lo, hi, eps)
    assert not stuck.any()
    np.testing.assert_allclose(x, xr, atol=1e-9)
    np.testing.assert_allclose(p, pr, atol=1e-9)
    assert np.all((x >= lo) & (x <= hi))
    np.testing.assert_allclose(np.sum(p * p, 1), np.sum(p0 * p0, 1), rtol=1e-10)
    assert np.any(np.abs(p - p0) > 0.1)  # it did reflect
    xb, pb = x.copy(), -p
    reflect_drift(xb, pb, pb @ L.T, L, L @ L.T, lo, hi, eps, 10_000)
    np.testing.assert_allclose(xb, x0, atol=1e-8)
    np.testing.assert_allclose(-pb, p0, atol=1e-8)
    few = reflect_drift(x0.copy(), p0.copy(), p0 @ L.T, L, L @ L.T, lo, hi, eps, 2)
    assert few.all()  # more than two reflections each: all stuck


def test_laplace_metric_at_a_bound_takes_the_exponential_scale():
    """A Gaussian whose mass lies far below the bound p0 >= a (a = mean + 4 sd), given its
    exact Laplace approximation at the constrained mode: the posterior of p0 is ~exponential
    of scale S00 / (a - m0), 4.4x narrower than the curvature's sd, which the start metric
    used to take. Now the metric's sd of p0 is the truncated posterior's within 25 % (the other
    coordinates' regression on it: tests/samplers/test_hmc_bound_metric.py)."""
    post, a = _truncated(cut_sd=4.0)
    m, S = post.mean, post.cov
    mode = m + S[:, 0] / S[0, 0] * (a - m[0])  # the mode on the bound p0 = a
    lap = dataclasses.replace(find_map(post), theta=mode, cov=S.copy())
    s = get_sampler("hmc", post, n_chains=8, seed=1)
    s.prepare(laplace=lap)
    M = s.L @ s.L.T
    sd0 = np.sqrt(S[0, 0])
    tn = stats.truncnorm((a - m[0]) / sd0, np.inf, loc=m[0], scale=sd0)
    assert sd0 / tn.std() > 4  # the curvature's sd, the metric before
    assert abs(np.sqrt(M[0, 0]) / tn.std() - 1) < 0.25, (np.sqrt(M[0, 0]), tn.std())


def test_the_adaptation_lasts_until_the_last_metric_window_and_50_steps_after():
    """With three metric windows (ends at steps 50, 100, 200) the loop's default adaptation is
    250 steps; it was a fixed 150, so the third window was never reached."""
    post = LinearGaussian(seed=3, d=4)
    s = get_sampler("hmc", post, n_chains=8, seed=1, options={"metric_windows": 3})
    assert s.adapt_length() == 250
    assert get_sampler("hmc", post, n_chains=8, seed=1).adapt_length() == 150
    s.prepare(laplace=find_map(post))
    res = run_sampler(s, _store(post, s.n_chains), ess_target=1e9, max_steps=260)
    assert res.n_adapt_rows == 250 and s.n_metric == 3


def test_negative_sqrt_shift_is_refused():
    """A negative shift would make sqrt(x + c) NaN near 0: refused when the sampler is made."""
    with pytest.raises(ValueError, match="sqrt_shift must be >= 0, got -0.1"):
        get_sampler("hmc", _near_zero(k_sd=-0.5), options={"sqrt_at_zero": True, "sqrt_shift": -0.1})


class _ColumnMajorGradient(LinearGaussian):
    """The toy posterior with its gradient in column-major memory, as the adjoint sweep of
    :class:`~pavement_mcmc.posterior.LogPosterior` returns it (Case C)."""

    def loglik_and_grad(self, theta):
        ll, g, bl = super().loglik_and_grad(theta)
        return ll, np.asfortranarray(g), bl


def test_resume_keeps_the_gradient_layout_and_the_chain_bit_for_bit():
    """Issue 24: a resumed Case C fit left the uninterrupted one 16 steps after the restart.
    The restored gradient was row-major while the running sampler's stays column-major, and
    ``g @ L`` sums in another order for another layout (BLAS). The restored sampler keeps the
    layout, and the run continues bit for bit after the adaptation."""
    post = _ColumnMajorGradient(seed=3, d=60, n=120)
    a, b, c, A, B = _straight_and_resumed(post, {"metric_at": 20}, seed=11, n=200, k=80)
    assert c.g.strides == b.g.strides == a.g.strides
    assert A.chain.shape[0] == 200
    for field in ("chain", "log_prob", "accepted"):
        np.testing.assert_array_equal(getattr(A, field), getattr(B, field))
