"""Geweke's test of an early against a late segment, with the AR spectral density at zero."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ._arrays import _as_3d, _next_pow_two

#: Geweke's |z| bound of one parameter or component (5 % two-sided), and the bound none may pass
GEWEKE_Z, GEWEKE_Z_MAX = 1.96, 3.5
#: steps the Geweke verdict thins a kept chain to (as :func:`~pavement_mcmc.diagnostics.summary`)
GEWEKE_ROWS = 4000
#: the fewest steps the test takes (an early segment, 10 % of them, of 2 steps)
GEWEKE_MIN_ROWS = 20


class GewekeResult(NamedTuple):
    """Geweke's comparison of an early and a late segment of the chain, per parameter.

    Attributes
    ----------
    rel_diff : ``|mean_first - mean_last| / |mean_last|`` (the paper's relative difference).
    z : ``(mean_first - mean_last) / sqrt(S_first(0)/n_first + S_last(0)/n_last)``.
    mean_first, mean_last : the segment means.
    """

    rel_diff: np.ndarray
    z: np.ndarray
    mean_first: np.ndarray
    mean_last: np.ndarray

    @property
    def passed(self) -> np.ndarray:
        """``|z| < 1.96`` per parameter (5 % two-sided level)."""
        return np.abs(self.z) < 1.96


def _spectrum0_ar(seg: np.ndarray, max_order: int = 10) -> np.ndarray:
    """Spectral density at zero of each chain, ``S(0) = sigma^2 tau``, by an AR(p) fit.

    Yule-Walker (Levinson-Durbin) fits of orders 0..max_order, order chosen by AIC, then
    ``S(0) = sigma_e^2 / (1 - sum(phi))^2`` (the estimator of R coda's ``spectrum0.ar``).
    Returns shape (n_chains, n_params).
    """
    n, m, p = seg.shape
    max_order = int(min(max_order, max(n // 4, 0)))
    y = (seg - seg.mean(axis=0)).reshape(n, m * p)
    f = np.fft.rfft(y, n=2 * _next_pow_two(n), axis=0)
    r = np.fft.irfft(f * np.conjugate(f), axis=0)[: max_order + 1] / n
    sigma2 = r[0].copy()
    best_aic = n * np.log(np.where(sigma2 > 0, sigma2, 1.0))
    best_s0 = sigma2.copy()
    phi = np.zeros((0, m * p))
    with np.errstate(invalid="ignore", divide="ignore"):
        for k in range(1, max_order + 1):
            acc = r[k] - np.sum(phi * r[k - 1 : 0 : -1], axis=0)
            refl = np.where(sigma2 > 0, acc / np.where(sigma2 > 0, sigma2, 1.0), 0.0)
            phi = np.vstack([phi - refl * phi[::-1], refl])
            sigma2 = sigma2 * (1.0 - refl**2)
            aic = n * np.log(np.where(sigma2 > 0, sigma2, 1.0)) + 2 * k
            s0 = sigma2 / (1.0 - phi.sum(axis=0)) ** 2
            better = (aic < best_aic) & (sigma2 > 0) & np.isfinite(s0)
            best_aic = np.where(better, aic, best_aic)
            best_s0 = np.where(better, s0, best_s0)
    return best_s0.reshape(m, p)


def _var_of_mean(seg: np.ndarray) -> np.ndarray:
    """Variance of a segment's mean pooled over chains, ``mean_j S_j(0) / (n m)``."""
    n, m, _ = seg.shape
    return _spectrum0_ar(seg).mean(axis=0) / (n * m)


def geweke(x: np.ndarray, first: float = 0.1, last: float = 0.5) -> GewekeResult:
    r"""Geweke (1992) test: does the first part of the chain have the mean of the last part?

    The spectral density at zero of each segment, :math:`S(0) = s^2 \tau`, is estimated as in
    R coda's ``geweke.diag``: an autoregressive model AR(p), p <= 10 chosen by AIC, is fitted to
    the segment and :math:`S(0) = \sigma_e^2 / (1 - \sum_i \phi_i)^2`. (A Sokal-window
    :math:`\tau` computed on the short first segment is biased low by the mean subtraction and
    makes :math:`z` too wide.) Then :math:`z` is approximately standard normal for a stationary
    chain; ``|z| < 1.96`` passes. Several chains are pooled (segment means over all chains; for emcee
    walkers this is an approximation, see the notes in :mod:`pavement_mcmc.diagnostics`).

    Parameters
    ----------
    x : array_like, shape (n_steps, n_chains, n_params), (n_steps, n_chains) or (n_steps,)
    first, last : float
        Fractions of the chain forming the early and the late segment; ``first + last <= 1``.

    Returns
    -------
    GewekeResult
        Per-parameter arrays ``rel_diff``, ``z``, ``mean_first``, ``mean_last``.
    """
    if not (0 < first and 0 < last and first + last <= 1):
        raise ValueError(f"need 0 < first, 0 < last, first + last <= 1; got {first}, {last}")
    x = _as_3d(x)
    n = x.shape[0]
    n_a, n_b = int(first * n), int(last * n)
    if n_a < 2 or n_b < 2:
        raise ValueError(f"chain of {n} steps is too short for segments {first}, {last}")
    a, b = x[:n_a], x[n - n_b :]
    mean_a = a.mean(axis=(0, 1))
    mean_b = b.mean(axis=(0, 1))
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.abs(mean_a - mean_b) / np.abs(mean_b)
        z = (mean_a - mean_b) / np.sqrt(_var_of_mean(a) + _var_of_mean(b))
    return GewekeResult(rel, z, mean_a, mean_b)


def geweke_components(x: np.ndarray, first: float = 0.1, last: float = 0.5) -> np.ndarray:
    """Geweke's z for the principal components of the chain instead of its parameters.

    Correlated parameters (Case C's 112 smooth h values) fail Geweke together: one ordinary
    2-3 sigma fluctuation of their common level flags twenty of them, so counting flagged
    parameters against the 5 % expected by chance is wrong for them. The chain's pooled
    correlation matrix (the parameters standardised first, so units do not matter) is
    diagonalised and :func:`geweke` applied to each component with nonzero variance (relative
    eigenvalue > 1e-10): the components are uncorrelated at lag 0, so roughly 5 % of them have
    ``|z| >= 1.96`` for a stationary chain. Parameters that never move are left out. Returns
    their z values.
    """
    x = _as_3d(np.asarray(x, float))
    flat = x.reshape(-1, x.shape[2])
    sd = flat.std(axis=0)
    moving = sd > 0
    y = (x[:, :, moving] - flat[:, moving].mean(axis=0)) / sd[moving]
    corr = np.atleast_2d(np.cov(y.reshape(-1, y.shape[2]), rowvar=False))
    e, V = np.linalg.eigh(0.5 * (corr + corr.T))
    keep = e > 1e-10 * max(float(e.max()), 1e-300)
    return geweke(y @ V[:, keep], first, last).z


class GewekeVerdict(NamedTuple):
    """Geweke's test of a kept chain as a run is judged by it (:func:`geweke_verdict`).

    Attributes
    ----------
    z : per parameter.
    zc : per principal component (:func:`geweke_components`).
    failed : the chain's early and late means differ by more than chance, or the chain is
        shorter than :data:`GEWEKE_MIN_ROWS` steps.
    n_rows : the steps it was judged on.
    """

    z: np.ndarray
    zc: np.ndarray
    failed: bool
    n_rows: int

    @property
    def n_fail_components(self) -> int:
        return int(np.sum(~(np.abs(self.zc) < GEWEKE_Z)))

    def text(self) -> str:
        """The failure in words (``n`` of ``m`` components, against the 5 % of chance)."""
        if self.n_rows < GEWEKE_MIN_ROWS:
            return f"{self.n_rows} kept steps are too few for it ({GEWEKE_MIN_ROWS} needed)"
        return (f"{self.n_fail_components} of {self.zc.size} principal components differ "
                f"(about {0.05 * self.zc.size:.1f} expected by chance)")


def geweke_verdict(kept: np.ndarray) -> GewekeVerdict:
    """Do the early and late means of a kept chain differ by more than chance?

    The chain (thinned to at most :data:`GEWEKE_ROWS` steps) fails when a parameter's or a
    principal component's ``|z|`` exceeds :data:`GEWEKE_Z_MAX` (or is not finite), or when more
    than 10 % of the components (5 % by chance; at least 2) have ``|z| >= 1.96``. The stopping
    rule and the assessment both judge by this one function, on the same rows.
    """
    x = _as_3d(np.asarray(kept, float))
    sub = x[:: max(1, -(-x.shape[0] // GEWEKE_ROWS))]
    if sub.shape[0] < GEWEKE_MIN_ROWS:  # no early segment of 2 steps: the test cannot pass
        return GewekeVerdict(np.full(x.shape[2], np.nan), np.zeros(0), True, sub.shape[0])
    z = geweke(sub).z
    zc = geweke_components(sub)
    n_fail = int(np.sum(~(np.abs(zc) < GEWEKE_Z)))
    failed = bool(np.any(~(np.abs(z) <= GEWEKE_Z_MAX)) or np.any(~(np.abs(zc) <= GEWEKE_Z_MAX))
                  or n_fail > max(1, 0.1 * zc.size))
    return GewekeVerdict(z, zc, failed, sub.shape[0])
