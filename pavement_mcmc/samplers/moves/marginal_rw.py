r"""Random walk on the gamma-marginal target (the GMRF case), with exact Gibbs for gamma.

Target of the chain: the marginal posterior of x = theta[idx] (every free parameter but gamma),
:class:`~pavement_mcmc.samplers.target.MarginalTarget`. Move: Gaussian random walk in the
ORIGINAL coordinates, x' = x + s L xi, L L^T the proposal covariance (the Laplace covariance at
the marginal mode, then re-estimated from the pooled chains at the end of each adaptation
window), s = 2.38/sqrt(d) times a factor tuned towards ``target_acceptance`` — both during
adaptation only, then frozen. Proposals outside the bounds (h < 0) are rejected without a
solve. After every step gamma | h is drawn exactly (it does not feed back into the chain of x,
so the (x, gamma) chain is exact for the joint posterior). The stored log-posterior is the JOINT
one at (x, gamma), log-likelihood + space.log_prior (GMRF x Rayleigh), like every other
sampler's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..target import MarginalTarget, cholesky_of
from .base import Move


@dataclass
class MarginalRW(Move):
    """Random walk on the gamma-marginal target (see the module docstring).

    Parameters
    ----------
    target_acceptance : acceptance rate the adaptation tunes the step towards.
    proposal_scale : initial step factor (default ``2.38/sqrt(d)``).
    first_window : length of the first covariance-adaptation window (windows double).
    cov_shrink : shrinkage of a window's covariance towards its diagonal.
    """

    target_acceptance: float = 0.234
    proposal_scale: float | None = None
    first_window: int = 100
    cov_shrink: float = 0.1

    name: ClassVar[str] = "rw"
    needs_gmrf: ClassVar[bool] = True

    def prepare(self, sampler, theta0=None, laplace=None, target=None) -> None:
        tg = target or MarginalTarget(sampler.posterior, theta0=theta0)
        sampler.n_prep_evals += tg.n_evals
        self.target = tg
        self.prop_cov = np.array(tg.mmap.cov)
        self.chol = cholesky_of(self.prop_cov)
        d = tg.idx.size
        self.log_s = float(np.log(self.proposal_scale or 2.38 / np.sqrt(d)))
        self.k_adapt = 0
        self.win_start, self.win_len = 0, int(self.first_window)
        self._reset_window()
        sampler.theta = tg.start_points(sampler.rng, sampler.n_chains, self.chol)
        sampler.logp, sampler.blobs = sampler.evaluate(sampler.theta)
        sampler.n_prep_evals += sampler.n_chains
        self.loglik = sampler.logp - sampler.posterior.space.log_prior(sampler.theta)
        self.mlogp = self.loglik + tg.uni_logp(sampler.theta) + tg.log_prior_h(sampler.theta)

    def _reset_window(self) -> None:
        k = self.target.idx.size
        self.win_n = 0.0
        self.win_1, self.win_2 = np.zeros(k), np.zeros((k, k))

    def step(self, sampler, adapt: bool) -> tuple:
        tg = self.target
        rng = sampler.rng
        lo_i, hi_i = tg.lo[tg.idx], tg.hi[tg.idx]
        m, d = sampler.theta.shape[0], tg.idx.size
        uni_c = tg.uni_logp(sampler.theta)
        xi = rng.standard_normal((m, d))
        xp = sampler.theta[:, tg.idx] + np.exp(self.log_s) * xi @ self.chol.T
        inside = np.all((xp >= lo_i) & (xp <= hi_i), axis=1)
        prop = sampler.theta.copy()
        prop[:, tg.idx] = xp
        ll_p, bl, uni_p, n_in = tg.score(prop, inside, sampler.blobs, sampler.evaluate)
        with np.errstate(invalid="ignore"):
            ml_p = ll_p + uni_p + tg.log_prior_h(prop)
            log_a = ml_p - self.mlogp
        acc = (np.log(rng.uniform(size=m)) < log_a) & inside
        sampler.theta = np.where(acc[:, None], prop, sampler.theta)
        self.loglik = np.where(acc, ll_p, self.loglik)
        self.mlogp = np.where(acc, ml_p, self.mlogp)
        uni_c = np.where(acc, uni_p, uni_c)
        sampler.blobs = np.where(acc[:, None], bl, sampler.blobs)
        sampler.theta[:, tg.gi] = tg.draw_gamma(rng, sampler.theta)
        sampler.logp = self.loglik + tg.joint_log_prior(sampler.theta, uni_c)
        if adapt:
            self._adapt(sampler, acc)
        return sampler.theta.copy(), sampler.logp.copy(), sampler.blobs.copy(), acc, n_in

    def _adapt(self, sampler, acc: np.ndarray) -> None:
        """Robbins–Monro on log s; the proposal covariance re-estimated from the pooled chains
        over the second half of each window (windows double: 100, 200, 400, ... steps)."""
        idx = self.target.idx
        self.k_adapt += 1
        gain = 2.0 / (1.0 + self.k_adapt) ** 0.6
        self.log_s += gain * (float(acc.mean()) - self.target_acceptance)
        k = self.k_adapt - self.win_start
        if k > self.win_len // 2:
            x = sampler.theta[:, idx]
            self.win_n += x.shape[0]
            self.win_1 += x.sum(axis=0)
            self.win_2 += x.T @ x
        if k >= self.win_len:
            n = self.win_n
            mu = self.win_1 / n
            cov = (self.win_2 - n * np.outer(mu, mu)) / max(n - 1.0, 1.0)
            # shrink towards the diagonal (few effective draws in a short window)
            w = float(self.cov_shrink)
            cov = (1 - w) * cov + w * np.diag(np.diag(cov))
            cov = 0.5 * (cov + cov.T)
            if np.all(np.isfinite(cov)) and np.all(np.linalg.eigvalsh(cov) > 0):
                self.prop_cov = cov
                self.chol = cholesky_of(cov)
                self.log_s = float(np.log(2.38 / np.sqrt(idx.size)))
            self.win_start = self.k_adapt
            self.win_len *= 2
            self._reset_window()

    def state(self):
        tg = self.target
        extra = {"marginal": True, "log_s": self.log_s, "k_adapt": self.k_adapt, "gi": tg.gi,
                 "win_start": self.win_start, "win_len": self.win_len, "win_n": self.win_n}
        arrays = {"idx": tg.idx, "hcols": tg.hcols, "prop_cov": self.prop_cov,
                  "chol": self.chol, "loglik": self.loglik, "mlogp": self.mlogp,
                  "win_1": self.win_1, "win_2": self.win_2}
        return extra, arrays

    def restore(self, sampler, extra, arrays):
        self.target = MarginalTarget.restored(sampler.posterior, np.array(arrays["idx"]).astype(int),
                                              np.array(arrays["hcols"]).astype(int), int(extra["gi"]))
        self.log_s = float(extra["log_s"])
        self.k_adapt = int(extra["k_adapt"])
        self.win_start, self.win_len = int(extra["win_start"]), int(extra["win_len"])
        self.win_n = float(extra["win_n"])
        for k in ("prop_cov", "chol", "loglik", "mlogp", "win_1", "win_2"):
            setattr(self, k, np.array(arrays[k], dtype=float))
