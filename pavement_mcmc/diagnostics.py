"""Convergence and mixing diagnostics: pure functions on chain arrays.

Chains are arrays shaped ``(n_steps, n_chains, n_params)`` (the layout of emcee's
``get_chain()``). A 2-D array is read as ``(n_steps, n_chains)`` of one parameter and a 1-D
array as a single chain of one parameter. Per-parameter results are arrays of shape
``(n_params,)`` (``(1,)`` for 1-D and 2-D input).

Nothing here prints. A diagnostic that cannot be trusted raises :class:`AutocorrError` (carrying
the estimate) or, when asked to be quiet, emits an :class:`AutocorrWarning`.

Notes on emcee
--------------
emcee's walkers are *not* independent chains: every stretch move uses the positions of the other
walkers. Quantities that treat walkers as independent replicates (ESS = N M / tau, split-R-hat,
the pooled Geweke test, MCSE) are therefore approximations; R-hat across walkers in particular is
optimistic. The integrated autocorrelation time averaged over walkers is the diagnostic emcee's
authors recommend.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy import special

__all__ = [
    "AutocorrError",
    "AutocorrWarning",
    "GewekeResult",
    "SegmentSummary",
    "acceptance_over_time",
    "autocorrelation",
    "autocovariance_norm",
    "choose_burn_in",
    "ess",
    "geweke",
    "integrated_time",
    "is_drifting",
    "mcse",
    "segment_summary",
    "split_rhat",
    "summary",
    "trend_z",
]


class AutocorrError(Exception):
    """The chain is too short to trust the integrated autocorrelation time.

    Attributes
    ----------
    tau : ndarray, shape (n_params,)
        The (untrustworthy) estimate, usable with caution.
    """

    def __init__(self, tau: np.ndarray, message: str) -> None:
        super().__init__(message)
        self.tau = tau


class AutocorrWarning(UserWarning):
    """Warning issued instead of :class:`AutocorrError` when ``quiet=True``."""


_FFT_BYTES = 2**28  # memory budget of one batch of FFTs


def _as_3d(x: np.ndarray) -> np.ndarray:
    """View ``x`` as ``(n_steps, n_chains, n_params)`` float64."""
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        return x[:, None, None]
    if x.ndim == 2:
        return x[:, :, None]
    if x.ndim == 3:
        return x
    raise ValueError(f"chain must be 1-D, 2-D or 3-D (n_steps, n_chains, n_params); got {x.shape}")


def _next_pow_two(n: int) -> int:
    return 1 << max(0, int(n - 1).bit_length())


def autocorrelation(x: np.ndarray) -> np.ndarray:
    """Normalised autocorrelation function, averaged over chains.

    Parameters
    ----------
    x : array_like, shape (n_steps, n_chains, n_params), (n_steps, n_chains) or (n_steps,)

    Returns
    -------
    rho : ndarray, shape (n_steps, n_params)
        ``rho[k]`` is the lag-k autocorrelation: each chain's FFT estimate (biased, divided by
        ``n_steps``) normalised by its own lag-0 value, then averaged over chains. A chain with
        zero variance contributes ``rho = 1`` at every lag (it never decorrelates).
    """
    x = _as_3d(x)
    n, m, p = x.shape
    n_fft = 2 * _next_pow_two(n)
    step = max(1, _FFT_BYTES // ((n_fft // 2 + 1) * m * 16))  # parameters per FFT batch
    rho = np.empty((n, p))
    for lo in range(0, p, step):
        blk = x[:, :, lo : lo + step]
        f = np.fft.rfft(blk - blk.mean(axis=0), n=n_fft, axis=0)
        acov = np.fft.irfft(f * np.conjugate(f), n=n_fft, axis=0)[:n]
        var0 = acov[0]
        with np.errstate(invalid="ignore", divide="ignore"):
            r = np.where(var0 > 0, acov / np.where(var0 > 0, var0, 1.0), 1.0)
        rho[:, lo : lo + step] = r.mean(axis=1)
    return rho


def _sokal_tau(x: np.ndarray, c: float) -> np.ndarray:
    """Integrated time with Sokal's automatic window, no length check. Shape (n_params,)."""
    rho = autocorrelation(x)
    taus = 2.0 * np.cumsum(rho, axis=0) - 1.0
    n = taus.shape[0]
    lags = np.arange(n)[:, None]
    inside = lags < c * taus
    # The window is the first lag M with M >= c * tau(M); if none, the last lag.
    window = np.where(inside.all(axis=0), n - 1, np.argmin(inside, axis=0))
    tau = taus[window, np.arange(taus.shape[1])]
    constant = np.all(rho == 1.0, axis=0) & (n > 1)
    return np.where(constant, np.inf, tau)


