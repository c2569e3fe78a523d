r"""The gamma-marginal target shared by the moves and samplers of the GMRF case (Case C).

With a free smoothness precision gamma, the chains move ``x = theta[idx]`` (every free parameter
but gamma) under the marginal posterior

.. math:: \log p(x) = \log L(x) + \sum_i \log\pi_i(x_i) + \log F(\lVert Dh\rVert^2),

gamma integrated out (:class:`~pavement_mcmc.posterior.MarginalGMRF`), and gamma | h is drawn
exactly after every step (:func:`.gamma.draw_gamma`). :class:`MarginalTarget` holds what that
needs: the tabulated ``F``, the marginal MAP, the columns, the non-flat univariate priors and the
bounds; its start points are draws around the marginal MAP reflected into the bounds.
"""

from __future__ import annotations

import numpy as np

from ..parameters import Flat
from ..posterior.map import psd_factor
from ..posterior.marginal import MarginalGMRF, find_marginal_map, gmrf_of
from .base import finite_draws
from .gamma import draw_gamma


class MarginalTarget:
    """The gamma-marginal posterior of a GMRF case (see the module docstring).

    Parameters
    ----------
    posterior : the :class:`~pavement_mcmc.posterior.LogPosterior` (or a look-alike with
        ``space``, ``residuals`` and ``log_likelihood_from_residuals``).
    mmap : a precomputed :class:`~pavement_mcmc.posterior.MarginalMAP`, else found here.
    theta0 : start of the marginal MAP search.

    Attributes
    ----------
    tab, mmap : the tabulated marginal prior and the marginal MAP; ``n_evals`` solves spent.
    idx, hcols, gi : free columns of x, of h_1..h_N, of gamma.
    uni : ``[(column, prior)]`` of the non-flat univariate priors of x; ``gprior`` gamma's.
    lo, hi : bounds of every free parameter.
    """

    def __init__(self, posterior, mmap=None, theta0=None):
        self.posterior = posterior
        self.tab = self.table(posterior.space)
        self.n_evals = 0
        if mmap is None:
            mmap = find_marginal_map(posterior, self.tab, theta0)
            self.n_evals = mmap.n_evals
        self.mmap = mmap
        self.idx, self.hcols, self.gi = mmap.idx, mmap.hcols, mmap.gamma_index
        self.set_columns(self.idx, self.hcols, self.gi)

    @staticmethod
    def table(space) -> MarginalGMRF:
        gname, hnames = gmrf_of(space)
        p = space[gname]
        return MarginalGMRF(len(hnames), p.prior, p.lower, p.upper)

    @classmethod
    def restored(cls, posterior, idx, hcols, gi) -> MarginalTarget:
        """The target of a resumed run (columns from the stored state; no MAP search)."""
        self = cls.__new__(cls)
        self.posterior = posterior
        self.tab = cls.table(posterior.space)
        self.n_evals, self.mmap = 0, None
        self.set_columns(np.asarray(idx, int), np.asarray(hcols, int), int(gi))
        return self

    def set_columns(self, idx, hcols, gi) -> None:
        """The columns, the non-flat univariate priors of x, gamma's prior and the bounds."""
        self.idx, self.hcols, self.gi = idx, hcols, gi
        space = self.posterior.space
        free = space.free
        self.uni = [(i, space[free[i]].prior) for i in self.idx
                    if not isinstance(space[free[i]].prior, Flat)]
        self.gprior = space[free[self.gi]].prior
        self.lo, self.hi = space.bounds()

    # -- densities -----------------------------------------------------------------------------
    def uni_logp(self, X: np.ndarray) -> np.ndarray:
        """Sum of the univariate log-priors of x, (n,)."""
        out = np.zeros(X.shape[0])
        for i, pr in self.uni:
            out = out + pr.logpdf(X[:, i])
        return out

    def joint_log_prior(self, X: np.ndarray, uni: np.ndarray) -> np.ndarray:
        """``space.log_prior`` for points inside the bounds: univariate + GMRF(h | gamma) +
        prior(gamma)."""
        g = X[:, self.gi]
        S = np.sum(np.diff(X[:, self.hcols], axis=1) ** 2, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            gm = 0.5 * (self.hcols.size - 1) * np.log(g) - 0.5 * g * S
        return uni + gm + self.gprior.logpdf(g)

    def log_prior_h(self, X: np.ndarray) -> np.ndarray:
        """The marginal log-prior of h, ``log F(||D h||^2)``, of full rows X (n, n_free)."""
        return self.tab.log_prior_h(X[:, self.hcols])

    def loglik(self, X: np.ndarray, evaluate) -> tuple[np.ndarray, np.ndarray]:
        """Log-likelihood and blobs of points inside the bounds (one batched solve);
        ``evaluate`` is the sampler's log-posterior call (look-alike posteriors only)."""
        post = self.posterior
        if hasattr(post, "loglik_blobs"):
            with np.errstate(all="ignore"):
                ll, rmse = post.loglik_blobs(X)
            good = np.isfinite(ll)
            return np.where(good, ll, -np.inf), np.where(good[:, None], rmse, np.inf)
        if hasattr(post, "residuals") and hasattr(post, "log_likelihood_from_residuals"):
            with np.errstate(all="ignore"):
                r = post.residuals(X)
                ll = post.log_likelihood_from_residuals(r)
                rmse = np.sqrt(np.mean(r * r, axis=1)).reshape(X.shape[0], -1)
            good = np.isfinite(ll)
            return np.where(good, ll, -np.inf), np.where(good[:, None], rmse, np.inf)
        lp, bl = evaluate(X)
        return lp - post.space.log_prior(X), bl

    def score(self, prop: np.ndarray, inside: np.ndarray, blobs_like: np.ndarray, evaluate):
        """Log-likelihood, blobs and univariate log-prior of proposals; only those ``inside``
        the bounds are solved (the others get -inf). Returns (ll, blobs, uni, n_solved)."""
        ll = np.full(prop.shape[0], -np.inf)
        bl = np.full_like(blobs_like, np.inf)
        n_in = int(inside.sum())
        if n_in:
            ll[inside], bl[inside] = self.loglik(prop[inside], evaluate)
        return ll, bl, self.uni_logp(prop), n_in

    def draw_gamma(self, rng: np.random.Generator, theta: np.ndarray) -> np.ndarray:
        return draw_gamma(rng, self.posterior.space, theta, self.gi, self.hcols)

    # -- start ---------------------------------------------------------------------------------
    def start_points(self, rng: np.random.Generator, n: int, chol: np.ndarray,
                     inflate: float = 1.2) -> np.ndarray:
        """``n`` draws of N(marginal MAP, inflate^2 chol chol^T) in x, reflected into the bounds
        (h >= 0 at night sits on its bound at the mode), redrawn until finite; then gamma | h."""
        mode, idx = self.mmap.theta, self.idx
        theta = draws_around(rng, self.posterior, n, mode, idx, mode[idx], chol,
                             self.lo[idx], self.hi[idx], inflate)
        theta[:, self.gi] = self.draw_gamma(rng, theta)
        return theta


def draws_around(rng: np.random.Generator, posterior, n: int, mode: np.ndarray, idx: np.ndarray,
                 center: np.ndarray, chol: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                 inflate: float, to_x=None, clip: float | None = None) -> np.ndarray:
    """``n`` start points: ``mode`` with the columns ``idx`` drawn as ``center + inflate chol z``
    (``z`` standard normal, clipped to ``+-clip`` if given) in some working coordinates,
    mapped to ``x`` by ``to_x`` (default: they are ``x``), reflected into ``[lo, hi]`` and
    redrawn (narrower) until the posterior is finite."""
    d = idx.size

    def draw(k, f):
        X = np.repeat(mode[None, :], k, axis=0)
        z = rng.standard_normal((k, d))
        if clip is not None:
            z = np.clip(z, -clip, clip)
        w = center + f * z @ chol.T
        X[:, idx] = reflect_into(w if to_x is None else to_x(w), lo, hi)
        return X

    return finite_draws(draw, n, posterior, inflate)


def reflect_into(X: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Points ``X`` (n, d) folded into ``[lo, hi]``: mirrored at the lower bound, clipped at
    the upper one (start points drawn around a mode on a bound)."""
    span = hi - lo
    with np.errstate(invalid="ignore"):
        Y = np.abs(X - lo)
        out = lo + np.where(np.isfinite(span), np.minimum(Y, span), Y)
    return np.where(np.isfinite(lo), out, np.minimum(X, hi))


def bounded_laplace_cov(cov: np.ndarray, x: np.ndarray, grad: np.ndarray, lo: np.ndarray,
                        hi: np.ndarray, tol: float = 1e-6) -> np.ndarray:
    r"""The Laplace covariance ``cov`` at a mode ``x`` with some coordinates on their bounds.

    Where the mode sits on a bound and the log-density still falls away from it (slope
    ``grad``, e.g. a night-time h at 0 that the data would push below 0), the posterior along
    that coordinate is close to an exponential of scale ``1/|grad|``, not the Gaussian of the
    curvature: such an active coordinate ``a`` gets the variance
    ``V_a = min(cov_aa, 1/grad_a^2)``, none of the others.
    The free coordinates ``f`` keep the Gaussian's regression on the active ones: with
    ``B = cov_fa cov_aa^-1``,

    .. math:: \Sigma_{ff} = \mathrm{cov}_{ff} - B\,\mathrm{cov}_{af} + B V B^T, \qquad
              \Sigma_{fa} = B V,

    the covariance of ``x_f = B x_a + e`` (``e`` the Gaussian's conditional spread given
    ``x_a``) when ``x_a`` varies by ``V`` instead of ``cov_aa``; for a Gaussian truncated at a
    bound it is exact with ``V`` the truncated variance. Dropping the correlations instead
    left the free coordinates their marginal spread along the cut-off side of the bound: on
    the Göttingen 72-h window with ``surface_layer`` (``R_surface`` on its bound 2) kappa, C
    and the plate factor, correlated at 0.99 with it, got 2.5x their posterior sd in a
    direction the step size then had to resolve (whitened sd 0.11: 64 leapfrog steps for the
    first metric window). Unchanged without such a bound.
    On the 72-h Göttingen window (43 of 144 h at 0 at the mode) the Laplace sd was 3.6x the
    exponential's there (median), and the step size adapted to 0.01 (64 leapfrog steps) until
    the metric's second window replaced it; from this metric it starts at ~0.06.
    """
    sd = np.sqrt(np.diag(cov))
    act = (((x - lo) <= tol * sd) & (grad < 0)) | (((hi - x) <= tol * sd) & (grad > 0))
    if not act.any():
        return cov
    cov = np.asarray(cov, float)
    fr = ~act
    var = np.minimum(sd[act] ** 2, 1.0 / grad[act] ** 2)
    B = np.linalg.lstsq(cov[np.ix_(act, act)], cov[np.ix_(act, fr)], rcond=None)[0].T
    out = np.zeros_like(cov)
    out[np.ix_(fr, fr)] = cov[np.ix_(fr, fr)] - B @ cov[np.ix_(act, fr)] + (B * var) @ B.T
    out[np.ix_(fr, act)] = B * var
    out[np.ix_(act, fr)] = (B * var).T
    out[act, act] = var
    return out


def cholesky_of(cov: np.ndarray) -> np.ndarray:
    """A Cholesky factor of a covariance through its correlation matrix (scale-robust)."""
    sd = np.sqrt(np.diag(cov))
    corr = cov / np.outer(sd, sd)
    k = cov.shape[0]
    try:
        return np.linalg.cholesky(corr + 1e-10 * np.eye(k)) * sd[:, None]
    except np.linalg.LinAlgError:  # round-off made it indefinite: the PSD square root
        return psd_factor(corr) * sd[:, None]
