r"""Compiled pieces of the marginal GMRF prior's value and gradient (``hmc``'s hot loop on Case C).

:meth:`.marginal.MarginalGMRF.terms` gives, for rows of h, the roughness
:math:`S = \lVert Dh\rVert^2`, :math:`D^TDh`, :math:`\log F(S)` and :math:`E[\gamma\mid S]` in
two compiled calls and two NumPy ones (the logarithm and the exponential stay NumPy's: its
SIMD ``log``/``exp`` and the C library's may differ in the last bit). The operations and their
order are those of the NumPy expressions they replace, so the numbers are the same to the bit
(``tests/posterior/test_marginal_compiled.py``):

- :func:`rows`: ``dh = np.diff(H, axis=1)``, ``S = np.sum(dh * dh, axis=1)`` (NumPy's pairwise
  order along a contiguous row, :func:`.compiled._pairwise_sum`) and ``D^T D h`` as
  ``z = 0; z[:, :-1] -= dh; z[:, 1:] += dh``;
- :func:`splines`: two of SciPy's cubic splines (``PPoly``) on one set of knots at the same
  points, as its ``evaluate`` does: the interval ``x[i] <= v < x[i+1]`` (the last one closed),
  ``s = v - x[i]`` and ``c3 + c2 s + c1 s^2 + c0 s^3`` summed in that order, with ``s^2 = s s``
  and ``s^3 = s^2 s``. The points must lie within the knots (the caller clips them).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .compiled import _pairwise_sum


@njit(cache=True)
def rows(H, pairwise):
    """``(S, DtDh)`` of rows of h, ``H`` (n, N): see the module docstring. ``pairwise``: sum
    the squares as NumPy does along a contiguous row (``H`` C-ordered), else in sequence (as
    NumPy does for an F-ordered ``H``, where the rows are not contiguous)."""
    n, N = H.shape
    S = np.empty(n)
    Z = np.empty((n, N))
    sq = np.empty(N - 1)
    for s in range(n):
        for j in range(N - 1):
            d = H[s, j + 1] - H[s, j]
            sq[j] = d * d
            z = 0.0
            z -= d
            if j > 0:
                z += H[s, j] - H[s, j - 1]
            Z[s, j] = z
        Z[s, N - 1] = 0.0 + (H[s, N - 1] - H[s, N - 2])
        if pairwise:
            S[s] = _pairwise_sum(sq, 0, N - 1)
        else:
            acc = sq[0]
            for j in range(1, N - 1):
                acc += sq[j]
            S[s] = acc
    return S, Z


@njit(cache=True)
def _interval(x, v):
    """The largest ``i`` with ``x[i] <= v``, at most ``len(x) - 2`` (SciPy's interval search)."""
    lo, hi = 0, x.size - 1
    if v >= x[hi]:
        return hi - 1
    while lo < hi - 1:
        mid = (lo + hi) // 2
        if v < x[mid]:
            hi = mid
        else:
            lo = mid
    return lo


@njit(cache=True)
def splines(x, c1, c2, v):
    """Two cubic splines with knots ``x`` and coefficients ``c1``, ``c2`` (4, len(x) - 1) at the
    points ``v`` (inside ``[x[0], x[-1]]``): ``(y1, y2)``, as SciPy's ``PPoly`` evaluates them."""
    n = v.size
    y1, y2 = np.empty(n), np.empty(n)
    for k in range(n):
        i = _interval(x, v[k])
        s = v[k] - x[i]
        s2 = s * s
        s3 = s2 * s
        y1[k] = ((c1[3, i] + c1[2, i] * s) + c1[1, i] * s2) + c1[0, i] * s3
        y2[k] = ((c2[3, i] + c2[2, i] * s) + c2[1, i] * s2) + c2[0, i] * s3
    return y1, y2
