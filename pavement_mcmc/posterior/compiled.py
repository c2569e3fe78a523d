r"""Compiled observation + likelihood path of the buried sensors' temperatures (``hmc``'s hot loop).

For the plain temperature stream (:class:`~.observations.Temperatures` with ``sigma``, no input
noise, the sensors read at their nominal depths: no extension's ``observe`` hook) one call per
gradient does what the generic path does in a dozen NumPy calls:
:func:`temperature_terms` interpolates the sensors from the nodal temperatures, forms the
residuals, the whitened residuals :math:`z = r/\sigma`, the log-likelihood
:math:`-\tfrac12(\lVert z\rVert^2 + \log\det\Sigma + n\log 2\pi)` and the RMSE per sensor;
:func:`temperature_cotangent` the nodal cotangent :math:`-P^T z/\sigma` (``P`` the
interpolation; zero for rows whose log-likelihood is not finite).

Same floating-point operations in the same order as the NumPy path (the sum of squares in
NumPy's order for the layout of the nodal temperatures: in sequence for the solver's, sets
innermost; pairwise, :func:`_pairwise_sum`, for C-ordered ones; the RMSE's sum over times in
sequence, as NumPy's reduction over a middle axis), so a chain is bit for bit the one the generic path gives
(checked by ``tests/posterior/test_compiled.py`` and the chain fingerprints). Saves about a tenth
of a Case C gradient (measured in ``benchmarks/bench_gradient.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

_PW_BLOCK = 128  # NumPy's PW_BLOCKSIZE


@njit(cache=True)
def _block_sum(a, lo, n):
    """NumPy's sum of at most 128 terms: sequential below 8, else 8 interleaved partial sums."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[lo + i]
        return res
    r = a[lo:lo + 8].copy()
    m = n - n % 8
    i = 8
    while i < m:
        for k in range(8):
            r[k] += a[lo + i + k]
        i += 8
    res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@njit(cache=True)
def _pairwise_sum(a, lo, n):
    """``np.sum`` of ``a[lo:lo+n]`` (contiguous float64) in NumPy's own order: blocks of at most
    128 terms (:func:`_block_sum`), longer runs cut in two at a multiple of 8 and the halves'
    sums added. The recursion is unrolled on an explicit stack (a recursive function loaded
    from numba's cache crashed)."""
    los = np.empty(64, np.int64)
    ns = np.empty(64, np.int64)
    stage = np.zeros(64, np.int64)
    vals = np.empty(64)
    top, nv = 0, 0
    los[0], ns[0] = lo, n
    while top >= 0:
        m = ns[top]
        if m <= _PW_BLOCK:
            vals[nv] = _block_sum(a, los[top], m)
            nv += 1
            top -= 1
            continue
        n2 = m // 2
        n2 -= n2 % 8
        if stage[top] < 2:  # push the left half, then the right half
            first = stage[top] == 0
            stage[top] += 1
            los[top + 1] = los[top] if first else los[top] + n2
            ns[top + 1] = n2 if first else m - n2
            stage[top + 1] = 0
            top += 1
        else:  # both halves summed: combine
            vals[nv - 2] = vals[nv - 2] + vals[nv - 1]
            nv -= 1
            top -= 1
    return vals[0]


@njit(cache=True)
def temperature_terms(T, oi, ow, data, sigma, logdet, n_log2pi, pairwise):
    """Log-likelihood (S,), RMSE per sensor (S, K) and whitened residuals (S, (n_obs-1) K).

    ``T`` (S, n_obs, n_nodes) nodal temperatures (any strides), ``oi``/``ow`` (K,) the left node
    and right weight of each sensor, ``data`` (n_obs-1, K) the observations after the initial
    row, ``sigma`` degC, ``logdet`` and ``n_log2pi`` the stream's constants. ``pairwise``: sum
    the squares as NumPy does along a contiguous axis (``T`` C-ordered), else in sequence (as
    NumPy does when the sets are the innermost axis, the solver's layout).
    """
    S, n_obs = T.shape[0], T.shape[1]
    K = oi.shape[0]
    J = n_obs - 1
    z = np.empty((S, J * K))
    zz = np.empty(J * K)
    ll = np.empty(S)
    rmse = np.empty((S, K))
    ss = np.empty(K)
    for s in range(S):
        for k in range(K):
            ss[k] = 0.0
        for j in range(J):
            for k in range(K):
                a, w = oi[k], ow[k]
                r = (T[s, j + 1, a] * (1.0 - w) + T[s, j + 1, a + 1] * w) - data[j, k]
                zk = r / sigma
                z[s, j * K + k] = zk
                zz[j * K + k] = zk * zk
                ss[k] += r * r
        if pairwise:
            ssq = _pairwise_sum(zz, 0, J * K)
        else:
            ssq = 0.0
            for m in range(J * K):
                ssq += zz[m]
        ll[s] = -0.5 * ((ssq + logdet) + n_log2pi)
        for k in range(K):
            rmse[s, k] = np.sqrt(ss[k] / J)
    return ll, rmse, z


@njit(cache=True)
def temperature_cotangent(z, ok, oi, ow, sigma, n_obs, n_nodes):
    """d log-likelihood / d nodal temperatures (S, n_obs, n_nodes): ``-P^T (z / sigma)`` for
    the rows with ``ok``, zero for the others and for the initial time."""
    S = z.shape[0]
    K = oi.shape[0]
    G = np.zeros((S, n_obs, n_nodes))
    for s in range(S):
        if not ok[s]:
            continue
        for j in range(n_obs - 1):
            for k in range(K):
                g = -(z[s, j * K + k] / sigma)
                a, w = oi[k], ow[k]
                G[s, j + 1, a] += g * (1.0 - w)
                G[s, j + 1, a + 1] += g * w
    return G
