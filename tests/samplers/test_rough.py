"""The scale move of h's rough part (samplers/rough.py): the DCT basis diagonalises D^T D, and
the move alone leaves the marginal GMRF prior's law of the rough roughness exact (a wrong
Jacobian shifts it); hmc with the move matches the GMRF toy's quadrature (test_samplers)."""

import numpy as np
import pytest

from pavement_mcmc.parameters import Rayleigh
from pavement_mcmc.posterior.marginal import MarginalGMRF
from pavement_mcmc.samplers.rough import RoughScale, dct_basis, scale_moves


def test_dct_basis_is_orthonormal_and_diagonalises_the_first_differences():
    n = 9
    B, lam = dct_basis(n)
    D = np.diff(np.eye(n), axis=0)
    np.testing.assert_allclose(B.T @ B, np.eye(n), atol=1e-12)
    np.testing.assert_allclose(B.T @ D.T @ D @ B, np.diag(lam), atol=1e-12)


class _FlatLikelihood:
    """The marginal target of N values of h with a flat likelihood: the marginal GMRF prior
    ``F(||Dh||^2)`` (Rayleigh hyperprior), no bounds; the interface of MarginalTarget."""

    def __init__(self, n, g0):
        self.tab = MarginalGMRF(n, Rayleigh(g0), 0.0, 1e4)
        self.hcols = self.idx = np.arange(n)
        self.lo, self.hi = np.full(n, -np.inf), np.full(n, np.inf)

    def score(self, prop, inside, blobs_like, evaluate):
        m = prop.shape[0]
        return np.zeros(m), np.zeros_like(blobs_like), np.zeros(m), int(inside.sum())

    def uni_logp(self, X):
        return np.zeros(X.shape[0])

    def log_prior_h(self, X):
        return self.tab.log_prior_h(X[:, self.hcols])


def _log_sr_moments(tab, s_smooth, n_rough):
    """Mean and sd of log S_r along the move's rays: density of u = log S_r proportional to
    exp(u n_r / 2) F(S_s + e^u) (polar coordinates of the rough part), by quadrature."""
    u = np.linspace(-12.0, 12.0, 40001)
    logp = 0.5 * n_rough * u + tab.log_f(s_smooth + np.exp(u))
    w = np.exp(logp - logp.max())
    w /= w.sum()
    mean = w @ u
    return mean, np.sqrt(w @ (u - mean) ** 2)


@pytest.mark.parametrize("jacobian_error", [0, -1, 1])
def test_scale_move_alone_keeps_the_marginal_prior_exact(jacobian_error):
    """N = 8, rough modes 3-7: with a flat likelihood the stationary law of log S_r along each
    ray is known (quadrature); the move reproduces its mean and sd, and a Jacobian one power
    off (``n_rough +- 1``) misses the mean by many Monte Carlo errors."""
    n, m, n_moves, burn = 8, 400, 600, 100
    tg = _FlatLikelihood(n, 2.22)
    rough = np.arange(n) >= 3
    move = RoughScale(rough, step=0.4)
    move.n_rough += jacobian_error
    B, lam = dct_basis(n)
    rng = np.random.default_rng(11)
    c = np.zeros((m, n))
    c[:, 0], c[:, 1], c[:, 2] = 20.0, 0.8, -0.5  # the same smooth part in every chain
    c[:, rough] = rng.normal(size=(m, rough.sum())) / np.sqrt(lam[rough])
    theta = c @ B.T
    s_smooth = float(lam[1] * 0.8**2 + lam[2] * 0.5**2)
    ll, blobs = np.zeros(m), np.zeros((m, 1))
    trace = []
    for k in range(n_moves):
        theta, ll, blobs, _, _ = scale_moves(move, rng, tg, theta, ll, blobs, 1, adapt=False)
        if k >= burn:
            cr = (theta @ B)[:, rough]
            trace.append(np.log(np.sum(lam[rough] * cr**2, axis=1)))
    trace = np.array(trace)  # (steps, chains): the chains are independent
    np.testing.assert_allclose((theta @ B)[:, ~rough], c[:, ~rough], atol=1e-9)  # smooth kept
    chain_means = trace.mean(axis=0)
    mcse = chain_means.std() / np.sqrt(m)
    mean, sd = _log_sr_moments(tg.tab, s_smooth, rough.sum())
    z = (chain_means.mean() - mean) / mcse
    if jacobian_error == 0:
        assert abs(z) < 4.0, (z, mean, chain_means.mean())
        np.testing.assert_allclose(trace.std(), sd, rtol=0.05)
    else:
        assert abs(z) > 10.0, z


def test_hmc_drops_a_move_tuned_too_small_at_the_end_of_adaptation():
    """The GMRF toy with ``rough_moves``: a step tuned below MIN_STEP (h piled at 0, as on the
    Göttingen window) is dropped when the adaptation ends, a useful one kept."""
    from test_samplers import ToyGMRF

    from pavement_mcmc.samplers import get_sampler
    from pavement_mcmc.samplers.rough import MIN_STEP

    for step, kept in ((0.5 * MIN_STEP, False), (2.0 * MIN_STEP, True)):
        s = get_sampler("hmc", ToyGMRF(), n_chains=8, seed=3, options={"rough_moves": 4})
        s.prepare()
        assert s.rough is not None
        s.rough.log_step = float(np.log(step))
        s.step(1, adapt=False)
        assert (s.rough is not None) == kept


@pytest.mark.parametrize("opts, msg", [({"rough_moves": -1}, "rough_moves must be an integer >= 0"),
                                       ({"rough_moves": 1.5}, "rough_moves must be an integer"),
                                       ({"rough_cut": 1.0}, r"rough_cut must lie in \(0, 1\)")])
def test_bad_rough_options_are_refused(opts, msg):
    from pavement_mcmc.samplers.hmc_options import HMCOptions

    with pytest.raises(ValueError, match=msg):
        HMCOptions(**opts)
