"""Samplers against a known Gaussian target; exact resume; the gamma Gibbs draw."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, stats

from pavement_mcmc.parameters import Flat, GMRFSmoothness, Parameter, ParameterSpace, Rayleigh
from pavement_mcmc.runs import run_sampler
from pavement_mcmc.samplers import SAMPLERS, get_sampler, sampler_names
from pavement_mcmc.samplers.hmc_options import HMCOptions
from pavement_mcmc.storage import MemoryStore


class LinearGaussian:
    """Posterior of a linear model y = X theta + e, e ~ N(0, sigma^2), flat priors: exactly
    N(theta_hat, sigma^2 (X^T X)^-1). Mimics LogPosterior's interface (residuals, obs, blobs)."""

    def __init__(self, seed=0, d=3, n=40, lower=None):
        rng = np.random.default_rng(seed)
        self.X = rng.normal(size=(n, d)) + 0.8 * rng.normal(size=(n, 1))  # correlated columns
        self.sigma = 0.5
        truth = np.linspace(3.0, 6.0, d)
        self.y = self.X @ truth + self.sigma * rng.normal(size=n)
        self.obs = self.y[:, None]
        lo = lower if lower is not None else [-np.inf] * d
        self.space = ParameterSpace([Parameter(f"p{i}", float(truth[i]) + 0.3, lo[i], np.inf,
                                               prior=Flat()) for i in range(d)])
        self.ndim = d
        self.blob_names = ["rmse"]
        XtX = self.X.T @ self.X
        self.mean = np.linalg.solve(XtX, self.X.T @ self.y)
        self.cov = self.sigma**2 * np.linalg.inv(XtX)

    def residuals(self, theta):
        return (np.atleast_2d(theta) @ self.X.T - self.y)[:, :, None]

    def standardized_residuals(self, r):
        return r.reshape(*r.shape[:-2], -1) / self.sigma

    def whitened(self, theta):
        return self.standardized_residuals(self.residuals(theta))

    def loglik_and_grad(self, theta):
        theta = np.atleast_2d(theta)
        r = theta @ self.X.T - self.y
        ll = -0.5 * np.sum((r / self.sigma) ** 2, axis=1)
        return ll, -(r @ self.X) / self.sigma**2, np.sqrt(np.mean(r * r, 1))[:, None]

    def __call__(self, theta):
        theta = np.atleast_2d(theta)
        lp = self.space.log_prior(theta)
        r = self.residuals(theta)[:, :, 0]
        ll = -0.5 * np.sum((r / self.sigma) ** 2, axis=1)
        return np.where(np.isfinite(lp), lp + ll, -np.inf), np.sqrt(np.mean(r * r, 1))[:, None]


def _store(post, n_chains):
    return MemoryStore.create(post.space.free, post.blob_names, n_chains, {"sampler": "test"})


def _prepared(kind, post, seed=1):
    from pavement_mcmc.posterior import find_map

    s = get_sampler(kind, post, seed=seed)
    s.prepare(laplace=find_map(post))
    return s


def test_registry_and_unknown_name():
    assert sampler_names() == sorted(SAMPLERS) == ["emcee", "fast", "hmc", "mh"]
    with pytest.raises(ValueError, match="valid: emcee, fast, hmc, mh"):
        get_sampler("nuts", LinearGaussian())


