"""Autocorrelation, integrated autocorrelation time, effective sample size and MCSE (of the
mean and of the sd)."""

from __future__ import annotations

import warnings

import numpy as np

from ._arrays import _FFT_BYTES, _as_3d, _next_pow_two


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
    return _rho(x, pooled=False)


def _per_chain_rho(acov: np.ndarray, blk: np.ndarray) -> np.ndarray:
    """Each chain's autocovariance over its own lag-0 value, averaged over chains (emcee's)."""
    var0 = acov[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(var0 > 0, acov / np.where(var0 > 0, var0, 1.0), 1.0)
    return r.mean(axis=1)


def _pooled_rho(acov: np.ndarray, blk: np.ndarray) -> np.ndarray:
    r"""Autocorrelation relative to the pooled variance, which counts the chains' disagreement.

    .. math:: \hat\rho(k) = 1 - \frac{\hat W - \overline{\hat C_j(k)}}{\hat W + \hat B},

    :math:`\hat C_j(k)` chain j's biased lag-k autocovariance, :math:`\hat W` their mean at
    lag 0, :math:`\hat B` the variance of the chain means (ddof 1; 0 for one chain): Vehtari,
    Gelman, Simpson, Carpenter & Bürkner (2021), eq. 10, as Stan and ArviZ compute it. Each chain
    centred on its own mean loses the slow part of its autocorrelation (the per-chain estimate
    is biased low by about ``tau / n`` at every lag); the spread of the chain means puts it back.
    """
    n, m = blk.shape[0], blk.shape[1]
    c = acov.mean(axis=1) / n
    b = blk.mean(axis=0).var(axis=0, ddof=1) if m > 1 else np.zeros(c.shape[1])
    var_plus = c[0] + b
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(var_plus > 0, 1.0 - (c[0] - c) / np.where(var_plus > 0, var_plus, 1.0), 1.0)


def _rho(x: np.ndarray, pooled: bool) -> np.ndarray:
    """Autocorrelation (n_steps, n_params) by FFT, per chain (emcee) or pooled (Stan)."""
    x = _as_3d(x)
    n, m, p = x.shape
    n_fft = 2 * _next_pow_two(n)
    step = max(1, _FFT_BYTES // ((n_fft // 2 + 1) * m * 16))  # parameters per FFT batch
    rho = np.empty((n, p))
    combine = _pooled_rho if pooled else _per_chain_rho
    for lo in range(0, p, step):
        blk = x[:, :, lo : lo + step]
        f = np.fft.rfft(blk - blk.mean(axis=0), n=n_fft, axis=0)
        acov = np.fft.irfft(f * np.conjugate(f), n=n_fft, axis=0)[:n]
        rho[:, lo : lo + step] = combine(acov, blk)
    return rho


def _sokal_tau(x: np.ndarray, c: float, pooled: bool = False) -> np.ndarray:
    """Integrated time with Sokal's automatic window, no length check. Shape (n_params,).
    ``pooled``: from :func:`_pooled_rho` (the ESS's) instead of emcee's per-chain average."""
    rho = _rho(x, pooled)
    taus = 2.0 * np.cumsum(rho, axis=0) - 1.0
    n = taus.shape[0]
    lags = np.arange(n)[:, None]
    inside = lags < c * taus
    # The window is the first lag M with M >= c * tau(M); if none, the last lag.
    window = np.where(inside.all(axis=0), n - 1, np.argmin(inside, axis=0))
    tau = taus[window, np.arange(taus.shape[1])]
    constant = np.all(rho == 1.0, axis=0) & (n > 1)
    # antithetic chains (HMC, tau < 1): a lag-1 correlation below -0.4 closes Sokal's window at
    # lag 1 and hides any slow positive tail, so there take at least Geyer's initial monotone
    # sequence estimate; and, as Stan does, cap the ESS at N log10 N (N = all draws)
    floor = 1.0 / np.log10(max(x.size // (x.shape[2] if x.ndim == 3 else 1), 10))
    tau = np.where(tau < 1.0, np.maximum(tau, _geyer_tau(rho)), tau)
    return np.where(constant, np.inf, np.maximum(tau, floor))


def _geyer_tau(rho: np.ndarray) -> np.ndarray:
    """Geyer's (1992) initial monotone sequence estimate from autocorrelations (n_lags, p):
    ``tau = -1 + 2 sum_k P_k``, ``P_k = rho(2k) + rho(2k+1)`` up to the first negative pair sum,
    each made no larger than the one before."""
    m = rho.shape[0] // 2
    if m == 0:
        return np.ones(rho.shape[1])
    P = rho[: 2 * m : 2] + rho[1 : 2 * m : 2]
    positive = np.cumprod(P > 0, axis=0).astype(bool)
    P = np.minimum.accumulate(np.where(positive, P, 0.0), axis=0)
    return -1.0 + 2.0 * P.sum(axis=0)


def integrated_time(x: np.ndarray, c: float = 5, tol: float = 50, quiet: bool = False) -> np.ndarray:
    r"""Integrated autocorrelation time per parameter (Sokal's automatic window).

    .. math:: \tau = 1 + 2 \sum_{k=1}^{M} \rho(k),

    with :math:`\rho` the FFT autocorrelation averaged over chains (as in emcee's
    ``autocorr.integrated_time``); where that is below 1 (antithetic chains: the window may close
    at lag 1) at least Geyer's initial monotone sequence estimate; at least
    :math:`1/\log_{10} N` (N draws in all: the ESS is capped at :math:`N \log_{10} N`, as in
    Stan), and the window
    :math:`M` the smallest lag with :math:`M \ge c\, \tau(M)` (Sokal 1997, p. 16; Goodman & Weare 2010).

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

    ``tau`` is :func:`integrated_time`'s Sokal window over the autocorrelation relative to the
    pooled variance (:func:`_pooled_rho`, Stan's and ArviZ's), not emcee's per-chain average:
    that one, each chain centred on its own mean, makes the ESS of AR(1) chains 1.2 times too
    large at 50 tau per chain and 1.5 times at 20 tau (``tests/diagnostics/test_diagnostics_crosscheck.py``
    measures it), and ignores chains that disagree. The same, to rounding, for one chain. For emcee
    walkers this is an approximation: the walkers are not independent, so the ``n_chains``
    factor overstates the information when the ensemble is strongly correlated.

    Returns
    -------
    ndarray, shape (n_params,)
    """
    x = _as_3d(x)
    return x.shape[0] * x.shape[1] / _sokal_tau(x, c, pooled=True)


def mcse(x: np.ndarray, c: float = 5) -> np.ndarray:
    """Monte Carlo standard error of the posterior mean per parameter, ``sd / sqrt(ess)``.

    Returns
    -------
    ndarray, shape (n_params,)
    """
    x = _as_3d(x)
    sd = x.reshape(-1, x.shape[2]).std(axis=0, ddof=1)
    return sd / np.sqrt(ess(x, c))


def mcse_sd(x: np.ndarray, c: float = 5) -> np.ndarray:
    """Monte Carlo standard error of the posterior sd per parameter.

    From the squared deviations ``z = (x - mean)^2``: the variance is their mean, its standard
    error ``sd(z) / sqrt(ess(z))``, carried to the sd by the delta method (``/ (2 sd)``), as
    the ``posterior`` R package's ``mcse_sd`` does. Unlike ``sd / sqrt(2 ess(x))`` (the
    Gaussian formula) it sees heavy tails (``sd(z)`` grows with the kurtosis: ``sqrt(2 / n)`` of
    the sd for iid exponential draws against ``sqrt(1 / (2 n))``) and the autocorrelation of
    ``z`` itself, which can differ from that of ``x``.

    Returns
    -------
    ndarray, shape (n_params,)
    """
    x = _as_3d(x)
    flat = x.reshape(-1, x.shape[2])
    z = (x - flat.mean(axis=0)) ** 2
    zf = z.reshape(-1, x.shape[2])
    var = zf.mean(axis=0)
    return zf.std(axis=0, ddof=1) / np.sqrt(ess(z, c)) / (2.0 * np.sqrt(var))


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
