r"""The fast sampler: MAP + Laplace, a Laplace-preconditioned Crank–Nicolson move, exact Gibbs for gamma.

Preparation (:func:`pavement_mcmc.posterior.map.find_map`): the MAP by least squares (gamma by EM) and the
Gauss–Newton precision ``K = J^T J`` of the working coordinates ``z`` (all free ones but gamma;
``log theta`` for parameters bounded below by 0, so the hard bound h >= 0 is never hit, else
``theta / scale``) at their mode, with ``B = dK/dgamma`` the smoothness part. Given gamma,
the posterior of ``z`` is
approximated by the Gaussian with precision ``A + gamma B`` (``A = K - gamma_hat B``) and mean
``m(gamma) = (A + gamma B)^{-1} K z_hat`` (one Gauss–Newton step of the linearised model). One
simultaneous diagonalisation (``G^T K G = I``, ``G^T B G = diag(lambda)``) makes that Gaussian
diagonal for every gamma: in ``y = G^{-1} z`` it is N(y_hat / w, diag(1 / w)),
``w = 1 + (gamma - gamma_hat) lambda``, so nothing is factorised during sampling.

Move 1 (kappa, C, h, ... given gamma), many chains at once, one posterior call per step:
the preconditioned Crank–Nicolson proposal with respect to that Gaussian,

.. math:: y' = \mu + \rho (y - \mu) + \beta\, \xi / \sqrt{w},\qquad \rho = \sqrt{1 - \beta^2},

reversible for the Gaussian, so the MH ratio is
:math:`[\pi(y')/N(y')] / [\pi(y)/N(y)]` (``pi`` including the Jacobian of the log
coordinates) — only the non-Gaussian part of the posterior is
tested. ``beta = 1`` is an independence sampler from the Laplace approximation; small ``beta``
is a Gaussian random walk with the Laplace covariance (step ``beta``). ``beta`` starts at
2.38/sqrt(d) and is adapted during burn-in only (Robbins–Monro on ``log beta`` towards the
target acceptance, default 0.45). Optionally (``refit_every`` > 0; off by default: on Case C
refits from short windows of slowly mixing chains made things worse), during burn-in only,
every ``refit_every`` steps the reference Gaussian is replaced by the mean and covariance of
the draws since the previous refit (centre gamma: their mean), because the Laplace
approximation is far too narrow where the data say little (Case C's night-time h). Both are
then frozen, so the kept chain is a valid
MH chain.

Move 2 (gamma given h, exact, no solve): :mod:`.gamma`. The log-posterior then changes only by
the prior terms (the log-likelihood of each chain is carried along).

Written with a :class:`numpy.random.Generator` rather than as emcee moves, so the whole state
(positions, log-likelihoods, beta, the Laplace matrices, the Generator) is one stored
:class:`~pavement_mcmc.storage.RunState`. Cases without gamma skip move 2.
"""

from __future__ import annotations

import numpy as np

from ..posterior.map import find_map
from ..posterior.marginal import gmrf_of
from .base import Block, Sampler, finite_draws
from .block import BlockGMRFMixin
from .gamma import GammaGibbsMixin
from .marginal_rw import MarginalRWMixin


