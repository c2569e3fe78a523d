r"""Working coordinates of ``hmc``: ``w = log x`` for the parameters a mask ``tlog`` selects,
``w = x`` for the others (the option ``log_positive``; the draws are stored as ``x``).

In ``w`` the target density gains the Jacobian :math:`\sum_{tlog} w` and its gradient is
:math:`x\,\partial f/\partial x + 1` there (:func:`in_log`); a bound ``[0, hi]`` becomes
``(-inf, log hi]``; a covariance of ``x`` is carried over by :func:`log_metric`.
"""

from __future__ import annotations

import numpy as np

#: floor of a log coordinate's value (a point exactly on the bound 0)
_TINY = 1e-300


def to_w(x: np.ndarray, tlog: np.ndarray) -> np.ndarray:
    """Working coordinates (n, d) of points ``x`` (n, d)."""
    w = np.array(x, float)
    w[:, tlog] = np.log(np.maximum(w[:, tlog], _TINY))
    return w


def to_x(w: np.ndarray, tlog: np.ndarray) -> np.ndarray:
    """Points ``x`` (n, d) of working coordinates ``w`` (n, d)."""
    x = np.array(w, float)
    x[:, tlog] = np.exp(w[:, tlog])
    return x


def bounds_w(lo: np.ndarray, hi: np.ndarray, tlog: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bounds ``(lo, hi)`` (d,) in the working coordinates (``tlog`` ones have ``lo = 0``);
    a finite upper one is the largest float whose ``exp`` does not exceed ``hi`` (``exp(log
    hi)`` rounds above ``hi`` for about half of all values, e.g. 0.1 and 3)."""
    lo, hi = np.array(lo, float), np.array(hi, float)
    top = hi[tlog]
    with np.errstate(divide="ignore"):
        w = np.log(top)
    for _ in range(8):
        over = np.exp(w) > top
        if not over.any():
            break
        w[over] = np.nextafter(w[over], -np.inf)
    lo[tlog], hi[tlog] = -np.inf, w
    return lo, hi


def in_log(f: np.ndarray, g: np.ndarray, w: np.ndarray, x: np.ndarray, tlog: np.ndarray):
    """Log-density ``f`` (n,) and its gradient ``g`` (n, d) in ``x`` carried to ``w``
    (``g`` is changed in place; rows with a non-finite ``f`` get a zero gradient)."""
    if tlog.any():
        f = f + np.sum(w[:, tlog], axis=1)
        g[:, tlog] = np.where(np.isfinite(f)[:, None], g[:, tlog] * x[:, tlog] + 1.0, 0.0)
    return f, g


def log_metric(cov: np.ndarray, x: np.ndarray, tlog: np.ndarray) -> np.ndarray:
    """The covariance ``cov`` of ``x`` carried to the coordinates ``log x`` where ``tlog``.

    At a mode inside the bounds, the delta method (``cov_ij / (x_i x_j)``). At a mode on the
    bound 0 the posterior is close to an exponential (:func:`.target.bounded_laplace_cov`), and
    the log of an exponential variable has the variance pi^2/6 whatever its scale: that, and no
    correlations.
    """
    d = np.where(tlog & (x > 0.0), x, 1.0)
    out = cov / np.outer(d, d)
    z = tlog & ~(x > 0.0)
    out[z, :] = 0.0
    out[:, z] = 0.0
    out[z, z] = np.pi**2 / 6.0
    return out