def integrated_time(x: np.ndarray, c: float = 5, tol: float = 50, quiet: bool = False) -> np.ndarray:
    r"""Integrated autocorrelation time per parameter (Sokal's automatic window).

    .. math:: \tau = 1 + 2 \sum_{k=1}^{M} \rho(k),

    with :math:`\rho` the FFT autocorrelation averaged over chains (as in emcee's
    ``autocorr.integrated_time``) and the window :math:`M` the smallest lag with
    :math:`M \ge c\, \tau(M)` (Sokal 1997, p. 16; Goodman & Weare 2010).

    Parameters
    ----------
    x : array_like, shape (n_steps, n_chains, n_params), (n_steps, n_chains) or (n_steps,)
    c : float
        Window constant.
    tol : float
        The estimate is trusted only if ``n_steps >= tol * tau``.
    quiet : bool
        If True, warn (:class:`AutocorrWarning`) instead of raising when the chain is too short.

    Returns
    -------
    tau : ndarray, shape (n_params,)
        In steps. ``inf`` for a parameter that never moves.

    Raises
    ------
    AutocorrError
        If ``n_steps < tol * tau`` for some parameter and ``quiet`` is False; ``.tau`` holds the
        estimate.
    """
    x = _as_3d(x)
    n_steps = x.shape[0]
    tau = _sokal_tau(x, c)
    short = tau > n_steps / tol if tol > 0 else np.zeros(tau.shape, dtype=bool)
    if np.any(short):
        msg = (
            f"the chain ({n_steps} steps) is shorter than {tol:g} integrated autocorrelation "
            f"times for {int(short.sum())} parameter(s) (indices {np.flatnonzero(short).tolist()});"
            f" tau = {np.array2string(tau, precision=3)}. Run a longer chain."
        )
        if not quiet:
            raise AutocorrError(tau, msg)
        warnings.warn(msg, AutocorrWarning, stacklevel=2)
    return tau


def ess(x: np.ndarray, c: float = 5) -> np.ndarray:
    """Effective sample size per parameter, ``n_steps * n_chains / tau``.

    ``tau`` is :func:`integrated_time` without the length check. For emcee walkers this is an
    approximation: the walkers are not independent, so the ``n_chains`` factor overstates the
    information when the ensemble is strongly correlated.

    Returns
    -------
    ndarray, shape (n_params,)
    """
    x = _as_3d(x)
    return x.shape[0] * x.shape[1] / _sokal_tau(x, c)


def mcse(x: np.ndarray, c: float = 5) -> np.ndarray:
    """Monte Carlo standard error of the posterior mean per parameter, ``sd / sqrt(ess)``.

    Returns
    -------
    ndarray, shape (n_params,)
    """
    x = _as_3d(x)
    sd = x.reshape(-1, x.shape[2]).std(axis=0, ddof=1)
    return sd / np.sqrt(ess(x, c))


