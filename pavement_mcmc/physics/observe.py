"""Observation operators: nodal temperatures -> temperatures at given depths (linear interpolation).

The one place sensor interpolation is written: :meth:`Model.observe_nominal`, the ``sensor_depth``
extension and the hold-out predictions of the criticism all use it.
"""

from __future__ import annotations

import numpy as np


def interpolation_weights(x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Left node index and weight of the right node for linear interpolation at depths ``z``.

    Works for any shape of ``z``; depths are clipped to the grid.
    """
    dx = x[1] - x[0]
    zc = np.clip(z, x[0], x[-1])
    i = np.minimum(((zc - x[0]) / dx).astype(int), x.size - 2)
    w = (zc - x[i]) / dx
    return i, w


def interpolate(T_nodes: np.ndarray, i: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Temperatures (..., n_depths) at the depths of :func:`interpolation_weights` ``(i, w)``.

    ``T_nodes`` is (..., n_nodes); ``i`` and ``w`` are (n_depths,) (shared by every leading
    index).
    """
    return T_nodes[..., i] * (1.0 - w) + T_nodes[..., i + 1] * w


def interpolate_transpose(G: np.ndarray, i: np.ndarray, w: np.ndarray, n_nodes: int) -> np.ndarray:
    """Adjoint of :func:`interpolate`: cotangents (..., n_depths) -> nodes (..., n_nodes)."""
    out = np.zeros(G.shape[:-1] + (n_nodes,))
    for k in range(G.shape[-1]):
        out[..., i[k]] += G[..., k] * (1.0 - w[k])
        out[..., i[k] + 1] += G[..., k] * w[k]
    return out
