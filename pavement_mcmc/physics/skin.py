r"""The skin temperature: where the surface energy balance acts, and what an infrared
thermometer reads.

Without a surface layer the skin is the soil's top node, :math:`T_k = T_0`. A layer of grass,
thatch or mulch (``surface_layer``, resistance :math:`R` in m2 K W-1) sits between the two: the
balance :math:`R_n = H + LE + G` acts on the canopy skin, and the flux :math:`G` that enters the
soil crosses the layer,

.. math::

    G = \frac{T_k - T_0}{R} \quad\Longrightarrow\quad T_k = T_0 + R\,G,

with :math:`G = h (T_a - T_0) + q` the model's surface flux (:meth:`Model.surface_flux`, the
coefficients after every surface hook). An extension places the skin by overriding
:meth:`~pavement_mcmc.physics.base.Extension.skin` and its adjoint ``skin_vjp``.
:func:`skin_vjp` gives the adjoint to the observation streams: the cotangent of the top node and
those of the final surface coefficients ``h`` and ``q`` (which :meth:`Model.solve_vjp` carries
back through the surface hooks to the parameters).
"""

from __future__ import annotations

import numpy as np

from .base import Extension

__all__ = ["skin_temperature", "skin_vjp"]


def _skins(model) -> list[Extension]:
    return [e for e in model.extensions if type(e).skin is not Extension.skin]


def skin_temperature(model, T_nodes: np.ndarray, coeffs, p: dict) -> np.ndarray:
    """Skin temperature (n_sets, n_obs), degC, from nodal temperatures (n_sets, n_obs, n_nodes)."""
    T = T_nodes[..., 0]
    exts = _skins(model)
    if not exts:
        return T
    if model.top_measured:
        raise ValueError("a measured top has no skin: its top node is a buried sensor")
    G = model.surface_flux(T_nodes, coeffs)
    for ext in exts:
        T = ext.skin(T, G, p, model)
    return T


def skin_vjp(model, g: np.ndarray, T_nodes: np.ndarray, coeffs, p: dict
             ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Adjoint of :func:`skin_temperature` for the cotangent ``g`` (n_sets, n_obs): the top
    node's cotangent (n_sets, n_obs) and the direct gradients (the extensions' own parameters;
    ``"h"`` (n_sets, n_obs - 1) and ``"q"`` (n_sets, n_obs), cotangents of the final surface
    coefficients)."""
    exts = _skins(model)
    if not exts:
        return g, {}
    G = model.surface_flux(T_nodes, coeffs)
    T0 = T_nodes[..., 0]
    ins = [T0]
    for ext in exts[:-1]:
        ins.append(ext.skin(ins[-1], G, p, model))
    g_G = np.zeros_like(g)
    direct: dict[str, np.ndarray] = {}
    for ext, T_in in zip(reversed(exts), reversed(ins), strict=True):
        g, gG, own = ext.skin_vjp(g, T_in, G, p, model)
        g_G += gG
        direct.update(own)
    # G = h_t (T_a - T_0) + q, h_t the h of the interval ending at each time (row 0: the first)
    h_t = np.concatenate([coeffs.h[:, :1], coeffs.h], axis=1)
    g_ht = g_G * (model.forcing.T_air[None, :] - T0)
    g_h = g_ht[:, 1:].copy()
    g_h[:, 0] += g_ht[:, 0]
    direct["h"], direct["q"] = g_h, g_G
    return g - h_t * g_G, direct