def _rhat_basic(x: np.ndarray) -> np.ndarray:
    """Classic potential scale reduction for ``(n, m, p)`` chains (no splitting)."""
    n = x.shape[0]
    means = x.mean(axis=0)
    w = x.var(axis=0, ddof=1).mean(axis=0)
    b_over_n = means.var(axis=0, ddof=1)
    var_hat = (n - 1) / n * w + b_over_n
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.sqrt(var_hat / w)
    return np.where((w == 0) & (b_over_n == 0), 1.0, r)


def _average_ranks(a: np.ndarray) -> np.ndarray:
    """Ranks 1..N along the last axis, ties sharing their average rank (MH chains repeat)."""
    order = np.argsort(a, axis=-1)
    s = np.take_along_axis(a, order, axis=-1)
    n = a.shape[-1]
    idx = np.broadcast_to(np.arange(n), a.shape)
    first = np.ones(a.shape, dtype=bool)
    first[..., 1:] = s[..., 1:] != s[..., :-1]
    last = np.ones(a.shape, dtype=bool)
    last[..., :-1] = first[..., 1:]
    start = np.maximum.accumulate(np.where(first, idx, 0), axis=-1)
    stop = np.flip(np.minimum.accumulate(np.flip(np.where(last, idx, n - 1), -1), axis=-1), -1)
    ranks = np.empty(a.shape)
    np.put_along_axis(ranks, order, (start + stop) / 2.0 + 1.0, axis=-1)
    return ranks


def _rank_normalize(x: np.ndarray) -> np.ndarray:
    """Rank-normalise over all draws of each parameter (Vehtari et al. 2021, eq. 14)."""
    n, m, p = x.shape
    flat_t = np.ascontiguousarray(x.reshape(n * m, p).T)  # (p, N): sort contiguous rows
    z = special.ndtri((_average_ranks(flat_t) - 0.375) / (n * m + 0.25))
    return z.T.reshape(n, m, p)


def split_rhat(x: np.ndarray, rank_normalized: bool = True) -> np.ndarray:
    r"""Split-:math:`\hat R` per parameter.

    Each chain is cut into halves (the middle draw is dropped if ``n_steps`` is odd) and the
    Gelman–Rubin statistic is computed over the ``2 n_chains`` half-chains. With
    ``rank_normalized`` (default) this is the rank-normalised version of Vehtari, Gelman,
    Simpson, Carpenter & Bürkner (2021): the maximum of the bulk R-hat (rank-normalised draws) and
    the tail R-hat (rank-normalised absolute deviations from the median). Values above 1.01
    (strict) or 1.1 (lenient) indicate non-convergence.

    emcee's walkers are not independent chains, so R-hat across walkers is optimistic: walkers
    that move together look converged to each other. Prefer several independent runs, or use the
    integrated autocorrelation time.

    Returns
    -------
    ndarray, shape (n_params,)
    """
    x = _as_3d(x)
    half = x.shape[0] // 2
    if half < 2:
        raise ValueError(f"split_rhat needs at least 4 steps; got {x.shape[0]}")
    split = np.concatenate([x[:half], x[-half:]], axis=1)
    if not rank_normalized:
        return _rhat_basic(split)
    bulk = _rhat_basic(_rank_normalize(split))
    folded = np.abs(split - np.median(split.reshape(-1, split.shape[2]), axis=0))
    tail = _rhat_basic(_rank_normalize(folded))
    return np.maximum(bulk, tail)


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
    walkers this is an approximation, see the module notes).

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


def acceptance_over_time(accepted: np.ndarray, window: int) -> np.ndarray:
    """Rolling acceptance fraction.

    Parameters
    ----------
    accepted : array_like of bool, shape (n_steps, n_chains) or (n_steps,)
    window : int
        Number of steps in the trailing window.

    Returns
    -------
    ndarray, shape (n_steps,)
        Entry ``i`` is the fraction of accepted proposals over steps
        ``max(0, i - window + 1) .. i`` and all chains (shorter windows at the start).
    """
    if window < 1:
        raise ValueError(f"window must be >= 1; got {window}")
    a = np.asarray(accepted, dtype=float)
    per_step = a.mean(axis=1) if a.ndim == 2 else a
    csum = np.concatenate([[0.0], np.cumsum(per_step)])
    idx = np.arange(1, per_step.size + 1)
    lo = np.maximum(idx - window, 0)
    return (csum[idx] - csum[lo]) / (idx - lo)


