r"""Hamiltonian Monte Carlo with the Laplace covariance as metric, reflection at the bounds.

The sampler for Case C: the random walks of :mod:`.fast` need ~100 autocorrelation times of
~500 steps there (116 unknowns, night h against h >= 0), while a Hamiltonian trajectory moves
all of them at once along the gradient, which the solver's adjoint gives for about 1.5
log-posterior evaluations (a solve and its reverse sweep).

Target: with a free smoothness precision gamma (Case C), the posterior of x = every free
parameter but gamma with gamma integrated out, log-likelihood + univariate log-priors +
:math:`\log F(\lVert Dh\rVert^2)` (:mod:`.marginal`; its gradient in h is
:math:`-E[\gamma\mid S]\,D^TDh`), and after every step gamma | h is drawn exactly (no solve),
as in :mod:`.marginal_rw`; otherwise the posterior of all free parameters.

Preparation: the (gamma-marginal) MAP and its Laplace covariance ``Sigma = L L^T``; the chains
start from it, over-dispersed. Coordinates the mode pushes against a bound (night-time h at 0)
take the scale of the exponential the posterior has there, ``1/|d log p / d x|``, not the
curvature's (:func:`.target.bounded_laplace_cov`; the Göttingen window adapted on a third of the
gradients). A parameter along which the metric is far narrower than the posterior's curvature at
the mode (which the windows below cannot widen in time) is widened to it, one far wider (which
costs them ~10x the gradients) narrowed to it (:mod:`.metric_guard`; d gradients; a sound Laplace
covariance is left as it is). Dynamics in whitened coordinates ``u =
L^{-1} x`` (identity mass): leapfrog steps of size ``eps`` (jittered by +-20 % per chain and step,
so no trajectory length resonates), ``n_leapfrog = ceil(trajectory_length / eps)`` of them. Bounds
(h >= 0, kappa, C > 0) are hyperplanes in ``u``; a drift that reaches one is reflected specularly
there (the momentum's component along the plane's normal flips) and continues for the rest of the
step — volume-preserving and reversible, so the Metropolis test on the total energy keeps the
chain exact (Neal 2011, "MCMC using Hamiltonian dynamics", 5.5.1.5); compiled, one chain at a time
(:mod:`.reflect`). The posterior is never evaluated outside the bounds.

Adaptation (burn-in only, then frozen): ``eps`` by dual averaging towards an acceptance rate of
``target_acceptance`` (default 0.8; Hoffman & Gelman 2014), and the metric ``Sigma`` in doubling
windows (as Stan does): at adaptation step ``metric_at`` (default 50) from the pooled chains since
step ``metric_skip`` (10), then at ``2 metric_at`` from those since (each 10 % towards the
correlations of the metric it replaces; ``adapt_metric = False`` keeps the Laplace one); after each
the dual averaging starts again for the new metric; ``metric_windows = 3`` adds one at ``4
metric_at`` (:mod:`.hmc_options`). Adaptation ends 50 steps after the last (:meth:`adapt_length`).

Rough-scale moves (option ``rough_moves``, with a free gamma): after each trajectory, that many
Metropolis moves scaling h's high-frequency part (:mod:`.rough`; one solve each, then one
gradient for each chain that moved), which the trajectories move slowly; dropped at the end of
adaptation if their step was tuned too small to matter (:meth:`.rough.RoughScale.useful`).

Working coordinates (``log_positive``: ``log(x + c)``, ``c`` a Laplace sd, for parameters bounded
at 0 with their mode well above it; ``sqrt_at_zero``: a shifted ``sqrt x`` for those at 0):
:mod:`.coords`, chosen with ``metric_windows`` at the MAP (:mod:`.hmc_options`). Strays: :mod:`.strays`.

A step costs ``n_leapfrog`` gradient evaluations per chain (:attr:`Block.n_evals`; each one
solve and one adjoint sweep, or ``2 d + 1`` solves by central differences without an adjoint).
"""

from __future__ import annotations

import math

import numpy as np