@pytest.mark.parametrize("kind,steps", [("fast", 400), ("mh", 3000), ("emcee", 1500)])
def test_recovers_gaussian_mean_and_covariance(kind, steps):
    post = LinearGaussian(lower=[0.0, -np.inf, 0.0])  # exercises the log coordinates of `fast`
    s = _prepared(kind, post)
    store = _store(post, s.n_chains)
    res = run_sampler(s, store, ess_target=1e9, max_steps=steps, n_adapt=min(500, steps // 4))
    assert not res.converged and "step budget" in res.reason
    data = store.read()
    kept = data.chain[res.burn_in:]
    flat = kept.reshape(-1, post.ndim)
    sd = np.sqrt(np.diag(post.cov))
    from pavement_mcmc.diagnostics import ess

    n_eff = ess(kept)
    assert np.all(n_eff > 300), n_eff
    # mean within 5 Monte Carlo standard errors, sd within 10 %, correlations within 0.1
    assert np.all(np.abs(flat.mean(0) - post.mean) < 5 * sd / np.sqrt(n_eff))
    np.testing.assert_allclose(flat.std(0), sd, rtol=0.1)
    corr = np.corrcoef(flat.T)
    np.testing.assert_allclose(corr, post.cov / np.outer(sd, sd), atol=0.1)


@pytest.mark.parametrize("kind", ["fast", "mh", "emcee", "hmc"])
def test_resume_is_bit_for_bit(kind):
    post = LinearGaussian(seed=3)
    n = 120
    a = _prepared(kind, post, seed=7)
    st_a = _store(post, a.n_chains)
    run_sampler(a, st_a, ess_target=1e9, max_steps=n, n_adapt=50)

    b = _prepared(kind, post, seed=7)
    st_b = _store(post, b.n_chains)
    run_sampler(b, st_b, ess_target=1e9, max_steps=n // 2 + 10, n_adapt=50)  # crosses adaptation end
    c = get_sampler(kind, post)  # a fresh object, as after a crash
    c.set_state(st_b.state)
    st_c = MemoryStore.open_append(st_b)
    run_sampler(c, st_c, ess_target=1e9, max_steps=n, n_adapt=50)
    A, B = st_a.read(), st_c.read()
    assert A.chain.shape == B.chain.shape == (n, a.n_chains, post.ndim)
    for field in ("chain", "log_prob", "blobs", "accepted"):
        np.testing.assert_array_equal(getattr(A, field), getattr(B, field))


@pytest.mark.parametrize("kind", ["fast", "emcee", "hmc"])
def test_stopping_point_does_not_depend_on_block_timing(kind):
    """Checks run at fixed step counts: with blocks of very different wall-clock length the
    run stops at the same step with the same chain (the stopping rule on a real target)."""
    post = LinearGaussian(seed=4)
    out = []
    for block_seconds in (1e-4, 5.0):
        s = _prepared(kind, post, seed=11)
        st = _store(post, s.n_chains)
        res = run_sampler(s, st, ess_target=300, max_steps=20_000, n_adapt=50,
                          block_seconds=block_seconds)
        assert res.converged, res.reason
        out.append((res.n_steps, st.read().chain))
    assert out[0][0] == out[1][0]
    np.testing.assert_array_equal(out[0][1], out[1][1])


def test_gamma_gibbs_draw_is_exact():
    """The rejection draw of gamma | h matches its density gamma^{(N+1)/2} exp(-g S/2 - (g/g0)^2/2)."""
    N, g0 = 20, 2.22
    names = [f"h_{i}" for i in range(N)]
    params = [Parameter("gamma", 1.0, 0.0, 1e4, prior=Rayleigh(g0))]
    params += [Parameter(n, 10.0, 0.0, 500.0, prior=Flat(), group="h") for n in names]
    space = ParameterSpace(params, [GMRFSmoothness(tuple(names), "gamma")])

    from pavement_mcmc.samplers.gamma import draw_gamma

    h = 10 + np.cumsum(np.random.default_rng(0).normal(0, 0.6, N))
    theta = np.tile(np.r_[1.0, h], (4000, 1))
    draws = draw_gamma(np.random.default_rng(5), space, theta, 0, np.arange(1, N + 1))
    S = np.sum(np.diff(h) ** 2)

    def dens(g):
        return g ** ((N + 1) / 2) * np.exp(-0.5 * g * S - 0.5 * (g / g0) ** 2)

    Z = integrate.quad(dens, 0, np.inf)[0]

    def cdf(x):
        return np.array([integrate.quad(dens, 0, v)[0] / Z for v in np.atleast_1d(x)])

    assert stats.kstest(draws, cdf).pvalue > 0.01


# ----------------------------------------------------------------------------- gamma integrated out


def test_marginal_gmrf_table_matches_quadrature():
    """The tabulated log F(S) = log int g^{(N-1)/2} e^{-g S/2} pi(g) dg agrees with adaptive
    quadrature to 1e-6 over 18 decades of S, and its moments with E[g], Var[g] by quadrature."""
    from pavement_mcmc.posterior.marginal import MarginalGMRF

    g0 = 2.22
    tab = MarginalGMRF(112, Rayleigh(g0), 0.0, 1e4)
    S = np.exp(np.linspace(np.log(1e-7), np.log(1e11), 41))
    direct = np.array([tab.direct(s) for s in S])
    np.testing.assert_allclose(tab.log_f(S), direct, rtol=0, atol=1e-6)
    # independently, in gamma itself (dense trapezoid): g^{(N+1)/2} e^{-gS/2 - g^2/(2 g0^2)} / g0^2
    s, a = 40.0, 0.5 * (112 + 1)
    g = np.linspace(1e-9, 30.0, 3_000_001)
    f = np.exp(a * np.log(g) - 0.5 * g * s - 0.5 * (g / g0) ** 2 - 2 * np.log(g0) - 20.0)
    Z = np.trapezoid(f, g)
    assert abs(tab.log_f(s) - (np.log(Z) + 20.0)) < 1e-6
    m1 = np.trapezoid(g * f, g) / Z
    np.testing.assert_allclose(tab.mean_gamma(s), m1, rtol=1e-6)


class ToyGMRF:
    """y_i = h_i + e_i, e ~ N(0, sigma^2), i = 1..N, with the GMRF prior h | gamma and a
    Rayleigh(g0) hyperprior: h | gamma, y is Gaussian, so the joint posterior's moments follow
    from 1-D quadrature over gamma. Mimics LogPosterior's interface."""

    def __init__(self, N=10, sigma=1.0, g0=2.22, seed=0):
        rng = np.random.default_rng(seed)
        self.N, self.sigma, self.g0 = N, sigma, g0
        self.y = 10 + np.cumsum(rng.normal(0, 0.7, N)) + sigma * rng.normal(size=N)
        self.obs = self.y[:, None]
        names = [f"h_{i}" for i in range(N)]
        params = [Parameter("gamma", 1.0, 0.0, 1e4, prior=Rayleigh(g0))]
        params += [Parameter(n, 10.0, 0.0, 500.0, prior=Flat(), group="h") for n in names]
        self.space = ParameterSpace(params, [GMRFSmoothness(tuple(names), "gamma")])
        self.ndim = N + 1
        self.blob_names = ["rmse"]
        self.n_data = N

    def residuals(self, theta):
        return (np.atleast_2d(theta)[:, 1:] - self.y)[:, :, None]

    def standardized_residuals(self, r):
        return r.reshape(*r.shape[:-2], -1) / self.sigma

    def whitened(self, theta):
        return self.standardized_residuals(self.residuals(theta))

    def log_likelihood_from_residuals(self, r):
        return -0.5 * np.sum((r / self.sigma) ** 2, axis=(-2, -1))

    def loglik_and_grad(self, theta):
        theta = np.atleast_2d(theta)
        r = theta[:, 1:] - self.y
        g = np.zeros_like(theta)
        g[:, 1:] = -r / self.sigma**2
        return (-0.5 * np.sum((r / self.sigma) ** 2, axis=1), g,
                np.sqrt(np.mean(r * r, 1))[:, None])

    def __call__(self, theta):
        theta = np.atleast_2d(theta)
        lp = self.space.log_prior(theta)
        r = self.residuals(theta)
        ll = self.log_likelihood_from_residuals(r)
        return (np.where(np.isfinite(lp), lp + ll, -np.inf),
                np.sqrt(np.mean(r[:, :, 0] ** 2, 1))[:, None])

    def exact_moments(self):
        """E[gamma], sd[gamma], E[h], sd[h] by quadrature over gamma (h >= 0 negligible)."""
        N, s2 = self.N, self.sigma**2
        D = np.diff(np.eye(N), axis=0)
        g = np.exp(np.linspace(np.log(1e-4), np.log(1e3), 6000))
        logw, means, vars_ = [], [], []
        for gi in g:
            P = np.eye(N) / s2 + gi * D.T @ D
            cov = np.linalg.inv(P)
            m = cov @ self.y / s2
            _, logdet = np.linalg.slogdet(P)
            lw = (0.5 * (N - 1) * np.log(gi) - 0.5 * logdet - 0.5 * (self.y @ self.y / s2 - m @ P @ m)
                  + np.log(gi) - 0.5 * (gi / self.g0) ** 2)
            logw.append(lw + np.log(gi))  # d gamma = gamma d log gamma
            means.append(m)
            vars_.append(np.diag(cov))
        w = np.exp(np.array(logw) - max(logw))
        w /= w.sum()
        means, vars_ = np.array(means), np.array(vars_)
        Eg = w @ g
        Eh = w @ means
        Vh = w @ (vars_ + means**2) - Eh**2
        return Eg, np.sqrt(w @ g**2 - Eg**2), Eh, np.sqrt(Vh)


@pytest.mark.parametrize("kind, move, opts, steps", [
    ("fast", "rw", {}, 6000), ("fast", "block", {}, 6000),
    ("fast", "block", {"block_kind": "independence"}, 6000), ("hmc", None, {}, 800),
    ("hmc", None, {"log_positive": True}, 800), ("hmc", None, {"rough_moves": 4}, 800)])
def test_gamma_marginalised_sampler_matches_quadrature(kind, move, opts, steps):
    """`fast` with gamma integrated out (random walk on h, exact gamma draw), the block move
    (gamma/h joint moves + pCN) and `hmc` (Hamiltonian moves on h with gamma integrated out,
    exact gamma draw; also with h moved as log h, and with the rough-scale moves of h's
    high-frequency part) reproduce the joint posterior's gamma and h
    means and sds of a small GMRF toy within Monte Carlo error."""
    post = ToyGMRF()
    options = {"move": {"kind": move, **opts}} if kind == "fast" else opts
    s = get_sampler(kind, post, n_chains=32 if kind == "fast" else 16, seed=4, options=options)
    s.prepare()
    assert s.move.name == move if kind == "fast" else s.marginal
    if kind == "hmc":
        assert s.tlog.all() == ("log_positive" in opts)
        assert (s.rough is not None) == (opts.get("rough_moves", HMCOptions().rough_moves) > 0)
    store = _store(post, s.n_chains)
    res = run_sampler(s, store, ess_target=1e9, max_steps=steps, n_adapt=steps // 8)
    kept = store.read().chain[res.burn_in:]
    flat = kept.reshape(-1, post.ndim)
    from pavement_mcmc.diagnostics import ess

    n_eff = ess(kept)
    assert np.all(n_eff > 1000), n_eff
    Eg, sg, Eh, sh = post.exact_moments()
    mean, sd = np.r_[Eg, Eh], np.r_[sg, sh]
    z = (flat.mean(0) - mean) / (sd / np.sqrt(n_eff))
    assert np.all(np.abs(z) < 4.5), z
    np.testing.assert_allclose(flat.std(0), sd, rtol=0.08)
    # the stored log-posterior is the joint one at (h, gamma)
    d = store.read()
    np.testing.assert_allclose(d.log_prob[-1], post(d.chain[-1])[0], rtol=0, atol=1e-8)


@pytest.mark.parametrize("kind, move", [("fast", "rw"), ("fast", "block"), ("hmc", None),
                                        ("hmc", "log"), ("hmc", "rough")])
def test_gamma_marginalised_resume_is_bit_for_bit(kind, move):
    post = ToyGMRF(seed=2)
    n = 120

    opts = ({"move": {"kind": move, "first_window": 20}} if move == "rw" else {"move": move}) \
        if kind == "fast" else {"metric_at": 40, "log_positive": move == "log",
                                "rough_moves": 2 if move == "rough" else 0}

    def prep():
        s = get_sampler(kind, post, n_chains=16, seed=7, options=opts)
        s.prepare()
        return s

    a = prep()
    st_a = _store(post, a.n_chains)
    run_sampler(a, st_a, ess_target=1e9, max_steps=n, n_adapt=50)
    b = prep()
    st_b = _store(post, b.n_chains)
    run_sampler(b, st_b, ess_target=1e9, max_steps=n // 2 - 25, n_adapt=50)  # inside adaptation
    c = get_sampler(kind, post, options=opts)
    c.set_state(st_b.state)
    st_c = MemoryStore.open_append(st_b)
    run_sampler(c, st_c, ess_target=1e9, max_steps=n, n_adapt=50)
    A, B = st_a.read(), st_c.read()
    for field in ("chain", "log_prob", "blobs", "accepted"):
        np.testing.assert_array_equal(getattr(A, field), getattr(B, field))


def test_hmc_resumes_a_state_saved_before_log_coordinates():
    """A run folder written before ``log_positive`` existed has no ``tlog`` in its hmc state:
    it resumes with every coordinate linear, bit for bit as the uninterrupted run."""
    post = ToyGMRF(seed=2)

    def prep():
        s = get_sampler("hmc", post, n_chains=16, seed=7, options={"metric_at": 40})
        s.prepare()
        return s

    a = prep()
    st_a = _store(post, a.n_chains)
    run_sampler(a, st_a, ess_target=1e9, max_steps=100, n_adapt=50)
    b = prep()
    st_b = _store(post, b.n_chains)
    run_sampler(b, st_b, ess_target=1e9, max_steps=60, n_adapt=50)
    state = st_b.state
    del state.arrays["tlog"]
    c = get_sampler("hmc", post, options={"metric_at": 40})
    c.set_state(state)
    assert not c.tlog.any()
    st_c = MemoryStore.open_append(st_b)
    run_sampler(c, st_c, ess_target=1e9, max_steps=100, n_adapt=50)
    np.testing.assert_array_equal(st_a.read().chain, st_c.read().chain)


@pytest.mark.parametrize("laplace_em", [False, True])
def test_marginal_map_is_the_em_fixed_point(laplace_em):
    """find_marginal_map on the GMRF toy: at the plug-in fixed point (laplace_em=False) the
    gradient of the gamma-marginal log-posterior, -(h - y)/s^2 - E[gamma | S] D^T D h, vanishes;
    with the Laplace-corrected roughness the returned gamma is E[gamma | S_eff]. The Aitken jumps
    get there in far fewer EM steps than the plain iteration (which needs ~30 on Case C)."""
    from pavement_mcmc.posterior.marginal import MarginalGMRF, find_marginal_map

    post = ToyGMRF(N=30, seed=5)
    tab = MarginalGMRF(post.N, Rayleigh(post.g0), 0.0, 1e4)
    mm = find_marginal_map(post, tab, laplace_em=laplace_em, em_tol=1e-8)
    h, g = mm.theta[1:], mm.theta[0]
    D = np.diff(np.eye(post.N), axis=0)
    S = float(np.sum(np.diff(h) ** 2))
    assert len(mm.history) < 20, len(mm.history)
    if not laplace_em:
        grad = -(h - post.y) / post.sigma**2 - float(tab.mean_gamma(S)) * D.T @ D @ h
        assert np.abs(grad).max() < 1e-5 * np.abs(h - post.y).max() / post.sigma**2
        np.testing.assert_allclose(g, tab.mean_gamma(S), rtol=1e-6)
    else:
        cov = np.linalg.inv(np.eye(post.N) / post.sigma**2 + g * D.T @ D)
        S_eff = S + np.trace(D @ cov @ D.T)
        np.testing.assert_allclose(g, tab.mean_gamma(S_eff), rtol=1e-5)


# -- typed options, moves as objects, samplers by module:Class ---------------------------------

def test_options_are_typed_and_unknown_keys_are_refused():
    post = LinearGaussian()
    s = get_sampler("hmc", post, options={"trajectory_length": 2, "metric_at": 40})
    assert s.options.trajectory_length == 2.0 and s.options.metric_at == 40
    with pytest.raises(ValueError, match=r"unknown option 'trajectroy_length' \(did you mean "
                                         r"'trajectory_length'\?\); valid options: target_acceptance"):
        get_sampler("hmc", post, options={"trajectroy_length": 1.0})
    with pytest.raises(ValueError, match="option 'max_leapfrog' must be int, got 'many'"):
        get_sampler("hmc", post, options={"max_leapfrog": "many"})
    with pytest.raises(ValueError, match="unknown option 'beta'.*valid options: target_acceptance, "
                                         "proposal_scale"):
        get_sampler("mh", post, options={"beta": 0.3})
    with pytest.raises(ValueError, match="move 'rw' needs a case with a free smoothness precision"):
        get_sampler("fast", post, options={"move": "rw"})
    with pytest.raises(ValueError, match="unknown option 'block_prb'"):
        get_sampler("fast", ToyGMRF(), options={"move": {"kind": "block", "block_prb": 0.3}})


def test_a_move_object_can_be_passed_and_written():
    from pavement_mcmc.samplers import BlockGMRF, LaplacePCN

    post = ToyGMRF()
    s = get_sampler("fast", post, n_chains=8, seed=1, options={"move": BlockGMRF(block_prob=0.2)})
    assert s.move.block_prob == 0.2 and s.move.name == "block"

    class Halved(LaplacePCN):  # a user's move: the pCN move with half the initial step
        def prepare(self, sampler, theta0=None, laplace=None):
            super().prepare(sampler, theta0, laplace)
            self.beta *= 0.5

    lin = LinearGaussian()
    s = get_sampler("fast", lin, n_chains=8, seed=1, options={"move": Halved()})
    s.prepare()
    ref = get_sampler("fast", lin, n_chains=8, seed=1)
    ref.prepare()
    assert s.move.beta == pytest.approx(0.5 * ref.move.beta)


def test_a_sampler_is_registered_by_module_path(monkeypatch):
    import sys
    import types

    from pavement_mcmc.samplers import MHSampler, sampler_class

    class Mine(MHSampler):
        name = "mine"

    mod = types.ModuleType("my_samplers")
    mod.Mine = Mine
    monkeypatch.setitem(sys.modules, "my_samplers", mod)
    assert sampler_class("my_samplers:Mine") is Mine
    s = get_sampler("my_samplers:Mine", LinearGaussian(), options={"target_acceptance": 0.3})
    assert isinstance(s, Mine) and s.options.target_acceptance == 0.3
    with pytest.raises(ValueError, match="cannot import sampler 'my_samplers:Nope'"):
        sampler_class("my_samplers:Nope")


def test_sampler_options_from_the_case_file(tmp_path):
    """[sampler.options] and --set sampler.options.X reach the sampler; a typo is refused before
    anything is written, naming the case file; the old [sampler] move says where it went."""
    from pavement_mcmc.data import ConfigError, load_case, parse_set
    from pavement_mcmc.runs import fit

    case = Path(__file__).resolve().parents[2] / "runs" / "caseA.toml"
    out = fit(case, tmp_path / "a", seed=1, overrides={
        "sampler": {"kind": "hmc", "max_steps": 30, "options": {"metric_at": 20}}})
    assert out.result.n_steps == 30
    with pytest.raises(ConfigError, match=r"caseA\.toml: \[sampler.options\] of sampler 'hmc': "
                                          "unknown option 'metric'"):
        fit(case, tmp_path / "b", overrides={"sampler": {"kind": "hmc", "options": {"metric": 3}}})
    assert parse_set("sampler.options.metric_at=40") == {"sampler": {"options": {"metric_at": 40}}}
    assert not (tmp_path / "b").exists()
    with pytest.raises(ConfigError, match=r"\[sampler\] move is now set in \[sampler.options\] move"):
        load_case(case, {"sampler": {"move": "block"}})


def test_pcn_move_outside_the_bounds_warns_nothing():
    """A pCN proposal outside a bound has log-posterior and log-prior both -inf; the move used to
    subtract them for every proposal and let 'invalid value encountered in subtract' reach the
    user (seen in make bench's batch). Modes close to the bounds make many such proposals."""
    import warnings

    post = LinearGaussian(lower=[2.9, 3.0, 5.8])
    s = _prepared("fast", post)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for _ in range(3):
            s.step(200, adapt=True)
    assert np.isfinite(s.move.loglik).all()