def autocovariance_norm(
    x: np.ndarray, max_lag: int, ord: str | int = "fro", standardize: bool = True
) -> np.ndarray:
    r"""Norm of the parameter vector's autocovariance function, normalised by lag 0.

    .. math:: \Gamma(k) = \frac{1}{n} \sum_{t=0}^{n-k-1} (x_t - \bar x)(x_{t+k} - \bar x)^T,
              \qquad g(k) = \lVert \Gamma(k) \rVert / \lVert \Gamma(0) \rVert,

    averaged over chains (each centred on its own mean). For an AR(1) chain,
    :math:`g(k) = \phi^k`.

    Parameters
    ----------
    x : array_like, shape (n_steps, n_chains, n_params), (n_steps, n_chains) or (n_steps,)
    max_lag : int
        Largest lag (``< n_steps``).
    ord : {"fro", 2}
        Frobenius or spectral (2-) norm of the ``(n_params, n_params)`` lag-k matrix.
    standardize : bool
        Divide each parameter by its pooled standard deviation first, so parameters in very
        different units (kappa ~ 1 W m-1 K-1, C ~ 1e6 J m-3 K-1) weigh alike.

    Returns
    -------
    ndarray, shape (max_lag + 1,)
        Cost is O(n_params^2 n_chains n_steps log n_steps); thin long chains first.
    """
    x = _as_3d(x)
    n, m, p = x.shape
    if not 0 <= max_lag < n:
        raise ValueError(f"max_lag must be in [0, {n - 1}]; got {max_lag}")
    y = x - x.mean(axis=0)
    if standardize:
        sd = x.reshape(n * m, p).std(axis=0)
        y = y / np.where(sd > 0, sd, 1.0)
    n_fft = 2 * _next_pow_two(n)
    gamma = np.zeros((max_lag + 1, p, p))
    step = max(1, _FFT_BYTES // ((n_fft // 2 + 1) * p * 16))  # chains per FFT batch
    for lo in range(0, m, step):
        f = np.fft.rfft(y[:, lo : lo + step, :], n=n_fft, axis=0)  # (freq, chains, p)
        for i in range(p):
            # Cross-spectrum of parameter i with all, summed over chains: one inverse FFT.
            cross = np.einsum("wc,wcj->wj", np.conjugate(f[:, :, i]), f)
            gamma[:, i, :] += np.fft.irfft(cross, n=n_fft, axis=0)[: max_lag + 1]
    gamma /= n * m
    norms = np.linalg.norm(gamma, ord=ord, axis=(1, 2))
    return norms / norms[0]


@dataclass(frozen=True)
class SegmentSummary:
    """Per-segment statistics for early-versus-late box plots.

    Attributes
    ----------
    edges : (n_segments + 1,) step indices; segment ``s`` is ``edges[s]:edges[s + 1]``.
    samples : list of (n_seg_steps * n_chains, n_params) arrays, the draws of each segment.
    mean : (n_segments, n_params).
    sd : (n_segments, n_params).
    quantiles : (n_segments, 5, n_params) at ``levels``.
    levels : (5,) the percentiles 2.5, 25, 50, 75, 97.5.
    """

    edges: np.ndarray
    samples: list[np.ndarray]
    mean: np.ndarray
    sd: np.ndarray
    quantiles: np.ndarray
    levels: np.ndarray


def segment_summary(x: np.ndarray, n_segments: int) -> SegmentSummary:
    """Split the chain into ``n_segments`` consecutive, nearly equal segments and summarise each.

    Returns
    -------
    SegmentSummary
    """
    x = _as_3d(x)
    n, m, p = x.shape
    if not 1 <= n_segments <= n:
        raise ValueError(f"n_segments must be in [1, {n}]; got {n_segments}")
    edges = np.linspace(0, n, n_segments + 1).astype(int)
    levels = np.array([2.5, 25.0, 50.0, 75.0, 97.5])
    samples = [x[lo:hi].reshape(-1, p) for lo, hi in zip(edges[:-1], edges[1:], strict=True)]
    return SegmentSummary(
        edges=edges,
        samples=samples,
        mean=np.array([s.mean(axis=0) for s in samples]),
        sd=np.array([s.std(axis=0, ddof=1) if len(s) > 1 else np.zeros(p) for s in samples]),
        quantiles=np.array([np.percentile(s, levels, axis=0) for s in samples]),
        levels=levels,
    )


def _trace(logp: np.ndarray) -> np.ndarray:
    """Chain-averaged log-posterior trace, shape (n_steps,)."""
    lp = np.asarray(logp, dtype=float)
    if lp.ndim == 2:
        return lp.mean(axis=1)
    if lp.ndim == 1:
        return lp
    raise ValueError(f"logp must be (n_steps,) or (n_steps, n_chains); got {lp.shape}")


def choose_burn_in(logp: np.ndarray, method: str = "mser", batch: int = 5, max_fraction: float = 0.5) -> int:
    r"""Choose the burn-in (number of initial steps to discard) from the log-posterior trace.

    The trace is first averaged over chains (one value per step).

    ``method="mser"`` (default) is the MSER-b truncation rule (White 1997; White, Cobb & Spratt
    2000), standard in simulation output analysis. With the trace cut into batches of ``batch``
    steps, :math:`\bar y_j`, discarding the first :math:`d` batches leaves the estimate

    .. math:: \mathrm{MSER}(d) = \frac{1}{(B - d)^2} \sum_{j=d}^{B-1} (\bar y_j - \bar y_{d:})^2,

    the squared standard error of the mean of what is kept. The burn-in is the :math:`d` that
    minimises it, restricted to ``d <= max_fraction * B``: discarding more removes transient bias
    (which inflates the spread) but shrinks the sample, so the minimum balances the two. The
    restriction guards against the known failure of choosing a late point from noise.

    ``method="median"``: the first step at which the trace reaches the median of its last half.
    Simple and robust for a monotone approach from low log-posterior, but it stops at the first
    noisy crossing and so tends to underestimate the transient.

    Parameters
    ----------
    logp : array_like, shape (n_steps,) or (n_steps, n_chains)
    method : {"mser", "median"}
    batch : int
        Batch size for MSER (5 is the usual MSER-5).
    max_fraction : float
        Largest fraction of the chain that may be discarded.

    Returns
    -------
    int
        Number of steps to discard.
    """
    y = _trace(logp)
    n = y.size
    if method == "median":
        ref = np.median(y[n // 2 :])
        return int(np.argmax(y >= ref))
    if method != "mser":
        raise ValueError(f"unknown burn-in method {method!r}; valid: 'mser', 'median'")
    n_b = n // batch
    if n_b < 4:
        raise ValueError(f"trace of {n} steps is too short for MSER with batch {batch}")
    yb = y[: n_b * batch].reshape(n_b, batch).mean(axis=1)
    # Suffix sums give the mean and sum of squares of every tail yb[d:] in O(B).
    s1 = np.cumsum(yb[::-1])[::-1]
    s2 = np.cumsum((yb**2)[::-1])[::-1]
    k = n_b - np.arange(n_b)
    sse = np.maximum(s2 - s1**2 / k, 0.0)
    d_max = max(1, int(max_fraction * n_b))
    mser = sse[:d_max] / k[:d_max] ** 2
    return int(np.argmin(mser)) * batch


def trend_z(logp: np.ndarray, c: float = 5) -> float:
    r"""Standardised slope of a linear trend in the (chain-averaged) log-posterior trace.

    Ordinary least squares slope :math:`\hat\beta` of :math:`y_t` on :math:`t`, with its
    standard error inflated by :math:`\sqrt{\tau}`, :math:`\tau` the integrated autocorrelation
    time of the residuals, so the statistic is approximately standard normal for a stationary
    chain.

    Returns
    -------
    float
        ``beta / se(beta)``.
    """
    y = _trace(logp)
    t = np.arange(y.size, dtype=float)
    t -= t.mean()
    sxx = float(t @ t)
    beta = float(t @ (y - y.mean())) / sxx
    resid = y - y.mean() - beta * t
    s2 = float(resid @ resid) / max(y.size - 2, 1)
    if s2 == 0:
        return 0.0 if beta == 0 else float(np.sign(beta) * np.inf)
    tau = max(float(_sokal_tau(resid, c)[0]), 1.0)
    return beta / np.sqrt(s2 * tau / sxx)


def is_drifting(logp_kept: np.ndarray, z_crit: float = 3.0) -> bool:
    """True if the kept log-posterior trace still has a significant linear trend.

    A chain whose mean log-posterior is still drifting after burn-in is not converged. The test
    is ``|trend_z(logp_kept)| > z_crit`` (default 3, about a 0.3 % false-alarm rate for a
    stationary chain).

    Parameters
    ----------
    logp_kept : array_like, shape (n_steps,) or (n_steps, n_chains)
        The trace after discarding burn-in.
    """
    return bool(abs(trend_z(logp_kept)) > z_crit)


def summary(
    x: np.ndarray, names: list[str] | None = None, max_steps: int | None = 4000
) -> dict[str, dict[str, float]]:
    """Posterior summary and diagnostics per parameter.

    Parameters
    ----------
    x : array_like, shape (n_steps, n_chains, n_params)
        Post-burn-in chain.
    names : list of str, optional
        Parameter names (default ``p0, p1, ...``).
    max_steps : int or None
        Moments and quantiles use every draw; the IACT, split-R-hat and Geweke are computed on
        the chain thinned to at most ``max_steps`` steps (the IACT rescaled to original steps),
        because on long runs (75 000 steps x 32 chains x 115 parameters) they take minutes.
        Thinning by k << tau changes them little; None uses every step.

    Returns
    -------
    dict
        ``{name: {"mean", "sd", "q2.5", "q50", "q97.5", "ess", "mcse", "tau", "rhat",
        "geweke_z", "geweke_rel"}}`` with float values. No length check is applied to ``tau``;
        compare ``tau`` with the chain length yourself (or call :func:`integrated_time`).
    """
    x = _as_3d(x)
    p = x.shape[2]
    names = list(names) if names is not None else [f"p{i}" for i in range(p)]
    if len(names) != p:
        raise ValueError(f"{len(names)} names for {p} parameters")
    flat = x.reshape(-1, p)
    q = np.percentile(flat, [2.5, 50.0, 97.5], axis=0)
    k = max(1, -(-x.shape[0] // max_steps)) if max_steps else 1
    sub = x[::k]
    tau = _sokal_tau(sub, 5) * k
    n_eff = x.shape[0] * x.shape[1] / tau
    sd = flat.std(axis=0, ddof=1)
    rhat = split_rhat(sub) if sub.shape[0] >= 4 else np.full(p, np.nan)
    g = geweke(sub)
    out: dict[str, dict[str, float]] = {}
    for i, name in enumerate(names):
        out[name] = {
            "mean": float(flat[:, i].mean()),
            "sd": float(sd[i]),
            "q2.5": float(q[0, i]),
            "q50": float(q[1, i]),
            "q97.5": float(q[2, i]),
            "ess": float(n_eff[i]),
            "mcse": float(sd[i] / np.sqrt(n_eff[i])),
            "tau": float(tau[i]),
            "rhat": float(rhat[i]),
            "geweke_z": float(g.z[i]),
            "geweke_rel": float(g.rel_diff[i]),
        }
    return out
