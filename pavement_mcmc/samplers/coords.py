r"""Working coordinates of ``hmc``, one code per parameter (``kind``; the draws are stored as ``x``):

- ``0``: ``w = x``;
- ``LOG`` (the option ``log_positive``): ``w = log x``, for a parameter bounded below by 0
  whose mode lies well above it; the density gains :math:`\sum w`, the gradient becomes
  :math:`x\,\partial f/\partial x + 1`; a bound ``[0, hi]`` becomes ``(-inf, log hi]``;
- ``SQRT`` (the option ``sqrt_at_zero``): ``w = sqrt x``, for a parameter bounded below by 0
  whose mode sits at or near it (a night-time h): an exponential-like posterior piled against
  the bound becomes a Rayleigh-like one that vanishes there; the density gains
  :math:`\sum \log 2w`, the gradient becomes :math:`2w\,\partial f/\partial x + 1/w`; ``[0, hi]``
  becomes ``[0, sqrt hi]``.

A covariance of ``x`` is carried over by :func:`log_metric` (:func:`in_log` carries a density
and its gradient). A boolean mask is read as ``LOG`` where true.

Measured for ``SQRT`` (``hmc``, the 72-h Göttingen window with ``surface_layer`` and
``runs/grass.toml``'s options): over 1000 steps after adaptation (seed 3) the slowest tau
halves (4.3 instead of 8.4 steps; 89 instead of 160 gradients per chain per effective draw);
to the stopping rule 309k instead of 504k gradients (seed 1, 102 s) but 520k against 518k
(seed 2: split R-hat of two h stayed at 1.010-1.012 from ESS 2300 to 3500); the base fit, with
65 such h instead of 18, needs half the step size (458k instead of 244k gradients, seed 1;
389k with only the 44 h whose mode is on 0, below 0.01 sd).
So it is off by default and in ``runs/grass.toml``. Start points of a ``SQRT`` coordinate lie
at least half a metric sd above 0 (``hmc``): near 0 the Jacobian's ``1/w`` pull rejects every
trajectory (a chain started at ``w`` = 1e-4 sd never moved).
"""

from __future__ import annotations

import numpy as np

LOG, SQRT = 1, 2
#: floor of a log coordinate's value (a point exactly on the bound 0)
_TINY = 1e-300


def _masks(kind: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    k = np.asarray(kind)
    return k == LOG, k == SQRT


def to_w(x: np.ndarray, kind: np.ndarray) -> np.ndarray:
    """Working coordinates (n, d) of points ``x`` (n, d) (``x`` itself if all are linear)."""
    if not np.any(kind):  # all linear (hmc's default): no copy, no work
        return x
    lg, sq = _masks(kind)
    w = np.array(x, float)
    w[:, lg] = np.log(np.maximum(w[:, lg], _TINY))
    w[:, sq] = np.sqrt(np.maximum(w[:, sq], 0.0))
    return w


def to_x(w: np.ndarray, kind: np.ndarray) -> np.ndarray:
    """Points ``x`` (n, d) of working coordinates ``w`` (n, d) (``w`` itself if all are linear)."""
    if not np.any(kind):
        return w
    lg, sq = _masks(kind)
    x = np.array(w, float)
    x[:, lg] = np.exp(w[:, lg])
    x[:, sq] = w[:, sq] * w[:, sq]
    return x


def bounds_w(lo: np.ndarray, hi: np.ndarray, kind: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bounds ``(lo, hi)`` (d,) in the working coordinates (``LOG`` and ``SQRT`` ones have
    ``lo = 0``); a finite upper one is the largest float that maps back to at most ``hi``
    (``exp(log hi)`` rounds above ``hi`` for about half of all values, e.g. 0.1 and 3)."""
    lo, hi = np.array(lo, float), np.array(hi, float)
    lg, sq = _masks(kind)
    for mask, fwd, back, low in ((lg, np.log, np.exp, -np.inf), (sq, np.sqrt, np.square, 0.0)):
        top = hi[mask]
        with np.errstate(divide="ignore"):
            w = fwd(top)
        for _ in range(8):
            over = back(w) > top
            if not over.any():
                break
            w[over] = np.nextafter(w[over], -np.inf)
        lo[mask], hi[mask] = low, w
    return lo, hi


def in_log(f: np.ndarray, g: np.ndarray, w: np.ndarray, x: np.ndarray, kind: np.ndarray):
    """Log-density ``f`` (n,) and its gradient ``g`` (n, d) in ``x`` carried to ``w``
    (``g`` is changed in place; rows with a non-finite ``f`` get a zero gradient)."""
    if not np.any(kind):
        return f, g
    lg, sq = _masks(kind)
    if lg.any():
        f = f + np.sum(w[:, lg], axis=1)
    if sq.any():  # log 2w, -inf at (and below) the bound 0
        with np.errstate(divide="ignore", invalid="ignore"):
            f = f + np.sum(np.where(w[:, sq] > 0.0, np.log(2.0 * w[:, sq]), -np.inf), axis=1)
    ok = np.isfinite(f)[:, None]
    if lg.any():
        g[:, lg] = np.where(ok, g[:, lg] * x[:, lg] + 1.0, 0.0)
    if sq.any():
        ws = w[:, sq]
        with np.errstate(divide="ignore", invalid="ignore"):
            g[:, sq] = np.where(ok, 2.0 * ws * g[:, sq] + 1.0 / ws, 0.0)
        g[:] = np.where(ok, g, 0.0)  # a sqrt coordinate on 0 makes the density 0: no gradient
    return f, g


def log_metric(cov: np.ndarray, x: np.ndarray, kind: np.ndarray) -> np.ndarray:
    """The covariance ``cov`` of ``x`` carried to the working coordinates.

    ``LOG``: at a mode inside the bounds, the delta method (``cov_ij / (x_i x_j)``); at a mode
    on the bound 0 the posterior is close to an exponential (:func:`.target.bounded_laplace_cov`),
    and the log of an exponential variable has the variance pi^2/6 whatever its scale: that,
    and no correlations. ``SQRT``: the square root of an exponential variable of scale ``s``
    (taken as the sd in ``cov``) has the variance ``(1 - pi/4) s``: that, and no correlations.
    """
    lg, sq = _masks(kind)
    d = np.where(lg & (x > 0.0), x, 1.0)
    var_sq = (1.0 - np.pi / 4.0) * np.sqrt(np.diag(cov)[sq])
    out = cov / np.outer(d, d)
    z = lg & ~(x > 0.0)
    out[z, :] = 0.0
    out[:, z] = 0.0
    out[z, z] = np.pi**2 / 6.0
    out[sq, :] = 0.0
    out[:, sq] = 0.0
    out[sq, sq] = var_sq
    return out
