"""Prior distributions with vectorised log-densities.

Every prior evaluates a whole batch of parameter sets at once: ``logpdf(x)`` takes an array of
shape ``(n_sets,)`` and returns ``(n_sets,)``; joint priors (the smoothness prior on h) take a
dict of such arrays. Out-of-support values give ``-inf``, never NaN or a warning.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.special import log_ndtr

_LOG_SQRT_2PI = 0.5 * np.log(2.0 * np.pi)


class Prior:
    """Base class of a univariate prior. Subclasses implement :meth:`logpdf` and :meth:`sample`.

    A prior whose ``-2 log pdf`` is ``((x - mu) / s)^2`` up to a constant inside its support
    (the Gaussian family) reports ``(mu, s)`` as :attr:`gaussian`; the least-squares MAP and
    the criticism then write it as a residual row (:class:`~.space.PriorResiduals`).
    """

    @property
    def gaussian(self) -> tuple[float, float] | None:
        """``(mu, s)`` if ``-2 log pdf = ((x - mu)/s)^2 + const`` on the support, else None."""
        return None

    def logpdf(self, x: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def sample(self, rng: np.random.Generator, size: int) -> np.ndarray:
        raise NotImplementedError

    def grad_logpdf(self, x: np.ndarray) -> np.ndarray:
        """d logpdf / dx inside the support (gradient-based samplers); 0 for flat priors."""
        raise NotImplementedError(f"{type(self).__name__} has no gradient")

    @property
    def mean(self) -> float:
        raise NotImplementedError

    @property
    def sd(self) -> float:
        raise NotImplementedError


@dataclass(frozen=True)
class _Gaussian(Prior):
    """Shared fields of the Gaussian priors: location ``mu`` and scale ``sigma``."""

    mu: float
    sigma: float

    @property
    def gaussian(self) -> tuple[float, float]:
        return (self.mu, self.sigma)

    @property
    def mean(self):
        return self.mu

    @property
    def sd(self):
        return self.sigma

    def grad_logpdf(self, x):
        return -(np.asarray(x, float) - self.mu) / self.sigma**2


@dataclass(frozen=True)
class Normal(_Gaussian):
    """Gaussian prior N(mu, sd^2)."""

    def logpdf(self, x):
        z = (np.asarray(x, float) - self.mu) / self.sigma
        return -0.5 * z * z - np.log(self.sigma) - _LOG_SQRT_2PI

    def sample(self, rng, size):
        return rng.normal(self.mu, self.sigma, size)


@dataclass(frozen=True)
class TruncatedNormal(_Gaussian):
    r"""Gaussian N(mu, sd^2) truncated to ``[lower, upper]`` (default: positive values).

    .. math:: \pi(x) = \frac{\phi((x-\mu)/s)}{s\,[\Phi((u-\mu)/s) - \Phi((l-\mu)/s)]},\ l \le x \le u
    """

    lower: float = 0.0
    upper: float = np.inf

    @cached_property
    def _log_norm(self) -> float:
        """log of the mass inside the bounds (worked out once: a prior is frozen)."""
        a = (self.lower - self.mu) / self.sigma
        b = (self.upper - self.mu) / self.sigma
        # log(Phi(b) - Phi(a)), stable for the usual case b = inf
        if np.isinf(b):
            return float(log_ndtr(-a))
        return float(np.log(np.exp(log_ndtr(b)) - np.exp(log_ndtr(a))))

    def logpdf(self, x):
        x = np.asarray(x, float)
        z = (x - self.mu) / self.sigma
        out = -0.5 * z * z - np.log(self.sigma) - _LOG_SQRT_2PI - self._log_norm
        return np.where((x >= self.lower) & (x <= self.upper), out, -np.inf)

    def sample(self, rng, size):
        from scipy.stats import truncnorm

        a = (self.lower - self.mu) / self.sigma
        b = (self.upper - self.mu) / self.sigma
        return truncnorm.rvs(a, b, loc=self.mu, scale=self.sigma, size=size, random_state=rng)


@dataclass(frozen=True)
class Uniform(Prior):
    """Uniform prior on ``[low, high]``."""

    low: float
    high: float

    def logpdf(self, x):
        x = np.asarray(x, float)
        inside = (x >= self.low) & (x <= self.high)
        return np.where(inside, -np.log(self.high - self.low), -np.inf)

    def sample(self, rng, size):
        return rng.uniform(self.low, self.high, size)

    def grad_logpdf(self, x):
        return np.zeros(np.shape(x))

    @property
    def mean(self):
        return 0.5 * (self.low + self.high)

    @property
    def sd(self):
        return (self.high - self.low) / np.sqrt(12.0)


@dataclass(frozen=True)
class Rayleigh(Prior):
    r"""Rayleigh prior of scale :math:`\gamma_0`: :math:`\pi(\gamma) = \gamma/\gamma_0^2
    \exp(-\tfrac12 (\gamma/\gamma_0)^2)`, :math:`\gamma > 0` (the paper's hyperprior)."""

    scale: float

    def logpdf(self, x):
        x = np.asarray(x, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.log(x) - 2 * np.log(self.scale) - 0.5 * (x / self.scale) ** 2
        return np.where(x > 0, out, -np.inf)

    def sample(self, rng, size):
        return rng.rayleigh(self.scale, size)

    def grad_logpdf(self, x):
        x = np.asarray(x, float)
        with np.errstate(divide="ignore"):
            return 1.0 / x - x / self.scale**2

    @property
    def mean(self):
        return self.scale * np.sqrt(np.pi / 2)

    @property
    def sd(self):
        return self.scale * np.sqrt((4 - np.pi) / 2)


@dataclass(frozen=True)
class Flat(Prior):
    """Improper flat prior (log-density 0); bounds are enforced by the parameter."""

    def logpdf(self, x):
        return np.zeros(np.shape(x))

    def grad_logpdf(self, x):
        return np.zeros(np.shape(x))

    @property
    def mean(self):
        return np.nan

    @property
    def sd(self):
        return np.nan


@dataclass(frozen=True)
class GMRFSmoothness:
    r"""First-order Gaussian Markov random field (smoothness) prior on a sequence h_1..h_N.

    .. math::
        \pi(h \mid \gamma) \propto \gamma^{(N-1)/2} \exp\left(-\tfrac12 \gamma \lVert D h \rVert^2\right)

    with D the (N-1) x N first-difference matrix, so the precision is :math:`\gamma D^T D`, of
    rank N - 1: the prior says nothing about the mean level of h (only positivity bounds it).
    :math:`\gamma` (m^4 K^2 W^-2) is a hyperparameter, usually under a :class:`Rayleigh` prior.

    Parameters
    ----------
    names : the parameter names of h_1..h_N, in time order.
    gamma_name : the name of the precision parameter.
    """

    names: tuple[str, ...]
    gamma_name: str = "gamma"

    def logpdf(self, p: dict[str, np.ndarray]) -> np.ndarray:
        h = np.stack([p[n] for n in self.names], axis=-1)
        g = np.asarray(p[self.gamma_name], float)
        sq = np.sum(np.diff(h, axis=-1) ** 2, axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            out = 0.5 * (len(self.names) - 1) * np.log(g) - 0.5 * g * sq
        return np.where(g > 0, out, -np.inf)

    def grad_logpdf(self, p: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Gradient of :meth:`logpdf` with respect to each h and gamma: {name: (n_sets,)}."""
        h = np.stack([p[n] for n in self.names], axis=-1)
        g = np.asarray(p[self.gamma_name], float)
        dh = np.diff(h, axis=-1)
        DtDh = np.zeros_like(h)
        DtDh[..., :-1] -= dh
        DtDh[..., 1:] += dh
        out = {n: -g * DtDh[..., i] for i, n in enumerate(self.names)}
        with np.errstate(divide="ignore"):
            out[self.gamma_name] = 0.5 * (len(self.names) - 1) / g - 0.5 * np.sum(dh * dh, axis=-1)
        return out


def prior_from_config(spec: dict) -> Prior:
    """Build a prior from a config table, e.g. ``{dist = "truncnormal", mean = 10, sd = 5}``.

    Valid ``dist`` values: normal, truncnormal, uniform, rayleigh, flat.
    """
    spec = dict(spec)
    dist = spec.pop("dist", "truncnormal")
    for key in ("sd", "scale"):
        if key in spec and not (isinstance(spec[key], int | float) and 0 < spec[key] < np.inf):
            raise ValueError(f"prior '{dist}': {key} must be a number > 0, got {spec[key]!r}")
    lo, hi = spec.get("low", spec.get("lower")), spec.get("high", spec.get("upper"))
    if isinstance(lo, int | float) and isinstance(hi, int | float) and not lo < hi:
        raise ValueError(f"prior '{dist}': the lower bound {lo!r} must be below the upper {hi!r}")
    try:
        if dist == "normal":
            return Normal(float(spec["mean"]), float(spec["sd"]))
        if dist == "truncnormal":
            return TruncatedNormal(
                float(spec["mean"]),
                float(spec["sd"]),
                float(spec.get("lower", 0.0)),
                float(spec.get("upper", np.inf)),
            )
        if dist == "uniform":
            return Uniform(float(spec["low"]), float(spec["high"]))
        if dist == "rayleigh":
            return Rayleigh(float(spec["scale"]))
        if dist == "flat":
            return Flat()
    except KeyError as err:
        raise ValueError(f"prior '{dist}' needs the key {err.args[0]!r} (got {spec})") from None
    raise ValueError(
        f"unknown prior dist {dist!r}; valid: normal, truncnormal, uniform, rayleigh, flat"
    )
