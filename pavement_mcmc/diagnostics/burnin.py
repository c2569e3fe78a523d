"""Choosing the burn-in from the log-posterior trace, and testing the kept trace for drift."""

from __future__ import annotations

import numpy as np

from .autocorr import _sokal_tau


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
