"""Observation operators: nodal temperatures -> temperatures at given depths (linear interpolation).

The one place sensor interpolation is written: :meth:`Model.observe_nominal`, the ``sensor_depth``
extension and the hold-out predictions of the criticism all use it.
"""

from __future__ import annotations

import numpy as np


def cell_widths(x: np.ndarray) -> np.ndarray:
    """(n_cells,) widths of the grid's cells, m; on a uniform grid every entry is exactly
    ``x[1] - x[0]`` (so formulas written for a scalar spacing give the same floats)."""
    dx = x[1] - x[0]
    steps = np.diff(x)
    return np.full(steps.size, dx) if np.allclose(steps, dx, rtol=1e-9, atol=0.0) else steps


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


def flux_weights(x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cell index and weight of the next cell for the heat flux at depths ``z`` (m).

    The finite-volume fluxes live at the cell midpoints; the flux at ``z`` interpolates the two
    cells whose midpoints enclose it (a plate on a node: the mean of its two cells, the
    central-difference gradient on a uniform grid). Depths outside the midpoints use the end cell.
    """
    mid = 0.5 * (x[1:] + x[:-1])
    if mid.size < 2:
        return np.zeros(np.shape(z), int), np.zeros(np.shape(z))
    zc = np.clip(z, mid[0], mid[-1])
    c = np.clip(np.searchsorted(mid, zc, side="right") - 1, 0, mid.size - 2)
    return c, (zc - mid[c]) / (mid[c + 1] - mid[c])


def heat_flux(T_nodes: np.ndarray, kappa: np.ndarray, x: np.ndarray, c: np.ndarray,
              w: np.ndarray) -> np.ndarray:
    """Conductive heat flux ``-kappa dT/dz`` (W m-2, positive downward) at the depths of
    :func:`flux_weights` ``(c, w)``: (n_sets, n_obs, n_depths) from nodal temperatures
    (n_sets, n_obs, n_nodes) and cell conductivities ``kappa`` (n_sets, n_cells)."""
    dx = np.diff(x)
    F0 = kappa[:, None, c] * (T_nodes[..., c] - T_nodes[..., c + 1]) / dx[c]
    F1 = kappa[:, None, c + 1] * (T_nodes[..., c + 1] - T_nodes[..., c + 2]) / dx[c + 1]
    return F0 * (1.0 - w) + F1 * w


def heat_flux_vjp(g: np.ndarray, T_nodes: np.ndarray, kappa: np.ndarray, x: np.ndarray,
                  c: np.ndarray, w: np.ndarray, gT: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Adjoint of :func:`heat_flux`: cotangents ``g`` (n_sets, n_obs, n_depths) -> (nodal
    cotangents (n_sets, n_obs, n_nodes), added into ``gT`` when given; cell-conductivity
    gradient (n_sets, n_cells))."""
    dx = np.diff(x)
    gT = np.zeros(T_nodes.shape) if gT is None else gT
    gk = np.zeros(kappa.shape)
    for j in range(g.shape[-1]):
        for cell, wt in ((c[j], 1.0 - w[j]), (c[j] + 1, w[j])):
            gj = g[..., j] * wt  # (n_sets, n_obs)
            a = gj * kappa[:, None, cell] / dx[cell]
            gT[..., cell] += a
            gT[..., cell + 1] -= a
            gk[:, cell] += np.sum(gj * (T_nodes[..., cell] - T_nodes[..., cell + 1]), axis=1) / dx[cell]
    return gT, gk
