r"""The drift of :mod:`.hmc` with specular reflection at box bounds, compiled (numba).

Per chain ``c``: move ``x`` along the velocity ``v = L p`` for time ``eps[c]``; when a coordinate
``k`` reaches its bound first, stop there, flip the momentum's component along that plane's
normal ``n = L[k]`` (the plane ``x_k = bound`` in whitened coordinates ``u = L^{-1} x``):
``p -= 2 (p.n / n.n) n``, so ``v -= 2 (p.n / n.n) M[:, k]`` with ``M = L L^T`` (``L n`` is the
metric's column ``k``: O(d) per reflection, not the O(d^2) product), and go on for the time
left. A chain that still has time left after ``max_reflections`` reflections is marked
``stuck`` (its proposal is rejected by the caller).

The vectorised NumPy version it replaces looped over reflections for all chains at once, a
dozen array operations per pass; on the 72-h Göttingen window (43 night h at their bound
h = 0) the drifts took ~10 % of the fit's time (cProfile of 400 steps).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def reflect_drift(x, p, v, L, M, lo, hi, eps, max_reflections):  # pragma: no cover - compiled
    """In place: ``x`` (m, d) positions, ``p`` (m, d) momenta, ``v`` (m, d) = ``p L^T``;
    ``L`` the metric's factor, ``M = L L^T``; ``lo``, ``hi`` (d,) bounds; ``eps`` (m,) times.
    Returns ``stuck`` (m,) booleans."""
    m, d = x.shape
    stuck = np.zeros(m, np.bool_)
    for c in range(m):
        t_left = eps[c]
        for it in range(max_reflections + 1):
            tk = np.inf
            k = -1
            for i in range(d):
                vi = v[c, i]
                if vi < 0.0:
                    t = max((lo[i] - x[c, i]) / vi, 0.0)
                elif vi > 0.0:
                    t = max((hi[i] - x[c, i]) / vi, 0.0)
                else:
                    continue
                if t < tk:
                    tk = t
                    k = i
            if k < 0 or tk >= t_left:  # no bound within the time left: the last free flight
                for i in range(d):
                    x[c, i] = min(max(x[c, i] + t_left * v[c, i], lo[i]), hi[i])
                t_left = 0.0
                break
            if it == max_reflections:
                break
            for i in range(d):
                x[c, i] += tk * v[c, i]
            x[c, k] = lo[k] if v[c, k] < 0.0 else hi[k]
            t_left -= tk
            pn = 0.0
            for i in range(d):
                pn += p[c, i] * L[k, i]
            coef = 2.0 * pn / M[k, k]
            for i in range(d):
                p[c, i] -= coef * L[k, i]
                v[c, i] -= coef * M[i, k]
        if t_left > 0.0:
            for i in range(d):
                x[c, i] = min(max(x[c, i], lo[i]), hi[i])
            stuck[c] = True
    return stuck
