r"""``hmc``'s guard on its start metric: no parameter far narrower than the posterior's curvature.

The start metric is a Laplace covariance ``Sigma`` at the mode (or one handed in). Where it is
far too narrow along a parameter, a trajectory moves that parameter by about the metric's sd,
and each metric window widens it only by how far the chains diffused in the window (3-9x): from
a metric whose κ sd was 1e-5 of the Laplace one, Case A under ``hmc`` had not converged after
20 k steps (R-hat 2.1-2.6, seeds 1-3), where it needs 330-410 (``benchmarks/bench_metric_guard.py``);
a Laplace covariance scored with a bound as outside did this to the SoilVUE desert window.

The check, along each parameter ``i``: the posterior's conditional precision at the mode

.. math:: p_i = \max\left(-\frac{\partial^2 \log p}{\partial x_i^2},
          \left(\frac{\partial \log p}{\partial x_i}\right)^2\right)

(the curvature by a forward difference of the gradient over one metric sd, towards the inside
of the bounds; the squared slope is the exponential's scale of a mode pushed against a bound,
as in :func:`.target.bounded_laplace_cov`) against the metric's, :math:`(\Sigma^{-1})_{ii}`;
for a Gaussian posterior and its own covariance the two are equal. Where the metric's conditional
sd is below :data:`RATIO` ``^-1`` times the posterior's, row and column ``i`` of ``Sigma`` are
scaled by :math:`\sqrt{(\Sigma^{-1})_{ii} / p_i}`: the conditional sds then agree, the
correlations are kept, and the chains start from the widened metric. Costs ``d`` gradients, no
random draw. A metric too wide is left to the windows: they replace one 10x too wide in sd
(``tests/samplers/test_hmc.py``), at a cost that grows with it (docs/VALIDATION.md, section 8).
"""

from __future__ import annotations

import warnings

import numpy as np

from .target import cholesky_of

#: a parameter's metric conditional sd below 1/RATIO of the posterior's is widened (sound
#: Laplace covariances of the shipped cases: within a factor 2, see docs/VALIDATION.md)
RATIO = 10.0


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


def widened(cov: np.ndarray, X: np.ndarray, f: np.ndarray, G: np.ndarray,
            names=None) -> tuple[np.ndarray, np.ndarray]:
    """The metric ``cov`` with every parameter too narrow widened (see the module docstring);
    a warning names them.

    Parameters
    ----------
    cov : (d, d) the start metric at the mode ``X[0]``.
    X, f, G : (d + 1, d) the parameters of :func:`probe_points`' rows, (d + 1,) the
        log-density there (non-finite: no check of that parameter), (d + 1, d) its gradient.
    names : the d parameters' names, for the warning.

    Returns
    -------
    (cov, factor) : the metric (``cov`` itself if nothing was widened) and the factor (d,) by
        which each parameter's sd was scaled (1 where none).
    """
    Linv = np.linalg.inv(cholesky_of(cov))
    prec_m = np.sum(Linv**2, axis=0)  # (Sigma^-1)_ii, of the factor the sampler will use
    g0 = G[0]
    with np.errstate(all="ignore"):
        curv = -(np.diag(G[1:]) - g0) / np.diag(X[1:] - X[0])
        ratio = np.sqrt(prec_m / np.maximum(curv, g0**2))  # posterior's conditional sd / metric's
    factor = np.where(np.isfinite(f[1:]) & np.isfinite(ratio) & (ratio > RATIO), ratio, 1.0)
    if np.all(factor == 1.0):
        return cov, factor
    if names is not None:
        wide = {str(n): f"x{w:.2g}" for n, w in zip(names, factor) if w > 1.0}
        warnings.warn(f"hmc: the start metric's sd was far below the posterior's curvature scale "
                      f"along {wide}: widened (samplers/metric_guard.py)", stacklevel=4)
    return cov * np.outer(factor, factor), factor
