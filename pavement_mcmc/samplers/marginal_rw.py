"""The gamma-marginal random-walk path of :class:`~pavement_mcmc.samplers.fast.FastSampler` (Case C).

Used when the case has a free smoothness precision gamma and ``move = "rw"`` (the default).

Target of the chain: the marginal posterior of x = theta[idx] (every free parameter but
gamma), log p(x) = log-likelihood + log-priors of x + log F(||D h||^2) (gamma integrated
out, :mod:`.marginal`). Move: Gaussian random walk in the ORIGINAL coordinates,
x' = x + s L xi, L L^T the proposal covariance (the Laplace covariance at the marginal
mode, then re-estimated from the pooled chains at the end of each adaptation window),
s = 2.38/sqrt(d) times a factor tuned towards the target acceptance (0.234) — both during
adaptation only, then frozen. Proposals outside the bounds (h < 0) are rejected without a
solve. After every step gamma | h is drawn exactly (it does not feed back into the chain
of x, so the (x, gamma) chain is exact for the joint posterior). The stored log-posterior
is the JOINT one at (x, gamma), log-likelihood + space.log_prior (GMRF x Rayleigh), like
every other sampler's.
"""

from __future__ import annotations

import numpy as np

from ..parameters.priors import Flat
from ..posterior.marginal import MarginalGMRF, find_marginal_map, gmrf_of
from .base import Block, finite_draws


