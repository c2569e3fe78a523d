"""Observation operators: nodal temperatures -> temperatures at given depths (linear interpolation).

The one place sensor interpolation is written: :meth:`Model.observe_nominal`, the ``sensor_depth``
extension and the hold-out predictions of the criticism all use it.
"""

from __future__ import annotations

import numpy as np


def interpolation_weights(x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Left node index and weight of the right node for linear interpolation at depths ``z``.

    ``x`` are the grid's nodes (uniform or not); ``z`` may have any shape; depths are clipped
    to the grid.
    """
    zc = np.clip(z, x[0], x[-1])
    steps = np.diff(x)
    dx = x[1] - x[0]
    if np.allclose(steps, dx, rtol=1e-9, atol=0.0):  # uniform: index by division
        i = np.minimum(((zc - x[0]) / dx).astype(int), x.size - 2)
        return i, (zc - x[i]) / dx
    i = np.clip(np.searchsorted(x, zc, side="right") - 1, 0, x.size - 2)
    return i, (zc - x[i]) / steps[i]


def interpolate(T_nodes: np.ndarray, i: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Temperatures at the depths of :func:`interpolation_weights` ``(i, w)``.

    ``T_nodes`` is (..., n_nodes). ``i`` and ``w`` are (n_depths,), shared by every leading
    index, giving (..., n_depths); or (n_sets, n_depths), one row per parameter set of
    ``T_nodes`` (n_sets, n_obs, n_nodes), giving (n_sets, n_obs, n_depths).
    """
    if np.ndim(i) == 1:
        return T_nodes[..., i] * (1.0 - w) + T_nodes[..., i + 1] * w
    rows = np.arange(T_nodes.shape[0])[:, None, None]
    obs_t = np.arange(T_nodes.shape[1])[None, :, None]
    Tl = T_nodes[rows, obs_t, i[:, None, :]]
    Tr = T_nodes[rows, obs_t, i[:, None, :] + 1]
    return Tl * (1.0 - w[:, None, :]) + Tr * w[:, None, :]


def interpolate_transpose(G: np.ndarray, i: np.ndarray, w: np.ndarray, n_nodes: int) -> np.ndarray:
    """Adjoint of :func:`interpolate`: cotangents (..., n_depths) -> nodes (..., n_nodes)."""
    out = np.zeros(G.shape[:-1] + (n_nodes,))
    for k in range(G.shape[-1]):
        out[..., i[k]] += G[..., k] * (1.0 - w[k])
        out[..., i[k] + 1] += G[..., k] * w[k]
    return out
