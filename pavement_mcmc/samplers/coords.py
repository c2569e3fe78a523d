r"""Working coordinates of ``hmc``, one code per parameter (``kind``; the draws are stored as ``x``):

- ``0``: ``w = x``;
- ``LOG`` (the option ``log_positive``): ``w = log(x + c)`` (``c``: the ``shift``, the option
  ``log_shift`` = 1 times the parameter's Laplace sd; ``c = 0``: ``log x``), for a parameter
  bounded below by 0 whose mode lies well above it; the density gains :math:`\sum w`, the
  gradient becomes :math:`(x + c)\,\partial f/\partial x + 1`; a bound ``[0, hi]`` becomes
  ``[log c, log(hi + c)]`` (``c = 0``: ``[log 1e-300, log hi]``);
- ``SQRT`` (the option ``sqrt_at_zero``): ``w = sqrt(x + c) - sqrt c`` (``c``: the ``shift``,
  the option ``sqrt_shift`` = 0.25 times the parameter's exponential scale at the bound), for
  a parameter bounded below by 0 whose mode sits at or near it (a night-time h): an
  exponential-like posterior piled against the bound becomes one that falls towards it;
  with :math:`u = w + \sqrt c` the density gains :math:`\sum \log 2u`, the gradient becomes
  :math:`2u\,\partial f/\partial x + 1/u`; ``[0, hi]`` becomes ``[0, sqrt(hi + c) - sqrt c]``.

A covariance of ``x`` is carried over by :func:`log_metric` (:func:`in_log` carries a density
and its gradient). A boolean mask is read as ``LOG`` where true.

``LOG``'s shift: in ``log x`` the neighbourhood of 0 is an infinite tail, as long in the metric's
units as the mode is far in sd; a parameter whose posterior keeps some mass near 0 lets a
chain wander down it and come back by a random walk at the metric's scale. On the Göttingen
72-h window (``runs/grass_plain.toml``, plain log, seed 1) a chain went to h_52 ~ 0-2 (mode 45,
sd 16; a ridge of equal density through its neighbours) and stayed there ~80 steps after the
adaptation: split-R-hat alone kept the run going from step 440 to 832. ``log(x + c)`` with
``c`` one Laplace sd keeps 0 at ``(z + 1) log(z + 1)`` metric sd from a mode ``z`` sd above it
and is ``log x`` for ``z >> 1``. To the stopping rule (seeds 1 / 2 / 3, gradients): the
Göttingen window 93k / 94k / 100k instead of 208k / 158k / 185k (steps 546 / 546 / 628 instead of
832 / 723 / 832), on a toy with 18 % of the mass near 0 (``tests/samplers/test_hmc_shifted_log.py``)
18 instead of 40 gradients per effective draw.

``LOG``: a parameter whose mode is more than one Laplace sd above 0 (``hmc``); the others stay
linear (a night h at 0 in ``log`` made the step size fall to 0.017, 64 leapfrog steps). With a
surface layer the Göttingen posterior of h is skewed (the soil feels ``h / (1 + h R)`` and
``q / (1 + h R)``, so roughly ``log h``): on the 72-h window, 1000 steps after adaptation,
177 / 122 / 160 instead of 253 / 209 / 205 gradients per chain per effective draw of the
slowest parameter (seeds 1 / 2 / 3; the roughness ``||Dh||^2`` tau 5.4 / 4.9 / 4.7 instead of
12.0 / 12.5 / 10.6 steps). Off by default: on Case C (no layer, h's posterior close to
Gaussian) it costs 158k / 194k instead of 114k gradients to the stopping rule (seeds 1 / 2),
and in ``log x`` a Gaussian's right tail gets a curvature growing like ``x^2``, which a chain
started far out there cannot leave at the adapted step size.

``SQRT``, measured on the 72-h Göttingen window with ``runs/grass.toml``'s other options
(``hmc``, 16 chains). Unshifted (``c = 0``, ``w = sqrt x``, a Rayleigh-like posterior that
vanishes at 0): over 1000 steps after adaptation (``surface_layer``, seed 3) the slowest tau
halves (4.3 instead of 8.4 steps; 89 instead of 160 gradients per chain per effective draw);
to the stopping rule 309k instead of 504k gradients on seed 1 but 520k against 518k on seed 2
(split R-hat of two h stayed at 1.010-1.012 from ESS 2300 to 3500); the base fit, with 65
such h instead of 18, needs half the step size (458k instead of 244k gradients, seed 1): the
Jacobian's ``1/w`` pull grows without bound at 0. The shift keeps it below ``1/sqrt c``.
Start points of a ``SQRT`` coordinate lie at least half a metric sd above 0 (``hmc``; without
a shift a chain started at ``w`` = 1e-4 sd never moved).
"""