class MarginalRWMixin:
    """The gamma-marginal path; mixed into FastSampler (uses its ``_draw_gamma``)."""

    def _table(self) -> MarginalGMRF:
        space = self.posterior.space
        gname, hnames = gmrf_of(space)
        p = space[gname]
        return MarginalGMRF(len(hnames), p.prior, p.lower, p.upper)

    def _prior_terms(self) -> None:
        """Precompute the non-flat univariate priors (col, prior), gamma's prior and bounds."""
        space = self.posterior.space
        free = space.free
        self.uni = [(i, space[free[i]].prior) for i in self.idx
                    if not isinstance(space[free[i]].prior, Flat)]
        self.gprior = space[free[self.gi]].prior
        self.lo, self.hi = space.bounds()

    def _score(self, prop: np.ndarray, inside: np.ndarray):
        """Log-likelihood, blobs and univariate log-prior of proposals; only those ``inside``
        the bounds are solved (the others get -inf). Returns (ll, blobs, uni, n_solved)."""
        ll = np.full(prop.shape[0], -np.inf)
        bl = np.full_like(self.blobs, np.inf)
        n_in = int(inside.sum())
        if n_in:
            ll[inside], bl[inside] = self._loglik(prop[inside])
        return ll, bl, self._uni_logp(prop), n_in

    def _uni_logp(self, X: np.ndarray) -> np.ndarray:
        out = np.zeros(X.shape[0])
        for i, pr in self.uni:
            out = out + pr.logpdf(X[:, i])
        return out

    def _joint_log_prior(self, X: np.ndarray, uni: np.ndarray) -> np.ndarray:
        """space.log_prior for points inside the bounds: univariate + GMRF(h | gamma) + prior(gamma)."""
        g = X[:, self.gi]
        S = np.sum(np.diff(X[:, self.hcols], axis=1) ** 2, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            gm = 0.5 * (self.hcols.size - 1) * np.log(g) - 0.5 * g * S
        return uni + gm + self.gprior.logpdf(g)

    def _loglik(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Log-likelihood and blobs of points inside the bounds (one batched solve)."""
        post = self.posterior
        if hasattr(post, "residuals") and hasattr(post, "log_likelihood_from_residuals"):
            with np.errstate(all="ignore"):
                r = post.residuals(X)
                ll = post.log_likelihood_from_residuals(r)
                rmse = np.sqrt(np.mean(r * r, axis=1)).reshape(X.shape[0], -1)
            good = np.isfinite(ll)
            return np.where(good, ll, -np.inf), np.where(good[:, None], rmse, np.inf)
        lp, bl = self.evaluate(X)
        return lp - post.space.log_prior(X), bl

    def _prepare_marginal(self, theta0=None) -> None:
        space = self.posterior.space
        self.tab = self._table()
        mm = self.options.get("marginal_map")
        if mm is None:
            mm = find_marginal_map(self.posterior, self.tab, theta0)
            self.n_prep_evals += mm.n_evals
        self.mmap = mm
        self.idx, self.hcols, self.gi = mm.idx, mm.hcols, mm.gamma_index
        self._prior_terms()
        self.prop_cov = np.array(mm.cov)
        self._set_chol()
        d = self.idx.size
        self.log_s = float(np.log(self.options.get("proposal_scale") or 2.38 / np.sqrt(d)))
        self.k_adapt = 0
        self.win_start, self.win_len = 0, int(self.options.get("first_window", 100))
        self._reset_window()
        lo, hi = space.bounds()

        def draw(n, f):
            X = np.repeat(mm.theta[None, :], n, axis=0)
            X[:, self.idx] += f * self.rng.standard_normal((n, d)) @ self.chol.T
            # reflect into the bounds (h >= 0 at night sits on its bound at the mode)
            span = hi[self.idx] - lo[self.idx]
            Y = np.abs(X[:, self.idx] - lo[self.idx])
            X[:, self.idx] = lo[self.idx] + np.where(np.isfinite(span), np.minimum(Y, span), Y)
            return X

        self.theta = finite_draws(draw, self.n_chains, self.posterior, 1.2)
        self.theta[:, self.gi] = self._draw_gamma(self.theta)
        self.logp, self.blobs = self.evaluate(self.theta)
        self.n_prep_evals += self.n_chains
        self.loglik = self.logp - space.log_prior(self.theta)
        self.mlogp = self.loglik + self._uni_logp(self.theta) + self.tab.log_prior_h(
            self.theta[:, self.hcols])

    def _set_chol(self) -> None:
        c = self.prop_cov
        sd = np.sqrt(np.diag(c))
        corr = c / np.outer(sd, sd)
        k = c.shape[0]
        self.chol = np.linalg.cholesky(corr + 1e-10 * np.eye(k)) * sd[:, None]

    def _reset_window(self) -> None:
        k = self.idx.size
        self.win_n = 0.0
        self.win_1, self.win_2 = np.zeros(k), np.zeros((k, k))

    def _step_marginal(self, n_steps: int, adapt: bool) -> Block:
        target = float(self.options.get("target_acceptance", 0.234))
        lo_i, hi_i = self.lo[self.idx], self.hi[self.idx]
        rows = []
        m, d = self.theta.shape[0], self.idx.size
        uni_c = self._uni_logp(self.theta)
        for _ in range(n_steps):
            xi = self.rng.standard_normal((m, d))
            xp = self.theta[:, self.idx] + np.exp(self.log_s) * xi @ self.chol.T
            inside = np.all((xp >= lo_i) & (xp <= hi_i), axis=1)
            prop = self.theta.copy()
            prop[:, self.idx] = xp
            ll_p, bl, uni_p, n_in = self._score(prop, inside)
            with np.errstate(invalid="ignore"):
                ml_p = ll_p + uni_p + self.tab.log_prior_h(prop[:, self.hcols])
                log_a = ml_p - self.mlogp
            acc = (np.log(self.rng.uniform(size=m)) < log_a) & inside
            self.theta = np.where(acc[:, None], prop, self.theta)
            self.loglik = np.where(acc, ll_p, self.loglik)
            self.mlogp = np.where(acc, ml_p, self.mlogp)
            uni_c = np.where(acc, uni_p, uni_c)
            self.blobs = np.where(acc[:, None], bl, self.blobs)
            self.theta[:, self.gi] = self._draw_gamma(self.theta)
            self.logp = self.loglik + self._joint_log_prior(self.theta, uni_c)
            if adapt:
                self._adapt_marginal(acc, target)
            rows.append((self.theta.copy(), self.logp.copy(), self.blobs.copy(), acc, n_in))
        return Block.stack(rows)

    def _adapt_marginal(self, acc: np.ndarray, target: float) -> None:
        """Robbins–Monro on log s; the proposal covariance re-estimated from the pooled chains
        over the second half of each window (windows double: 100, 200, 400, ... steps)."""
        self.k_adapt += 1
        gain = 2.0 / (1.0 + self.k_adapt) ** 0.6
        self.log_s += gain * (float(acc.mean()) - target)
        k = self.k_adapt - self.win_start
        if k > self.win_len // 2:
            x = self.theta[:, self.idx]
            self.win_n += x.shape[0]
            self.win_1 += x.sum(axis=0)
            self.win_2 += x.T @ x
        if k >= self.win_len:
            n = self.win_n
            mu = self.win_1 / n
            cov = (self.win_2 - n * np.outer(mu, mu)) / max(n - 1.0, 1.0)
            # shrink towards the diagonal (few effective draws in a short window)
            w = float(self.options.get("cov_shrink", 0.1))
            cov = (1 - w) * cov + w * np.diag(np.diag(cov))
            cov = 0.5 * (cov + cov.T)
            if np.all(np.isfinite(cov)) and np.all(np.linalg.eigvalsh(cov) > 0):
                self.prop_cov = cov
                self._set_chol()
                self.log_s = float(np.log(2.38 / np.sqrt(self.idx.size)))
            self.win_start = self.k_adapt
            self.win_len *= 2
            self._reset_window()

    def _extra_state_marginal(self):
        extra = {"marginal": True, "log_s": self.log_s, "k_adapt": self.k_adapt, "gi": self.gi,
                 "win_start": self.win_start, "win_len": self.win_len, "win_n": self.win_n}
        arrays = {"idx": self.idx, "hcols": self.hcols, "prop_cov": self.prop_cov,
                  "chol": self.chol, "loglik": self.loglik, "mlogp": self.mlogp,
                  "win_1": self.win_1, "win_2": self.win_2}
        return extra, arrays

    def _load_extra_state_marginal(self, extra, arrays):
        self.tab = self._table()
        self.log_s = float(extra["log_s"])
        self.k_adapt = int(extra["k_adapt"])
        self.gi = int(extra["gi"])
        self.win_start, self.win_len = int(extra["win_start"]), int(extra["win_len"])
        self.win_n = float(extra["win_n"])
        self.idx = np.array(arrays["idx"]).astype(int)
        self.hcols = np.array(arrays["hcols"]).astype(int)
        for k in ("prop_cov", "chol", "loglik", "mlogp", "win_1", "win_2"):
            setattr(self, k, np.array(arrays[k], dtype=float))
        self._prior_terms()
