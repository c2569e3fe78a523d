r"""``hmc``'s guard on its start metric: no parameter far narrower or far wider than the posterior.

The start metric is a Laplace covariance ``Sigma`` at the mode (or one handed in). Where it is
far too narrow along a parameter, a trajectory moves that parameter by about the metric's sd,
and each metric window widens it only by how far the chains diffused in the window (3-9x): from
a metric whose κ sd was 1e-5 of the Laplace one, Case A under ``hmc`` had not converged after
20 k steps (R-hat 2.1-2.6, seeds 1-3), where it needs 330-410 (``benchmarks/bench_metric_guard.py``);
a Laplace covariance scored with a bound as outside did this to the SoilVUE desert window. Where
it is far too wide, the step size shrinks to the narrowest direction and every trajectory takes
~10x the leapfrog steps until the windows shrink the metric: from κ's sd 1e3 times the Laplace
one, Case A took 108 k gradients to the rule instead of 11 k, and from 1e5 times it had not
converged in 60 s (922 k gradients, R-hat 3.7).

The check, along each parameter ``i``: the posterior's conditional precision at the mode

.. math:: p_i = \max\left(-\frac{\partial^2 \log p}{\partial x_i^2},
          \left(\frac{\partial \log p}{\partial x_i}\right)^2\right)

(the curvature by a forward difference of the gradient over one metric sd, towards the inside
of the bounds; the squared slope is the exponential's scale of a mode pushed against a bound,
as in :func:`.target.bounded_laplace_cov`) against the metric's, :math:`(\Sigma^{-1})_{ii}`;
for a Gaussian posterior and its own covariance the two are equal. Where the metric's conditional
sd is below :data:`RATIO` ``^-1`` times the posterior's, row and column ``i`` of ``Sigma`` are
scaled by :math:`\sqrt{(\Sigma^{-1})_{ii} / p_i}`: the conditional sds then agree, the
correlations are kept, and the chains start from the widened metric.

Where it is above :data:`RATIO` times the curvature's :math:`(-\partial^2 \log p/\partial x_i^2)^{-1/2}`
the same scaling narrows it, with the curvature alone for :math:`p_i`: at an interior mode the
slope is 0 anyway, and a mode pushed against a bound keeps the Laplace (curvature) scale that
:func:`.target.bounded_laplace_cov` expects and caps at the slope's next (with the squared slope
the grass window's night h, on h >= 0, would have been narrowed 12x; narrowed to the slope's
scale, a parameter on its bound loses the regression of its correlated neighbours on it). A
secant taken 1e3 sd out is far from the mode's curvature (κ's flattens: narrowed by it alone κ
stayed 17x too wide, 48 k gradients), so each narrowed parameter is probed again at its new sd,
up to :data:`REFINE` times, until the ratio is within 2 (Case A, any of its five parameters
1e2-1e5 times too wide: back within 3.2 % of the normal start's sd on 1-2 more gradients).
Narrowing the metric to the mode's curvature gives it the normal start's (Laplace) scale, so a
heavy-tailed posterior, whose spread exceeds that, is no worse off than from a Laplace start.
Costs ``d`` gradients (and one a narrowed parameter a re-probe), no random draw; a sound start
metric is left as it is: over every parameter of the 13 shipped configurations the ratio lies
in 0.085-2.67, and with the curvature alone (the narrowing's) in 0.48-2.67 (docs/VALIDATION.md).
"""

from __future__ import annotations

import warnings

import numpy as np

from .target import cholesky_of

#: a parameter's metric conditional sd below 1/RATIO of the posterior's is widened, above RATIO
#: times it narrowed (sound Laplace covariances of the shipped cases: within a factor 2.7, see
#: docs/VALIDATION.md)
RATIO = 10.0
#: re-probes of the parameters narrowed, at their new sd (each costs one gradient a parameter)
REFINE = 4


def probe_points(mode: np.ndarray, idx: np.ndarray, sd: np.ndarray, lo: np.ndarray,
                 hi: np.ndarray) -> np.ndarray:
    """The rows where the gradient is taken: ``mode``, then ``mode`` with parameter ``idx[k]``
    moved by ``sd[k]`` (backwards where its upper bound is within it; where both bounds are,
    half-way to the farther one: the posterior is never evaluated outside ``[lo, hi]``)."""
    x, up, down = mode[idx], hi[idx] - mode[idx], mode[idx] - lo[idx]
    half = np.where(up >= down, 0.5 * up, -0.5 * down)
    T = np.repeat(mode[None, :], idx.size + 1, axis=0)
    T[1:, idx] = x[None, :] + np.diag(np.where(sd <= up, sd, np.where(sd <= down, -sd, half)))
    return T