class FastSampler(BlockGMRFMixin, MarginalRWMixin, GammaGibbsMixin, Sampler):
    """Laplace-preconditioned Crank–Nicolson + exact gamma Gibbs (see the module docstring).

    Options
    -------
    target_acceptance : float, default 0.45.
    proposal_scale : initial ``beta`` (default ``2.38/sqrt(d)``, at most 1).
    laplace : a precomputed :class:`~pavement_mcmc.posterior.map.Laplace` (else computed in ``prepare``).
    move : ``"rw"`` (default; gamma integrated out, random walk + exact gamma draw) or
        ``"block"`` (GMRF cases only: joint gamma/x block move mixed with pCN, :mod:`.block`).
    """

    name = "fast"
    adaptive = True

    @property
    def refit_every(self) -> int:
        return int(self.options.get("refit_every") or 0)

    @staticmethod
    def default_chains(ndim: int) -> int:
        return 64

    def _use_marginal(self) -> bool:
        return bool(self.options.get("marginal", True)) and gmrf_of(self.posterior.space) is not None

    def needs_laplace(self) -> bool:
        return not self._use_marginal()  # the gamma-marginal path finds its own mode

    def prepare(self, theta0=None) -> None:
        self.marginal = self._use_marginal()
        self.block = False
        if self.marginal:
            if self.options.get("move", "rw") == "block":
                self._prepare_block(theta0)
            else:
                self._prepare_marginal(theta0)
            return
        lap = self.options.get("laplace")
        if lap is None:
            lap = find_map(self.posterior, theta0)
            self.n_prep_evals += lap.n_evals
        self.lap = lap
        self.idx = np.asarray(lap.idx, int)
        self.scale = np.asarray(lap.scale, float)
        self.logc = np.asarray(lap.logc, bool)
        self.gi = lap.gamma_index
        self.gcols = np.asarray(lap.gmrf_cols, int) if self.gi is not None else np.zeros(0, int)
        self.hcols = self.idx[self.gcols]
        self._set_reference(lap.K, lap.z, float(lap.gamma_hat))
        self._reset_moments()
        self.beta = float(self.options.get("proposal_scale") or min(1.0, 2.38 / np.sqrt(self.idx.size)))
        self.k_adapt = 0
        self.theta = finite_draws(lambda n, f: lap.draw(self.rng, n, f), self.n_chains,
                                  self.posterior, 1.2)
        self.logp, self.blobs = self.evaluate(self.theta)
        self.n_prep_evals += self.n_chains
        self.loglik = self.logp - self.posterior.space.log_prior(self.theta)

    # -- the Gaussian reference -------------------------------------------------------------
    def _B(self, zc: np.ndarray) -> np.ndarray:
        """d(precision)/d(gamma) of the smoothness prior in z, linearised at ``zc``."""
        k = self.idx.size
        B = np.zeros((k, k))
        if self.gi is not None:
            dz = np.where(self.logc, np.exp(zc), self.scale)[self.gcols]
            D = np.diff(np.eye(self.gcols.size), axis=0) * dz[None, :]
            B[np.ix_(self.gcols, self.gcols)] = D.T @ D
        return B

    def _set_reference(self, K: np.ndarray, zc: np.ndarray, gamma_c: float) -> None:
        """Reference N(m(gamma), (K + (gamma - gamma_c) B)^-1), diagonalised once."""
        k = K.shape[0]
        L = np.linalg.cholesky(K + 1e-9 * np.trace(K) / k * np.eye(k))
        Linv = np.linalg.inv(L)
        lam, Q = np.linalg.eigh(Linv @ self._B(zc) @ Linv.T)
        self.G = Linv.T @ Q
        self.Ginv = Q.T @ L.T
        self.lam = np.clip(lam, 0.0, None)
        self.yhat = self.Ginv @ zc
        self.gamma_hat = gamma_c

    def _reset_moments(self) -> None:
        k = self.idx.size
        self.mom_n, self.mom_g = 0.0, 0.0
        self.mom_1, self.mom_2 = np.zeros(k), np.zeros((k, k))

    def _refit(self) -> None:
        """Replace the reference by the moments of the draws since the last refit (burn-in
        only): the Laplace approximation can be far too narrow where the data say little."""
        n = self.mom_n
        m = self.mom_1 / n
        cov = self.mom_2 / n - np.outer(m, m)
        e, V = np.linalg.eigh(0.5 * (cov + cov.T))
        e = np.maximum(e, 1e-8 * max(float(e.max()), 1e-300))
        K = (V / e) @ V.T
        self._set_reference(0.5 * (K + K.T), m, self.mom_g / n if self.gi is not None else 0.0)
        self._reset_moments()

    # -- pieces ------------------------------------------------------------------------------
    def _z(self, theta):
        t = theta[:, self.idx]
        with np.errstate(divide="ignore"):
            return np.where(self.logc, np.log(t), t / self.scale)

    def _theta_idx(self, Z):
        with np.errstate(over="ignore"):
            return np.where(self.logc, np.exp(Z), Z * self.scale)

    def _w(self, theta):
        if self.gi is None:
            return np.ones((theta.shape[0], self.lam.size))
        g = theta[:, self.gi]
        return np.maximum(1.0 + (g[:, None] - self.gamma_hat) * self.lam[None, :], 1e-10)

    # -- stepping ----------------------------------------------------------------------------
    def step(self, n_steps: int, adapt: bool = False) -> Block:
        if self.marginal and getattr(self, "block", False):
            return Block.stack(self._step_block(n_steps, adapt))
        if self.marginal:
            return self._step_marginal(n_steps, adapt)
        target = float(self.options.get("target_acceptance", 0.45))
        space = self.posterior.space
        rows = []
        m = self.theta.shape[0]
        for _ in range(n_steps):
            w = self._w(self.theta)
            mu = self.yhat[None, :] / w
            z = self._z(self.theta)
            y = z @ self.Ginv.T
            rho = np.sqrt(max(0.0, 1.0 - self.beta**2))
            xi = self.rng.standard_normal(y.shape)
            yp = mu + rho * (y - mu) + self.beta * xi / np.sqrt(w)
            prop = self.theta.copy()
            zp = yp @ self.G.T
            prop[:, self.idx] = self._theta_idx(zp)
            lp, bl = self.evaluate(prop)
            jac_p = zp[:, self.logc].sum(axis=1)  # log |d theta / d z|
            jac_c = z[:, self.logc].sum(axis=1)
            ref_p = -0.5 * np.sum(w * (yp - mu) ** 2, axis=1)
            ref_c = -0.5 * np.sum(w * (y - mu) ** 2, axis=1)
            with np.errstate(invalid="ignore"):
                log_a = (lp + jac_p - ref_p) - (self.logp + jac_c - ref_c)
            acc = np.log(self.rng.uniform(size=m)) < log_a
            lprior_p = space.log_prior(prop)
            self.theta = np.where(acc[:, None], prop, self.theta)
            self.logp = np.where(acc, lp, self.logp)
            self.blobs = np.where(acc[:, None], bl, self.blobs)
            self.loglik = np.where(acc, lp - lprior_p, self.loglik)
            if self.gi is not None:
                self.theta[:, self.gi] = self._draw_gamma(self.theta)
                self.logp = self.loglik + space.log_prior(self.theta)
            if adapt:
                zc = self._z(self.theta)
                self.mom_n += m
                self.mom_1 += zc.sum(axis=0)
                self.mom_2 += zc.T @ zc
                if self.gi is not None:
                    self.mom_g += float(self.theta[:, self.gi].sum())
                self.k_adapt += 1
                gain = 2.0 / (1.0 + self.k_adapt) ** 0.6
                self.beta = float(min(1.0, self.beta * np.exp(gain * (acc.mean() - target))))
                if self.refit_every and self.k_adapt % self.refit_every == 0:
                    self._refit()
            rows.append((self.theta.copy(), self.logp.copy(), self.blobs.copy(), acc, m))
        return Block.stack(rows)

    def _extra_state(self):
        if self.marginal and getattr(self, "block", False):
            return self._extra_state_block()
        if self.marginal:
            return self._extra_state_marginal()
        extra = {"beta": self.beta, "k_adapt": self.k_adapt, "gi": self.gi,
                 "gamma_hat": self.gamma_hat, "mom_n": self.mom_n, "mom_g": self.mom_g}
        arrays = {"G": self.G, "Ginv": self.Ginv, "lam": self.lam, "idx": self.idx,
                  "logc": self.logc, "gcols": self.gcols, "mom_1": self.mom_1,
                  "mom_2": self.mom_2,
                  "scale": self.scale, "yhat": self.yhat, "hcols": self.hcols,
                  "loglik": self.loglik}
        return extra, arrays

    def _load_extra_state(self, extra, arrays):
        self.marginal = bool(extra.get("marginal", False))
        self.block = bool(extra.get("block", False))
        if self.block:
            self._load_extra_state_block(extra, arrays)
            return
        if self.marginal:
            self._load_extra_state_marginal(extra, arrays)
            return
        self.beta = float(extra["beta"])
        self.k_adapt = int(extra["k_adapt"])
        self.gi = None if extra["gi"] is None else int(extra["gi"])
        self.gamma_hat = float(extra["gamma_hat"])
        self.mom_n, self.mom_g = float(extra["mom_n"]), float(extra["mom_g"])
        self.gcols = np.array(arrays["gcols"]).astype(int)
        for k in ("G", "Ginv", "lam", "scale", "yhat", "loglik", "mom_1", "mom_2"):
            setattr(self, k, np.array(arrays[k], dtype=float))
        self.idx = np.array(arrays["idx"]).astype(int)
        self.hcols = np.array(arrays["hcols"]).astype(int)
        self.logc = np.array(arrays["logc"]) > 0.5
