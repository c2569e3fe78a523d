"""The reverse step of the discrete adjoint (``adjoint._adjoint_step``) on explicit SIMD vectors.

Internal module; the maths in :mod:`.adjoint`, the vectors in :mod:`.simd`, the loop order as in
:mod:`.cn_simd`: chunks of sets outside, nodes inside, ``mu[i+1]`` of the bottom-up sweep and
``mu[i-1]``, ``X[i-1]`` of the top-down one in registers, the parameter sums of a node added in
the top-down sweep as soon as its ``mu`` is final. The same operations and fused multiply-adds
as the loops, so the same numbers (``tests/solver/test_cn_simd.py``). The sets must fill whole
vectors (the caller uses the loops otherwise). ``z`` row 4 is ``invD0``; ``Ta`` and ``XN``
enter as scalars, ``wq0``, ``wq1`` as the weights of ``q_j``, ``q_j+1``.
"""

from __future__ import annotations

from numba import njit

from .cn_simd import _WIDE
from .simd import W, vfma, vload, vmul, vsplat, vstore, vsub


@njit(cache=True, inline="always")
def _chunk(lam, mu, T, Tp, ct, cl, u, gt, z, invD, r, XN, Ta, rq0, rq1, acc_a, acc_b, acc_h, acc_q, j, s):
    """One chunk of sets at ``s``; the vector width is that of ``ct`` (and ``cl``, ``r``)."""
    N = lam.shape[0]
    m = vload(lam, N - 1, s, ct)
    vstore(mu, N - 1, s, m)
    for i in range(N - 2, -1, -1):
        m = vfma(vload(gt, i + 1, s, ct), m, vload(lam, i, s, ct))
        vstore(mu, i, s, m)
    m0 = vmul(m, vload(z, 4, s, ct))
    vstore(mu, 0, s, m0)
    vstore(lam, 0, s, vfma(cl, vsub(m0, vload(lam, 0, s, ct)), m0))
    x = vfma(ct, vload(T, 0, s, ct), vload(Tp, 0, s, ct))  # X[0] = T+ + ct T
    vstore(acc_h, j, s, vfma(vmul(r, m0), vsub(x, vsplat(Ta, ct)), vload(acc_h, j, s, ct)))
    vstore(acc_q, j, s, vfma(vsplat(rq0, ct), m0, vload(acc_q, j, s, ct)))
    vstore(acc_q, j + 1, s, vfma(vsplat(rq1, ct), m0, vload(acc_q, j + 1, s, ct)))
    prev = m0
    for i in range(1, N):
        mi = vmul(vfma(vload(u, i - 1, s, ct), prev, vload(mu, i, s, ct)), vload(invD, i, s, ct))
        vstore(mu, i, s, mi)
        vstore(lam, i, s, vfma(cl, vsub(mi, vload(lam, i, s, ct)), mi))
        xi = vfma(ct, vload(T, i, s, ct), vload(Tp, i, s, ct))
        dk = vmul(r, vsub(x, xi))
        vstore(acc_a, i - 1, s, vfma(prev, dk, vload(acc_a, i - 1, s, ct)))
        vstore(acc_b, i - 1, s, vfma(mi, dk, vload(acc_b, i - 1, s, ct)))
        prev = mi
        x = xi
    vstore(acc_a, N - 1, s, vfma(vmul(r, prev), vsub(x, vsplat(XN, ct)), vload(acc_a, N - 1, s, ct)))


@njit(cache=True)
def adjoint_step(lam, mu, T, Tp, ct, cl, u, gt, z, invD, r, XN, Ta, wq0, wq1, acc_a, acc_b, acc_h, acc_q, j):
    """``adjoint._adjoint_step`` (same arguments but ``z`` for ``invD0``): chunks of ``_WIDE``
    sets, then of ``W``."""
    nb = lam.shape[1]
    rq0, rq1 = r * wq0, r * wq1
    s = 0
    while s + _WIDE <= nb:
        _chunk(lam, mu, T, Tp, vsplat(ct, _WIDE), vsplat(cl, _WIDE), u, gt, z, invD, vsplat(r, _WIDE), XN, Ta,
               rq0, rq1, acc_a, acc_b, acc_h, acc_q, j, s)
        s += _WIDE
    while s < nb:
        _chunk(lam, mu, T, Tp, vsplat(ct, W), vsplat(cl, W), u, gt, z, invD, vsplat(r, W), XN, Ta,
               rq0, rq1, acc_a, acc_b, acc_h, acc_q, j, s)
        s += W