def _ratio(cov: np.ndarray, X: np.ndarray, G: np.ndarray, cols: np.ndarray,
           slope: bool = True) -> np.ndarray:
    """The posterior's conditional sd over the metric's, ``sqrt((Sigma^-1)_ii / p_i)``, along
    the parameters ``cols`` (k,) of ``cov``: ``X[0]``, ``G[0]`` the mode and the gradient there,
    ``X[j]``, ``G[j]`` with parameter ``cols[j - 1]`` moved; ``p_i`` the curvature alone unless
    ``slope`` (nan where ill-defined)."""
    Linv = np.linalg.inv(cholesky_of(cov))
    prec_m = np.sum(Linv**2, axis=0)[cols]  # (Sigma^-1)_ii, of the factor the sampler will use
    g0 = G[0, cols]
    with np.errstate(all="ignore"):
        curv = -(np.diag(G[1:, cols]) - g0) / (np.diag(X[1:, cols]) - X[0, cols])
        return np.sqrt(prec_m / (np.maximum(curv, g0**2) if slope else curv))


def rescaled(cov: np.ndarray, X: np.ndarray, f: np.ndarray, G: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The metric ``cov`` with every parameter too narrow widened and every one too wide
    narrowed to the posterior's conditional sd (see the module docstring).

    Parameters
    ----------
    cov : (d, d) the start metric at the mode ``X[0]``.
    X, f, G : (d + 1, d) the parameters of :func:`probe_points`' rows, (d + 1,) the
        log-density there (non-finite: no check of that parameter), (d + 1, d) its gradient.

    Returns
    -------
    (cov, factor) : the metric (``cov`` itself if nothing was rescaled) and the factor (d,) by
        which each parameter's sd was scaled (1 where none).
    """
    cols = np.arange(X.shape[1])
    good = np.isfinite(f[1:])
    up, down = _ratio(cov, X, G, cols), _ratio(cov, X, G, cols, slope=False)
    factor = np.where(good & (up > RATIO), up, np.where(good & (down < 1.0 / RATIO), down, 1.0))
    if np.all(factor == 1.0):
        return cov, factor
    return cov * np.outer(factor, factor), factor


def guarded(cov: np.ndarray, mode: np.ndarray, idx: np.ndarray, lo: np.ndarray, hi: np.ndarray,
            value_grad, names=None) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The guard as ``hmc`` runs it: probe, :func:`rescaled`, and for the parameters narrowed
    up to :data:`REFINE` more probes at their new sd until the ratio is within ``[1/2, 2]``;
    a warning names what changed.

    Parameters
    ----------
    cov : (d, d) the start metric of the columns ``idx`` of the full parameter vector ``mode``.
    lo, hi : (n_free,) bounds.
    value_grad : rows (n, n_free) -> (log-density (n,), gradient (n, d) in the columns idx).
    names : the d parameters' names, for the warning.

    Returns
    -------
    (cov, factor, grad, n_evals) : the metric, the factor (d,) of each sd, the gradient at the
        mode (d,), the gradients spent.
    """
    sd = np.sqrt(np.diag(cov))
    T = probe_points(mode, idx, sd, lo, hi)
    with np.errstate(all="ignore"):
        f, G = value_grad(T)
    n_evals, g0 = T.shape[0], G[0]
    cov, factor = rescaled(cov, T[:, idx], f, G)
    k = np.flatnonzero(factor < 1.0)
    for _ in range(REFINE if k.size else 0):
        Tk = probe_points(mode, idx[k], np.sqrt(np.diag(cov))[k], lo, hi)
        with np.errstate(all="ignore"):
            fk, Gk = value_grad(Tk[1:])
        n_evals += k.size
        r = _ratio(cov, np.vstack([mode[None, idx], Tk[1:, idx]]), np.vstack([g0[None], Gk]), k,
                   slope=False)
        r = np.where(np.isfinite(fk) & np.isfinite(r), r, 1.0)
        s = np.ones(factor.size)
        s[k] = r
        cov, factor = cov * np.outer(s, s), factor * s
        if np.all((r > 0.5) & (r < 2.0)):
            break
    if names is not None and np.any(factor != 1.0):
        for what, sel, side in (("widened", factor > 1.0, "below the posterior's curvature scale"),
                                ("narrowed", factor < 1.0, "above the posterior's conditional sd")):
            if sel.any():
                which = {str(n): f"x{w:.2g}" for n, w, t in zip(names, factor, sel) if t}
                warnings.warn(f"hmc: the start metric's sd was far {side} along {which}: "
                              f"{what} (samplers/metric_guard.py)", stacklevel=4)
    return cov, factor, g0, n_evals
