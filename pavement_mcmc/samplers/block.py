r"""One-block update of (gamma, kappa, C, h) for the GMRF case (Knorr-Held & Rue 2002).

Used by :class:`~pavement_mcmc.samplers.fast.FastSampler` with option ``move = "block"`` when
the case has a free smoothness precision gamma (Case C). ``x`` = every free parameter but gamma
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

* with probability ``block_prob`` (default 0.5) the joint move: ``gamma' = gamma e^{s z}`` and
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

import numpy as np

BLOCK_ARRAYS = ("G", "Ginv", "lam", "yhat", "bscale", "loglik", "uni_c")


class BlockGMRFMixin:
    """The block move; mixed into FastSampler (uses its marginal-path helpers)."""

    def _prepare_block(self, theta0=None) -> None:
        self._prepare_marginal(theta0)  # marginal MAP + Laplace, start points, exact gamma draw
        mm = self.mmap
        self.block = True
        cov = np.asarray(mm.cov, float)
        sc = np.sqrt(np.diag(cov))
        self.bscale = sc
        K = np.asarray(mm.precision, float) * np.outer(sc, sc)
        K = 0.5 * (K + K.T)
        pos = {int(c): j for j, c in enumerate(self.idx)}
        hj = np.array([pos[int(c)] for c in self.hcols])
        d = self.idx.size
        Bh = np.diff(np.eye(hj.size), axis=0)
        B = np.zeros((d, d))
        B[np.ix_(hj, hj)] = (Bh.T @ Bh) * np.outer(sc[hj], sc[hj])
        L = np.linalg.cholesky(K + 1e-12 * np.trace(K) / d * np.eye(d))
        Linv = np.linalg.inv(L)
        lam, V = np.linalg.eigh(Linv @ B @ Linv.T)
        self.G = Linv.T @ V
        self.Ginv = V.T @ L.T
        self.lam = np.clip(lam, 0.0, None)
        self.yhat = self.Ginv @ (mm.theta[self.idx] / sc)
        self.gamma_hat = float(mm.theta[self.gi])
        self.log_s = float(np.log(self.options.get("gamma_step", 0.5)))
        self.log_beta = float(np.log(self.options.get("proposal_scale") or 0.5))
        self.k_adapt = 0
        self.uni_c = self._uni_logp(self.theta)

    def _bw(self, g: np.ndarray) -> np.ndarray:
        return np.maximum(1.0 + (g[:, None] - self.gamma_hat) * self.lam[None, :], 1e-10)

    def _logq(self, y: np.ndarray, w: np.ndarray) -> np.ndarray:
        """log q(x | gamma) in y = G^-1 x / scale, up to a constant not depending on gamma."""
        return 0.5 * np.sum(np.log(w), axis=1) - 0.5 * np.sum(w * (y - self.yhat / w) ** 2, axis=1)

    def _step_block(self, n_steps: int, adapt: bool) -> tuple:
        p_block = float(self.options.get("block_prob", 0.5))
        gibbs = bool(self.options.get("gibbs_gamma", True))
        indep = self.options.get("block_kind", "rescale") == "independence"
        lo_i, hi_i = self.lo[self.idx], self.hi[self.idx]
        g_lo, g_hi = self.lo[self.gi], self.hi[self.gi]
        rows = []
        m, d = self.theta.shape[0], self.idx.size
        for _ in range(n_steps):
            g = self.theta[:, self.gi]
            y = (self.theta[:, self.idx] / self.bscale) @ self.Ginv.T
            blk = self.rng.uniform(size=m) < p_block
            gp = np.where(blk, g * np.exp(np.exp(self.log_s) * self.rng.standard_normal(m)), g)
            xi = self.rng.standard_normal((m, d))
            w_c, w_p = self._bw(g), self._bw(gp)
            mu_c, mu_p = self.yhat / w_c, self.yhat / w_p
            beta = min(1.0, float(np.exp(self.log_beta)))
            rho = np.sqrt(max(0.0, 1.0 - beta**2))
            if indep:
                y_blk = mu_p + xi / np.sqrt(w_p)
            else:  # keep the standardised deviation: y' - mu(g') = sqrt(w / w') (y - mu(g))
                y_blk = mu_p + np.sqrt(w_c / w_p) * (y - mu_c)
            yp = np.where(blk[:, None], y_blk, mu_c + rho * (y - mu_c) + beta * xi / np.sqrt(w_c))
            prop = self.theta.copy()
            prop[:, self.idx] = (yp @ self.G.T) * self.bscale
            prop[:, self.gi] = gp
            xp = prop[:, self.idx]
            inside = (np.all((xp >= lo_i) & (xp <= hi_i), axis=1) & (gp > g_lo) & (gp < g_hi))
            ll_p, bl, uni_p, n_in = self._score(prop, inside)
            with np.errstate(invalid="ignore", divide="ignore"):
                lp_p = ll_p + self._joint_log_prior(prop, uni_p)
                # block: pi(x', g') g' q(x | g) / (pi(x, g) g q(x' | g'))
                a_blk = lp_p + np.log(gp) - self.logp - np.log(g)
                if indep:
                    a_blk = a_blk + self._logq(y, w_c) - self._logq(yp, w_p)
                else:  # Jacobian of the deterministic map (an involution with z -> -z)
                    a_blk = a_blk + 0.5 * np.sum(np.log(w_c / w_p), axis=1)
                # pCN at fixed g: pi(x') q(x) / (pi(x) q(x'))
                a_pcn = lp_p - self.logp + self._logq(y, w_c) - self._logq(yp, w_c)
                log_a = np.where(blk, a_blk, a_pcn)
            acc = (np.log(self.rng.uniform(size=m)) < log_a) & inside
            st = self.__dict__.setdefault("block_stats", np.zeros(6))  # diagnostics only
            st += (blk.sum(), (blk & inside).sum(), (blk & acc).sum(),
                   (~blk).sum(), (~blk & inside).sum(), (~blk & acc).sum())
            self.theta = np.where(acc[:, None], prop, self.theta)
            self.loglik = np.where(acc, ll_p, self.loglik)
            self.uni_c = np.where(acc, uni_p, self.uni_c)
            self.blobs = np.where(acc[:, None], bl, self.blobs)
            if gibbs:
                self.theta[:, self.gi] = self._draw_gamma(self.theta)
            self.logp = self.loglik + self._joint_log_prior(self.theta, self.uni_c)
            if adapt:
                self.k_adapt += 1
                gain = 1.0 / (1.0 + self.k_adapt) ** 0.6
                if blk.any():
                    self.log_s += gain * (float(acc[blk].mean())
                                          - float(self.options.get("block_target", 0.25)))
                if (~blk).any():
                    self.log_beta = min(0.0, self.log_beta + gain * (
                        float(acc[~blk].mean()) - float(self.options.get("pcn_target", 0.3))))
            rows.append((self.theta.copy(), self.logp.copy(), self.blobs.copy(), acc, n_in))
        return rows

    def _extra_state_block(self):
        extra = {"marginal": True, "block": True, "log_s": self.log_s, "log_beta": self.log_beta,
                 "k_adapt": self.k_adapt, "gi": self.gi, "gamma_hat": self.gamma_hat}
        arrays = {k: getattr(self, k) for k in BLOCK_ARRAYS}
        arrays["idx"], arrays["hcols"] = self.idx, self.hcols
        return extra, arrays

    def _load_extra_state_block(self, extra, arrays):
        self.block = True
        self.log_s, self.log_beta = float(extra["log_s"]), float(extra["log_beta"])
        self.k_adapt = int(extra["k_adapt"])
        self.gi = int(extra["gi"])
        self.gamma_hat = float(extra["gamma_hat"])
        self.idx = np.array(arrays["idx"]).astype(int)
        self.hcols = np.array(arrays["hcols"]).astype(int)
        for k in BLOCK_ARRAYS:
            setattr(self, k, np.array(arrays[k], dtype=float))
        self._prior_terms()
