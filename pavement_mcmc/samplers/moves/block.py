r"""One-block update of (gamma, kappa, C, h) for the GMRF case (Knorr-Held & Rue 2002).

The ``fast`` sampler's move ``"block"`` for a case with a free smoothness precision gamma
(Case C). ``x`` = every free parameter but gamma
(kappa, C, h, ...) in ORIGINAL coordinates (divided by fixed per-parameter scales).

Reference Gaussian: the Gauss–Newton approximation at the gamma-marginal MAP ``x_hat``
(:func:`~pavement_mcmc.posterior.marginal.find_marginal_map`, precision ``K`` including
``gamma_hat D^T D``), as a function of gamma:

.. math:: q(x \mid \gamma) = N\bigl(\mu(\gamma), Q(\gamma)^{-1}\bigr),\quad
          Q(\gamma) = K + (\gamma - \hat\gamma) B,\quad \mu(\gamma) = Q(\gamma)^{-1} K \hat x,

``B = D^T D`` in the h block (``K - gamma_hat B`` is the data + Gaussian-prior part). One
simultaneous diagonalisation (``G^T K G = I``, ``G^T B G = diag(lambda)``) makes it diagonal
for every gamma: in ``y = G^{-1} x`` it is N(y_hat / w, diag(1 / w)),
``w = 1 + (gamma - gamma_hat) lambda``.

Each step, every chain makes ONE of two moves (all chains share one batched posterior call):

* with probability ``block_prob`` (``block_prob``, default 0.5) the joint move: ``gamma' = gamma e^{s z}`` and
  either (``block_kind = "rescale"``, default) the deterministic non-centred map
  ``y' = mu(gamma') + sqrt(w / w') (y - mu(gamma))`` (the standardised deviation from the
  reference is kept; with z -> -z it is its own inverse), accepted with
  :math:`\frac{\pi(x',\gamma')\,\gamma'}{\pi(x,\gamma)\,\gamma}\prod\sqrt{w/w'}`, or
  (``"independence"``, Knorr-Held & Rue) ``x' ~ q(. | gamma')``, accepted with
  :math:`\frac{\pi(x',\gamma')\,\gamma'\,q(x\mid\gamma)}{\pi(x,\gamma)\,\gamma\,q(x'\mid\gamma')}`
  (on Case C nearly every independence draw has some night h < 0: 5 % inside, so it is off);
* otherwise a preconditioned Crank–Nicolson move at fixed gamma with respect to
  ``q(. | gamma)``: ``y' = mu + rho (y - mu) + beta xi / sqrt(w)``, accepted with
  :math:`\frac{\pi(x')\,q(x)}{\pi(x)\,q(x')}`.

Proposals outside the bounds (h < 0, kappa or C <= 0, gamma out of range) are rejected without
a solve. After the step gamma | h is drawn exactly (no solve; option ``gibbs_gamma``, default
on). ``s`` and ``beta`` are tuned by Robbins–Monro during adaptation only (targets
``block_target`` 0.25 and ``pcn_target`` 0.3), then frozen: the kept chain is an exact MH chain
for the joint posterior. The stored chain and log-posterior are the joint (kappa, C, gamma, h)
ones.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ..target import MarginalTarget, cholesky_of
from .base import Move

BLOCK_ARRAYS = ("G", "Ginv", "lam", "yhat", "bscale", "loglik", "uni_c")


@dataclass
class BlockGMRF(Move):
    """Joint (gamma, x) block move mixed with pCN (see the module docstring).

    Parameters
    ----------
    block_prob : probability that a chain makes the block move in a step.
    block_kind : ``"rescale"`` (deterministic non-centred map) or ``"independence"``.
    gamma_step : initial sd of the log-gamma step.
    proposal_scale : initial pCN ``beta`` (default 0.5).
    block_target, pcn_target : acceptance rates the adaptation tunes towards.
    gibbs_gamma : draw gamma | h exactly after every step.
    """

    block_prob: float = 0.5
    block_kind: str = field(default="rescale", metadata={"choices": ("rescale", "independence")})
    gamma_step: float = 0.5
    proposal_scale: float | None = None
    block_target: float = 0.25
    pcn_target: float = 0.3
    gibbs_gamma: bool = True

    name: ClassVar[str] = "block"
    needs_gmrf: ClassVar[bool] = True

    def prepare(self, sampler, theta0=None, laplace=None, target=None) -> None:
        tg = target or MarginalTarget(sampler.posterior, theta0=theta0)
        sampler.n_prep_evals += tg.n_evals
        self.target = tg
        mm = tg.mmap
        sampler.theta = tg.start_points(sampler.rng, sampler.n_chains, cholesky_of(np.array(mm.cov)))
        sampler.logp, sampler.blobs = sampler.evaluate(sampler.theta)
        sampler.n_prep_evals += sampler.n_chains
        self.loglik = sampler.logp - sampler.posterior.space.log_prior(sampler.theta)
        cov = np.asarray(mm.cov, float)
        sc = np.sqrt(np.diag(cov))
        self.bscale = sc
        K = np.asarray(mm.precision, float) * np.outer(sc, sc)
        K = 0.5 * (K + K.T)
        pos = {int(c): j for j, c in enumerate(tg.idx)}
        hj = np.array([pos[int(c)] for c in tg.hcols])
        d = tg.idx.size
        Bh = np.diff(np.eye(hj.size), axis=0)
        B = np.zeros((d, d))
        B[np.ix_(hj, hj)] = (Bh.T @ Bh) * np.outer(sc[hj], sc[hj])
        L = np.linalg.cholesky(K + 1e-12 * np.trace(K) / d * np.eye(d))
        Linv = np.linalg.inv(L)
        lam, V = np.linalg.eigh(Linv @ B @ Linv.T)
        self.G = Linv.T @ V
        self.Ginv = V.T @ L.T
        self.lam = np.clip(lam, 0.0, None)
        self.yhat = self.Ginv @ (mm.theta[tg.idx] / sc)
        self.gamma_hat = float(mm.theta[tg.gi])
        self.log_s = float(np.log(self.gamma_step))
        self.log_beta = float(np.log(self.proposal_scale or 0.5))
        self.k_adapt = 0
        self.uni_c = tg.uni_logp(sampler.theta)

    def _bw(self, g: np.ndarray) -> np.ndarray:
        return np.maximum(1.0 + (g[:, None] - self.gamma_hat) * self.lam[None, :], 1e-10)

    def _logq(self, y: np.ndarray, w: np.ndarray) -> np.ndarray:
        """log q(x | gamma) in y = G^-1 x / scale, up to a constant not depending on gamma."""
        return 0.5 * np.sum(np.log(w), axis=1) - 0.5 * np.sum(w * (y - self.yhat / w) ** 2, axis=1)

    def step(self, sampler, adapt: bool) -> tuple:
        tg, rng = self.target, sampler.rng
        indep = self.block_kind == "independence"
        lo_i, hi_i = tg.lo[tg.idx], tg.hi[tg.idx]
        g_lo, g_hi = tg.lo[tg.gi], tg.hi[tg.gi]
        theta = sampler.theta
        m, d = theta.shape[0], tg.idx.size
        g = theta[:, tg.gi]
        y = (theta[:, tg.idx] / self.bscale) @ self.Ginv.T
        blk = rng.uniform(size=m) < self.block_prob
        gp = np.where(blk, g * np.exp(np.exp(self.log_s) * rng.standard_normal(m)), g)
        xi = rng.standard_normal((m, d))
        w_c, w_p = self._bw(g), self._bw(gp)
        mu_c, mu_p = self.yhat / w_c, self.yhat / w_p
        beta = min(1.0, float(np.exp(self.log_beta)))
        rho = np.sqrt(max(0.0, 1.0 - beta**2))
        if indep:
            y_blk = mu_p + xi / np.sqrt(w_p)
        else:  # keep the standardised deviation: y' - mu(g') = sqrt(w / w') (y - mu(g))
            y_blk = mu_p + np.sqrt(w_c / w_p) * (y - mu_c)
        yp = np.where(blk[:, None], y_blk, mu_c + rho * (y - mu_c) + beta * xi / np.sqrt(w_c))
        prop = theta.copy()
        prop[:, tg.idx] = (yp @ self.G.T) * self.bscale
        prop[:, tg.gi] = gp
        xp = prop[:, tg.idx]
        inside = (np.all((xp >= lo_i) & (xp <= hi_i), axis=1) & (gp > g_lo) & (gp < g_hi))
        ll_p, bl, uni_p, n_in = tg.score(prop, inside, sampler.blobs, sampler.evaluate)
        with np.errstate(invalid="ignore", divide="ignore"):
            lp_p = ll_p + tg.joint_log_prior(prop, uni_p)
            # block: pi(x', g') g' q(x | g) / (pi(x, g) g q(x' | g'))
            a_blk = lp_p + np.log(gp) - sampler.logp - np.log(g)
            if indep:
                a_blk = a_blk + self._logq(y, w_c) - self._logq(yp, w_p)
            else:  # Jacobian of the deterministic map (an involution with z -> -z)
                a_blk = a_blk + 0.5 * np.sum(np.log(w_c / w_p), axis=1)
            # pCN at fixed g: pi(x') q(x) / (pi(x) q(x'))
            a_pcn = lp_p - sampler.logp + self._logq(y, w_c) - self._logq(yp, w_c)
            log_a = np.where(blk, a_blk, a_pcn)
        acc = (np.log(rng.uniform(size=m)) < log_a) & inside
        sampler.theta = np.where(acc[:, None], prop, theta)
        self.loglik = np.where(acc, ll_p, self.loglik)
        self.uni_c = np.where(acc, uni_p, self.uni_c)
        sampler.blobs = np.where(acc[:, None], bl, sampler.blobs)
        if self.gibbs_gamma:
            sampler.theta[:, tg.gi] = tg.draw_gamma(rng, sampler.theta)
        sampler.logp = self.loglik + tg.joint_log_prior(sampler.theta, self.uni_c)
        if adapt:
            self.k_adapt += 1
            gain = 1.0 / (1.0 + self.k_adapt) ** 0.6
            if blk.any():
                self.log_s += gain * (float(acc[blk].mean()) - self.block_target)
            if (~blk).any():
                self.log_beta = min(0.0, self.log_beta + gain * (
                    float(acc[~blk].mean()) - self.pcn_target))
        return sampler.theta.copy(), sampler.logp.copy(), sampler.blobs.copy(), acc, n_in

    def state(self):
        tg = self.target
        extra = {"marginal": True, "block": True, "log_s": self.log_s, "log_beta": self.log_beta,
                 "k_adapt": self.k_adapt, "gi": tg.gi, "gamma_hat": self.gamma_hat}
        arrays = {k: getattr(self, k) for k in BLOCK_ARRAYS}
        arrays["idx"], arrays["hcols"] = tg.idx, tg.hcols
        return extra, arrays

    def restore(self, sampler, extra, arrays):
        self.target = MarginalTarget.restored(sampler.posterior, np.array(arrays["idx"]).astype(int),
                                              np.array(arrays["hcols"]).astype(int), int(extra["gi"]))
        self.log_s, self.log_beta = float(extra["log_s"]), float(extra["log_beta"])
        self.k_adapt = int(extra["k_adapt"])
        self.gamma_hat = float(extra["gamma_hat"])
        for k in BLOCK_ARRAYS:
            setattr(self, k, np.array(arrays[k], dtype=float))