from __future__ import annotations

import numpy as np
from scipy.special import erfcx

LOG, SQRT = 1, 2
#: floor of a log coordinate's value (a point exactly on the bound 0)
_TINY = 1e-300
#: the lower bound of a log coordinate: a leapfrog flung far below it reflects there instead of
#: reaching x = exp(w) = 0 (underflow), which the solver refuses with an error that ended the fit
_LOG_TINY = float(np.log(_TINY))


class Coords:
    """The working coordinates of ``d`` parameters: their kinds (d,) and the ``c`` (d,) of the
    sqrt ones (``shift``, default 0), with the masks and ``sqrt c`` worked out once (``hmc``
    maps every leapfrog position through them)."""

    def __init__(self, kind: np.ndarray, shift=None):
        self.kind = np.asarray(kind)
        self.shift = shift
        self.linear = not np.any(self.kind)
        self.lg, self.sq = self.kind == LOG, self.kind == SQRT
        self.r = 0.0 if shift is None else np.sqrt(np.asarray(shift, float)[self.sq])
        self.c = 0.0 if shift is None else np.asarray(shift, float)[self.lg]  # log(x + c)

    def to_w(self, x: np.ndarray) -> np.ndarray:
        """Working coordinates (n, d) of points ``x`` (n, d) (``x`` itself if all are linear)."""
        if self.linear:  # all linear (hmc's default): no copy, no work
            return x
        lg, sq, r = self.lg, self.sq, self.r
        w = np.array(x, float)
        w[:, lg] = np.log(np.maximum(w[:, lg] + self.c, _TINY))
        w[:, sq] = np.sqrt(np.maximum(w[:, sq], 0.0) + r * r) - r
        return w

    def to_x(self, w: np.ndarray) -> np.ndarray:
        """Points ``x`` (n, d) of working coordinates ``w`` (n, d) (``w`` itself if all are
        linear)."""
        if self.linear:
            return w
        lg, sq, r = self.lg, self.sq, self.r
        x = np.array(w, float)
        x[:, lg] = np.exp(w[:, lg]) - self.c
        x[:, sq] = (w[:, sq] + r) ** 2 - r * r
        return x

    def bounds(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The bounds ``(lo, hi)`` (d,) in the working coordinates (``SQRT`` ones have
        ``lo = 0``, ``LOG`` ones ``log 1e-300``, so that no point inside maps to ``x = 0``); a
        finite upper one is the largest float that maps back to at most ``hi`` (``exp(log hi)``
        rounds above ``hi`` for about half of all values, e.g. 0.1 and 3), within 8 steps of
        one ulp: for a shifted sqrt with ``hi`` far below ``c``, ``(w + sqrt c)^2 - c`` rounds
        with an error of about ``1e-16 c``, and ``hi`` can come back up to that much above
        (3e-13 relative for ``hi = c / 1000``; the bounds of h are hundreds of times ``c``)."""
        lo, hi = np.array(lo, float), np.array(hi, float)
        r, c = self.r, self.c
        low_lg = np.log(np.maximum(np.zeros(np.count_nonzero(self.lg)) + c, _TINY))
        for _ in range(8):  # log(x + c): the first float that maps back to x > 0 (a kappa or C
            under = np.exp(low_lg) - c <= 0.0  # reflected onto x = 0 ended a fit: the solver refuses it)
            if not under.any():
                break
            # one ulp of w, at least the relative ulp of x + c (near w = 0, e.g. c = 1, the next
            # floats are denormals that exp maps back to c)
            low_lg[under] += np.maximum(np.spacing(np.abs(low_lg[under])), 2.3e-16)
        for mask, fwd, back, low in ((self.lg, lambda v: np.log(v + c), lambda v: np.exp(v) - c,
                                      low_lg),
                                     (self.sq, lambda v: np.sqrt(v + r * r) - r,
                                      lambda v: (v + r) ** 2 - r * r, 0.0)):
            top = hi[mask]
            with np.errstate(divide="ignore", invalid="ignore"):
                w = fwd(top)
            for _ in range(8):
                over = back(w) > top
                if not over.any():
                    break
                w[over] = np.nextafter(w[over], -np.inf)
            lo[mask], hi[mask] = low, w
        return lo, hi

    def in_log(self, f: np.ndarray, g: np.ndarray, w: np.ndarray, x: np.ndarray):
        """Log-density ``f`` (n,) and its gradient ``g`` (n, d) in ``x`` carried to ``w``
        (``g`` is changed in place; rows with a non-finite ``f`` get a zero gradient)."""
        if self.linear:
            return f, g
        lg, sq = self.lg, self.sq
        if lg.any():
            f = f + np.sum(w[:, lg], axis=1)
        if sq.any():  # log 2(w + sqrt c), -inf at (and below) w = -sqrt c
            ws = w[:, sq] + self.r
            with np.errstate(divide="ignore", invalid="ignore"):
                f = f + np.sum(np.where(ws > 0.0, np.log(2.0 * ws), -np.inf), axis=1)
        ok = np.isfinite(f)[:, None]
        if lg.any():
            g[:, lg] = np.where(ok, g[:, lg] * (x[:, lg] + self.c) + 1.0, 0.0)
        if sq.any():
            with np.errstate(divide="ignore", invalid="ignore"):
                g[:, sq] = np.where(ok, 2.0 * ws * g[:, sq] + 1.0 / ws, 0.0)
            g[:] = np.where(ok, g, 0.0)  # a sqrt coordinate on 0 makes the density 0: no gradient
        return f, g


def to_w(x: np.ndarray, kind: np.ndarray, shift=None) -> np.ndarray:
    """:meth:`Coords.to_w` (``shift``: the ``c`` (d,) of the sqrt coordinates, default 0)."""
    return Coords(kind, shift).to_w(x)


def to_x(w: np.ndarray, kind: np.ndarray, shift=None) -> np.ndarray:
    """:meth:`Coords.to_x`."""
    return Coords(kind, shift).to_x(w)


def bounds_w(lo: np.ndarray, hi: np.ndarray, kind: np.ndarray,
             shift=None) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`Coords.bounds`."""
    return Coords(kind, shift).bounds(lo, hi)


def in_log(f: np.ndarray, g: np.ndarray, w: np.ndarray, x: np.ndarray, kind: np.ndarray,
           shift=None):
    """:meth:`Coords.in_log`."""
    return Coords(kind, shift).in_log(f, g, w, x)


def log_metric(cov: np.ndarray, x: np.ndarray, kind: np.ndarray, shift=None) -> np.ndarray:
    """The covariance ``cov`` of ``x`` carried to the working coordinates.

    ``LOG``: at a mode inside the bounds, the delta method (``cov_ij / ((x_i + c_i)(x_j + c_j))``); at a mode
    on the bound 0 the posterior is close to an exponential (:func:`.target.bounded_laplace_cov`),
    and the log of an exponential variable has the variance pi^2/6 whatever its scale: that,
    and no correlations. ``SQRT``: for an exponential variable ``x`` of scale ``s`` (taken as
    the sd in ``cov``), ``sqrt(x + c)`` has the mean ``sqrt c + sqrt(pi s) / 2 erfcx(sqrt(c/s))``
    and so the variance ``s + c`` minus its square (``(1 - pi/4) s`` for ``c = 0``): that, and
    no correlations.
    """
    co = Coords(kind, shift)
    lg, sq = co.lg, co.sq
    xc = np.array(x, float)
    xc[lg] += co.c
    d = np.where(lg & (xc > 0.0), xc, 1.0)
    s = np.sqrt(np.diag(cov)[sq])
    c = np.zeros_like(s) if shift is None else np.asarray(shift, float)[sq]
    mean = np.sqrt(c) + 0.5 * np.sqrt(np.pi * s) * erfcx(np.sqrt(c / s))
    var_sq = s + c - mean * mean
    out = cov / np.outer(d, d)
    z = lg & ~(xc > 0.0)
    out[z, :] = 0.0
    out[:, z] = 0.0
    out[z, z] = np.pi**2 / 6.0
    out[sq, :] = 0.0
    out[:, sq] = 0.0
    out[sq, sq] = var_sq
    return out
