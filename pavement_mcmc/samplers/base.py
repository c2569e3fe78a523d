"""What every sampler provides: a block of steps as arrays, and a state that resumes exactly.

A sampler holds many chains (or walkers) stepped together, one vectorised posterior call per
step. :meth:`Sampler.step` returns a :class:`Block`; :meth:`Sampler.get_state` returns a
:class:`~pavement_mcmc.storage.RunState` (positions, adaptation state, random state; floats
round-trip exactly) and :meth:`Sampler.set_state` restores it, so the continuation is
bit-for-bit the run that was never interrupted.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .options import options_from
from .state import RunState


@dataclass(frozen=True)
class NoOptions:
    """A sampler without options."""


@dataclass
class Block:
    """Consecutive steps of every chain.

    Attributes
    ----------
    chain : (n_steps, n_chains, n_free) positions after each step.
    logp : (n_steps, n_chains) log-posterior at those positions.
    blobs : (n_steps, n_chains, n_sensors) RMSE per sensor, degC.
    accepted : (n_steps, n_chains) bool, was the (solver-evaluated) proposal accepted.
    n_evals : number of parameter sets the posterior evaluated (solves) for this block; for
        ``hmc`` the gradient evaluations (each a solve and an adjoint sweep), plus the solves
        of its rough-scale moves (option ``rough_moves``).
    """

    chain: np.ndarray
    logp: np.ndarray
    blobs: np.ndarray
    accepted: np.ndarray
    n_evals: int

    @classmethod
    def stack(cls, steps: list[tuple]) -> Block:
        th, lp, bl, acc, ev = zip(*steps)
        return cls(np.stack(th), np.stack(lp), np.stack(bl), np.stack(acc), int(sum(ev)))


class Sampler:
    """Base class. Subclasses set :attr:`name` and implement the abstract methods.

    Parameters
    ----------
    posterior : a :class:`~pavement_mcmc.posterior.LogPosterior` (or any callable
        ``theta (n, d) -> (logp (n,), blobs (n, s))`` with ``.space`` and ``.ndim``).
    n_chains : number of chains / walkers stepped together (None: the sampler's default).
    seed : seed of the run's :class:`numpy.random.Generator`.
    options : the sampler's typed options: an instance of its :attr:`Options` dataclass or a
        mapping of them (a case's ``[sampler.options]``); an unknown key is refused with the
        valid ones listed.
    """

    name = "base"
    #: True if the sampler adapts its proposal during burn-in (then frozen)
    adaptive = False
    #: the frozen dataclass of the sampler's options
    Options: ClassVar[type] = NoOptions

    def __init__(self, posterior, n_chains: int | None = None, seed: int | None = None,
                 options=None):
        self.posterior = posterior
        self.ndim = int(posterior.ndim)
        self.options = options_from(self.Options, options, f"[sampler.options] of sampler {self.name!r}")
        self.n_chains = int(n_chains or self.default_chains(self.ndim))
        self.rng = np.random.default_rng(seed)
        self.n_prep_evals = 0
        self.theta: np.ndarray | None = None
        self.logp: np.ndarray | None = None
        self.blobs: np.ndarray | None = None

    # -- to implement ------------------------------------------------------------------------
    @staticmethod
    def default_chains(ndim: int) -> int:
        return 32

    def adapt_length(self) -> int:
        """Adaptation (burn-in) steps the run loop gives this sampler by default (0: none)."""
        return 0

    def needs_laplace(self) -> bool:
        """Whether :meth:`prepare` uses a MAP/Laplace approximation (passed as ``laplace``)."""
        return True

    def prepare(self, theta0: np.ndarray | None = None, laplace=None) -> None:
        """Choose initial positions (and whatever the proposal needs); evaluate them.

        ``laplace``: a :class:`~pavement_mcmc.posterior.Laplace` of the posterior (the run
        computes it once when :meth:`needs_laplace`), else the sampler starts without it.
        """
        raise NotImplementedError

    def step(self, n_steps: int, adapt: bool = False) -> Block:
        """Advance every chain ``n_steps`` steps; adapt the proposal only if ``adapt``."""
        raise NotImplementedError

    def _extra_state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """Sampler-specific (JSON dict, named float arrays) for the resume state."""
        return {}, {}

    def _load_extra_state(self, extra: dict, arrays: dict[str, np.ndarray]) -> None:
        pass

    # -- shared ------------------------------------------------------------------------------
    def evaluate(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Posterior at ``theta`` (n, d) -> (logp, blobs), with NaN mapped to -inf."""
        lp, bl = self.posterior(theta)
        lp = np.where(np.isnan(lp), -np.inf, lp)
        return lp, bl

    def get_state(self) -> RunState:
        """Everything needed to continue exactly: positions, adaptation and random state."""
        extra, arrays = self._extra_state()
        extra = {"sampler": self.name, "n_prep_evals": self.n_prep_evals, **extra}
        return RunState.capture(self.theta, self.logp, self.blobs, self.rng, extra, arrays)

    def set_state(self, state: RunState) -> None:
        """Continue from a stored :class:`~pavement_mcmc.storage.RunState`."""
        name = state.extra.get("sampler")
        if name != self.name:
            raise ValueError(f"stored state is of sampler {name!r}, not {self.name!r}")
        self.theta = np.array(state.position, dtype=float)
        self.logp = np.array(state.log_prob, dtype=float)
        self.blobs = np.array(state.blobs, dtype=float)
        self.n_chains = self.theta.shape[0]
        self.rng = state.make_rng()
        self.n_prep_evals = int(state.extra.get("n_prep_evals", 0))
        self._load_extra_state(state.extra, state.arrays)


def finite_draws(draw, n: int, posterior, inflate: float = 1.0) -> np.ndarray:
    """``draw(k, inflate) -> (k, d)`` called until all ``n`` points have a finite posterior
    (rows that fail are redrawn with ``inflate`` shrunk by 0.7, at most 50 rounds)."""
    out = draw(n, inflate)
    for _ in range(50):
        lp, _ = posterior(out)
        bad = ~np.isfinite(lp)
        if not bad.any():
            return out
        inflate *= 0.7
        out[bad] = draw(int(bad.sum()), inflate)
    raise ValueError("could not find finite-posterior starting points near the initial values")


def scale_guess(space, theta: np.ndarray) -> np.ndarray:
    """A per-parameter length scale: the prior sd where finite, else 1 % of ``|value|`` (or 1e-3)."""
    out = []
    for n, v in zip(space.free, theta):
        sd = space[n].prior.sd if hasattr(space[n].prior, "sd") else np.nan
        try:
            sd = float(sd)
        except (TypeError, NotImplementedError):
            sd = np.nan
        out.append(sd if np.isfinite(sd) and sd > 0 else max(0.01 * abs(float(v)), 1e-3))
    return np.array(out)


def start_points(sampler: Sampler, theta0=None, laplace=None, inflate: float = 1.5):
    """Initial positions of every chain and the per-parameter scales.

    With a Laplace approximation: draws from it, spread ``inflate`` times wider (over-dispersed,
    so R-hat can see non-convergence). Without: a ball around ``theta0`` (default: the parameters' values) of
    sd 10 % of :func:`scale_guess`.
    """
    post, rng = sampler.posterior, sampler.rng
    if laplace is not None:
        x = finite_draws(lambda k, f: laplace.draw(rng, k, f), sampler.n_chains, post, inflate)
        return x, laplace.sd
    c = np.asarray(post.space.initial() if theta0 is None else theta0, float)
    sd = scale_guess(post.space, c)
    x = finite_draws(lambda k, f: c + f * 0.1 * sd * rng.standard_normal((k, c.size)),
                     sampler.n_chains, post)
    return x, sd