from ..posterior.map import find_map
from ..posterior.marginal import gmrf_of
from .base import Block, Sampler, start_points
from .coords import LOG, SQRT, Coords, log_metric
from .hmc_options import AUTO, LEGACY, HMCOptions, resolve, restored
from .metric_guard import guarded
from .reflect import reflect_drift
from .rough import RoughScale, scale_moves
from .strays import rejoin, strays
from .target import MarginalTarget, bounded_laplace_cov, cholesky_of, draws_around

#: dual-averaging constants (Hoffman & Gelman 2014, section 3.2)
_DA_GAMMA, _DA_T0, _DA_KAPPA = 0.05, 10.0, 0.75
_SCALARS = ("log_eps", "log_eps_bar", "hbar", "mu", "k_adapt", "k_da", "n_leapfrog", "frozen",
            "n_metric", "win_n")
#: reflections in one drift after which the chain's proposal is rejected (a trajectory caught
#: in a corner of the bounds, e.g. a parameter piling up at a bound in a refit)
_MAX_REFLECTIONS = 1000
_ARRAYS = ("idx", "hcols", "hpos", "L", "f", "g", "loglik", "win_1", "win_2", "tlog",
           "shift")


class HMCSampler(Sampler):
    """Reflective HMC with a Laplace metric (see the module docstring)."""

    name = "hmc"
    adaptive = True
    Options = HMCOptions
    #: the ``"auto"`` options as :func:`.hmc_options.resolve` decided them, and why
    chosen: dict = {}
    #: the scale move of h's rough part (:mod:`.rough`; option ``rough_moves``), or None
    rough = None

    @staticmethod
    def default_chains(ndim: int) -> int:
        return 16

    def needs_laplace(self) -> bool:
        return gmrf_of(self.posterior.space) is None

    def adapt_length(self) -> int:
        """The last metric window's end and 50 steps for the step size to settle after it
        (``"auto"`` windows, not yet resolved by :meth:`prepare`: as :data:`LEGACY`)."""
        o = self.options
        windows = LEGACY["metric_windows"] if o.metric_windows == AUTO else o.metric_windows
        return 150 if not o.adapt_metric or windows < 1 else max(150, o.metric_at * 2 ** (windows - 1) + 50)

    # -- preparation -------------------------------------------------------------------------
    def prepare(self, theta0=None, laplace=None) -> None:
        space = self.posterior.space
        self.marginal = gmrf_of(space) is not None
        if self.marginal:  # marginal MAP, Laplace covariance, start points, gamma draw
            tg = self.target = MarginalTarget(self.posterior, theta0=theta0)
            self.n_prep_evals += tg.n_evals
            self.idx, self.hcols, self.gi = tg.idx, tg.hcols, tg.gi
            self.lo, self.hi = tg.lo, tg.hi
            self._set_hpos()
            mode = tg.mmap.theta
            cov = self._bounded(mode, np.array(tg.mmap.cov))
            if self.options.rough_moves:
                self.rough = RoughScale.above(self.hcols.size, self.options.rough_cut)
        else:
            lap = laplace
            if lap is None:
                lap = find_map(self.posterior, theta0)
                self.n_prep_evals += lap.n_evals
            self.idx = np.arange(len(space.free))
            self.hcols, self.gi = np.zeros(0, int), None
            self.lo, self.hi = space.bounds()
            self._set_hpos()
            mode = np.asarray(lap.theta, float)
            cov = self._bounded(mode, np.asarray(lap.cov, float)[np.ix_(self.idx, self.idx)])
        i = self.idx
        sd = np.sqrt(np.diag(cov))
        at0, above = self.lo[i] == 0.0, mode[i] > sd
        z = float(np.median(mode[i][at0] / sd[at0])) if at0.any() else np.inf
        self.options, self.chosen = resolve(self.options, n_params=i.size, n_chains=self.n_chains,
                                            n_at0=int(at0.sum()), n_near=int((at0 & ~above).sum()),
                                            z_median=z)
        self.tlog = np.where(self.options.log_positive & at0 & above, LOG,  # coordinate kinds
                             np.where(self.options.sqrt_at_zero & at0 & ~above, SQRT, 0))
        self.shift = np.sqrt(np.diag(cov)) * np.select(  # the c of sqrt(x + c) and log(x + c)
            [self.tlog == SQRT, self.tlog == LOG], [self.options.sqrt_shift, self.options.log_shift], 0.0)
        self._set_coords()
        self._set_metric(log_metric(cov, mode[i], self.tlog, self.shift))
        if self.tlog.any() or np.any(self.rescale != 1.0):  # around the mode in the working coordinates
            self.theta = self._start_points(mode)
        elif self.marginal:
            self.theta = tg.start_points(self.rng, self.n_chains, cholesky_of(cov))
        else:
            self.theta = start_points(self, laplace=lap)[0]
        d = self.idx.size
        eps0 = float(self.options.step_size or 0.5 * d**-0.25)
        self.log_eps = self.log_eps_bar = float(np.log(eps0))
        self.mu = float(np.log(10.0 * eps0))
        self.hbar, self.k_adapt, self.k_da, self.frozen, self.n_metric = 0.0, 0, 0, False, 0
        self.n_leapfrog = self._n_leapfrog(eps0)
        self.win_n, self.win_1, self.win_2 = 0.0, np.zeros(d), np.zeros((d, d))
        self.f, self.g, self.loglik, self.blobs = self._value_grad_w(self.coords.to_w(self.theta[:, i]))
        self.n_prep_evals += self.n_chains
        self.logp = self._joint_logp(self.theta)

    def _set_hpos(self) -> None:
        pos = {int(c): j for j, c in enumerate(self.idx)}
        self.hpos = np.array([pos[int(c)] for c in self.hcols], dtype=int)

    def _bounded(self, mode: np.ndarray, cov: np.ndarray) -> np.ndarray:
        """The Laplace covariance, bound coordinates at their exponential scale (:func:`.target.
        bounded_laplace_cov`), none far narrower or wider than the posterior (:mod:`.metric_guard`)."""
        i = self.idx
        cov, self.rescale, g0, n = guarded(cov, mode, i, self.lo, self.hi, lambda T: self._value_grad(T)[:2],
                                           np.asarray(self.posterior.space.free)[i])
        self.n_prep_evals += n
        return bounded_laplace_cov(cov, mode[i], g0, self.lo[i], self.hi[i])

    def _start_points(self, mode: np.ndarray, inflate: float = 1.2) -> np.ndarray:
        """Draws of N(mode, inflate^2 metric) in the working coordinates, each standard normal
        clipped to +-2.5: a log coordinate starts within a few of its own sd of the mode, never
        in a Gaussian's far right tail, where in ``log x`` the curvature grows like ``x^2`` and
        a chain would stay stuck. A sqrt coordinate starts at least half its metric sd above 0:
        near 0 the Jacobian's gradient ``1/w`` rejects every trajectory (a chain started at
        ``w`` = 1e-4 sd never moved on the Göttingen window)."""
        i, t = self.idx, self.tlog
        sq = t == SQRT
        floor = 0.5 * np.sqrt(np.diag(self.M))[sq]

        def x_of(w):
            w = np.array(w, float)
            w[:, sq] = np.maximum(np.abs(w[:, sq]), floor)
            return self.coords.to_x(w)

        theta = draws_around(self.rng, self.posterior, self.n_chains, mode, i,
                             self.coords.to_w(mode[None, i])[0], self.L, self.lo[i], self.hi[i], inflate,
                             to_x=x_of, clip=2.5)
        if self.marginal:
            theta[:, self.gi] = self.target.draw_gamma(self.rng, theta)
        return theta

    def _set_coords(self) -> None:
        """The working coordinates of the kinds and shifts, and the bounds in them."""
        self.coords = Coords(self.tlog, self.shift)
        self.lo_w, self.hi_w = self.coords.bounds(self.lo[self.idx], self.hi[self.idx])

    def _value_grad_w(self, w: np.ndarray):
        """:meth:`_value_grad` in the working coordinates ``w`` (:meth:`.coords.Coords.in_log`)."""
        x = self.coords.to_x(w)
        f, g, ll, bl = self._value_grad(self._full(x))
        return (*self.coords.in_log(f, g, w, x), ll, bl)

    def _set_metric(self, cov: np.ndarray) -> None:
        self.L = cholesky_of(0.5 * (cov + cov.T))
        self.M = self.L @ self.L.T  # the metric's columns, for the reflections

    def _n_leapfrog(self, eps: float) -> int:
        traj = self.options.trajectory_length
        return int(np.clip(np.ceil(traj / eps), 1, self.options.max_leapfrog))

    # -- the target --------------------------------------------------------------------------
    def _full(self, X: np.ndarray) -> np.ndarray:
        th = self.theta.copy() if X.shape[0] == self.theta.shape[0] else np.repeat(
            self.theta[:1], X.shape[0], axis=0)
        th[:, self.idx] = X
        return th

    def _value_grad(self, theta: np.ndarray):
        """Target log-density f (n,), its gradient in x (n, d), log-likelihood, blobs."""
        space = self.posterior.space
        with np.errstate(all="ignore"):
            ll, gll, bl = self.posterior.loglik_and_grad(theta)
        if self.marginal:
            gp = np.zeros_like(theta)
            for i, prior in self.target.uni:  # the non-flat univariate priors
                gp[:, i] = prior.grad_logpdf(theta[:, i])
        else:
            gp = space.grad_log_prior(theta)
        g = (gll + gp)[:, self.idx]
        if self.marginal:  # + log F(||Dh||^2), whose gradient in h is -E[gamma | S] D^T D h
            log_f, mean_gamma, DtDh = self.target.tab.terms(theta[:, self.hcols])
            f = ll + self.target.uni_logp(theta) + log_f
            g[:, self.hpos] -= mean_gamma[:, None] * DtDh
        else:
            f = ll + space.log_prior(theta)
        # one memory layout for every gradient (the adjoint's, column-major): it decides
        # BLAS's summation order in ``g @ L``, so a restored ``g`` must have it too
        if math.isfinite(f.sum() + g.sum()):  # the common case: every row finite
            return f, np.asfortranarray(g), ll, bl
        bad = ~(np.isfinite(f) & np.all(np.isfinite(g), axis=1))
        f = np.where(bad, -np.inf, f)
        g = np.asfortranarray(np.where(bad[:, None], 0.0, g))
        return f, g, ll, np.where(bad[:, None], np.inf, bl)

    def _joint_logp(self, theta: np.ndarray) -> np.ndarray:
        if self.marginal:
            return self.loglik + self.target.joint_log_prior(theta, self.target.uni_logp(theta))
        with np.errstate(all="ignore"):
            return np.where(np.isfinite(self.f), self.loglik + self.posterior.space.log_prior(theta),
                            -np.inf)

    # -- dynamics ----------------------------------------------------------------------------
    def _drift(self, x: np.ndarray, p: np.ndarray, eps: np.ndarray):
        """Move for time ``eps`` (per chain) along x-velocity ``L p``, reflecting at the bounds
        (compiled: :func:`.reflect.reflect_drift`).

        Returns ``(x, p, stuck)``: ``stuck`` marks chains still reflecting after
        :data:`_MAX_REFLECTIONS` (their proposal is rejected by the caller, never raised)."""
        lo, hi = self.lo_w, self.hi_w
        v = p @ self.L.T
        xn = x + eps[:, None] * v
        if np.all((xn >= lo) & (xn <= hi)):  # the common case: no bound reached
            return xn, p, np.zeros(x.shape[0], bool)
        x, p = np.array(x, float), np.array(p, float)
        stuck = reflect_drift(x, p, v, self.L, self.M, lo, hi, np.asarray(eps, float),
                              _MAX_REFLECTIONS)
        return x, p, stuck

    def _trajectory(self, eps: np.ndarray):
        """One leapfrog trajectory from the current state; returns the proposal and log alpha."""
        m, d = self.theta.shape[0], self.idx.size
        p0 = self.rng.standard_normal((m, d))
        x = self.coords.to_w(self.theta[:, self.idx])
        e = eps[:, None]
        p = p0 + 0.5 * e * (self.g @ self.L)
        stuck = np.zeros(m, bool)
        for j in range(self.n_leapfrog):
            x, p, st = self._drift(x, p, eps)
            stuck |= st
            f, g, ll, bl = self._value_grad_w(x)
            p = p + (0.5 if j == self.n_leapfrog - 1 else 1.0) * e * (g @ self.L)
        with np.errstate(invalid="ignore", over="ignore"):
            log_a = (f - 0.5 * np.sum(p * p, axis=1)) - (self.f - 0.5 * np.sum(p0 * p0, axis=1))
        log_a = np.where(np.isnan(log_a) | stuck, -np.inf, log_a)
        return self.coords.to_x(x), f, g, ll, bl, log_a

    def step(self, n_steps: int, adapt: bool = False) -> Block:
        if not adapt and not self.frozen:
            self._freeze()
        rows = []
        m = self.theta.shape[0]
        for _ in range(n_steps):
            eps = np.exp(self.log_eps) * self.rng.uniform(0.8, 1.2, size=m)
            x, f, g, ll, bl, log_a = self._trajectory(eps)
            acc = np.log(self.rng.uniform(size=m)) < log_a
            self.theta[:, self.idx] = np.where(acc[:, None], x, self.theta[:, self.idx])
            self.f = np.where(acc, f, self.f)
            self.g = np.where(acc[:, None], g, self.g)
            self.loglik = np.where(acc, ll, self.loglik)
            self.blobs = np.where(acc[:, None], bl, self.blobs)
            n_evals = m * self.n_leapfrog
            if self.rough is not None:
                n_evals += self._rough_moves(adapt)
            if self.marginal:
                self.theta[:, self.gi] = self.target.draw_gamma(self.rng, self.theta)
            self.logp = self._joint_logp(self.theta)
            if adapt:
                self._adapt(float(np.mean(np.exp(np.minimum(log_a, 0.0)))))
                if self.k_adapt == self.options.metric_skip:  # chains stranded by their start
                    rejoin(self.rng, strays(self.f, self.idx.size), self.theta, self.f, self.g, self.loglik,
                           self.blobs, self.logp)
            rows.append((self.theta.copy(), self.logp.copy(), self.blobs.copy(), acc, n_evals))
        return Block.stack(rows)

    def _rough_moves(self, adapt: bool) -> int:
        """The scale moves of h's rough part (:func:`.rough.scale_moves`), then the gradient
        of the chains that moved; returns the solves and gradients spent."""
        th, _, _, moved, n = scale_moves(self.rough, self.rng, self.target, self.theta,
                                         self.loglik, self.blobs, self.options.rough_moves, adapt)
        if moved.any():
            self.theta[moved] = th[moved]
            f, g, ll, bl = self._value_grad_w(self.coords.to_w(th[moved][:, self.idx]))
            self.f[moved], self.g[moved], self.loglik[moved], self.blobs[moved] = f, g, ll, bl
        return n + int(moved.sum())

    # -- adaptation --------------------------------------------------------------------------
    def _adapt(self, accept_prob: float) -> None:
        """Dual averaging of log eps; at step ``metric_at`` the metric from the pooled draws
        of the current window (``metric_skip``, ``metric_at``, ``metric_windows``), and the dual
        averaging restarts for it."""
        self.k_adapt += 1
        self.k_da += 1
        k = self.k_da
        delta = self.options.target_acceptance
        eta = 1.0 / (k + _DA_T0)
        self.hbar = (1.0 - eta) * self.hbar + eta * (delta - accept_prob)
        self.log_eps = self.mu - np.sqrt(k) / _DA_GAMMA * self.hbar
        w = k**-_DA_KAPPA
        self.log_eps_bar = w * self.log_eps + (1.0 - w) * self.log_eps_bar
        o = self.options
        if o.adapt_metric and self.n_metric < o.metric_windows:
            start = o.metric_skip if self.n_metric == 0 else o.metric_at * 2 ** (self.n_metric - 1)
            if self.k_adapt > start:
                x = self.coords.to_w(self.theta[:, self.idx])
                self.win_n += x.shape[0]
                self.win_1 += x.sum(axis=0)
                self.win_2 += x.T @ x
            if self.k_adapt >= o.metric_at * 2**self.n_metric:
                self._metric_from_window()
        self.n_leapfrog = self._n_leapfrog(float(np.exp(self.log_eps)))

    def _metric_from_window(self) -> None:
        """The pooled draws' covariance, 10 % towards the correlations of the metric it replaces."""
        self.n_metric += 1
        n, w1, w2 = self.win_n, self.win_1, self.win_2
        self.win_n, self.win_1, self.win_2 = 0.0, np.zeros_like(w1), np.zeros_like(w2)
        if n < 2 * w1.size:
            return
        mu = w1 / n
        cov = (w2 - n * np.outer(mu, mu)) / (n - 1.0)
        r = np.sqrt(np.diag(cov) / np.diag(self.M))  # the draws' sd over the metric's
        cov = 0.9 * cov + 0.1 * self.M * np.outer(r, r)
        sd = np.sqrt(np.diag(cov))  # positive definite as a correlation matrix (scales 1e-3 to 1e6)
        if np.all(np.isfinite(cov)) and np.all(np.linalg.eigvalsh(cov / np.outer(sd, sd)) > 0):
            self._set_metric(cov)
            # whitened gradients change with the metric; restart the step size search
            self.mu = float(self.log_eps + np.log(10.0))
            self.hbar, self.k_da, self.log_eps_bar = 0.0, 0, float(self.log_eps)

    def _freeze(self) -> None:
        """End of adaptation: the averaged step size, frozen with the metric."""
        self.frozen = True
        if self.rough is not None and not self.rough.useful():
            self.rough = None  # tuned to a step too small to move S (h piled at 0: the grass)
        if self.k_da > 0:
            self.log_eps = self.log_eps_bar
        self.n_leapfrog = self._n_leapfrog(float(np.exp(self.log_eps)))

    # -- state -------------------------------------------------------------------------------
    def _extra_state(self):
        extra = {k: getattr(self, k) for k in _SCALARS}
        extra.update(marginal=self.marginal, gi=self.gi)
        if any(self.chosen.get(k, v) != v for k, v in LEGACY.items()):  # else: as before the rule
            extra["chosen"] = self.chosen
        arrays = {k: np.asarray(getattr(self, k), float) for k in _ARRAYS}
        if self.rough is not None:
            extra["rough"], arrays["rough_modes"] = self.rough.state()
        return extra, arrays

    def _load_extra_state(self, extra, arrays):
        self.marginal = bool(extra["marginal"])
        self.gi = None if extra["gi"] is None else int(extra["gi"])
        auto = self.options.auto_names()
        self.options = restored(self.options, extra.get("chosen"))
        self.chosen = {k: getattr(self.options, k) for k in auto}
        for k in _SCALARS:
            setattr(self, k, extra[k])
        self.k_adapt, self.k_da, self.n_leapfrog = int(self.k_adapt), int(self.k_da), int(self.n_leapfrog)
        self.frozen, self.n_metric = bool(self.frozen), int(self.n_metric)
        # a run saved before log (sqrt shift) coordinates has no "tlog" ("shift"): linear (none)
        none = np.zeros(np.size(arrays["idx"]))
        arrays = {"tlog": none, "shift": none, **arrays}
        for k in _ARRAYS:
            setattr(self, k, np.array(arrays[k], dtype=float))
        for k in ("idx", "hcols", "hpos"):
            setattr(self, k, getattr(self, k).astype(int))
        self.tlog = self.tlog.astype(int)
        self.g = np.asfortranarray(self.g)  # the layout of :meth:`_value_grad`'s (issue 24)
        self.M = self.L @ self.L.T
        self.lo, self.hi = self.posterior.space.bounds()
        self._set_coords()
        if self.marginal:
            self.target = MarginalTarget.restored(self.posterior, self.idx, self.hcols, self.gi)
        if "rough_modes" in arrays:
            self.rough = RoughScale.restored(extra["rough"], arrays["rough_modes"])
