"""Layered ground: a top layer over a second material."""

from __future__ import annotations

import numpy as np

from ...parameters import Parameter
from ...parameters.priors import TruncatedNormal, Uniform
from ..base import Extension
from ..observe import cell_widths
from ..registry import register_extension


@register_extension
class TwoLayer(Extension):
    """A top layer of thickness ``d_layer`` (kappa, C) over a second material (kappa2, C2).

    Cells straddling the interface take the series (harmonic) conductivity and nodes the
    volume-weighted heat capacity, so predictions vary smoothly with ``d_layer``.
    """

    name = "two_layer"
    hint = "residuals grow with depth and lag the surface: the ground is layered"
    signals = ("depth_growth", "phase_lag", "amplitude")
    reads = ("kappa", "C")

    def start_values(self, meas, base):
        """Two starts: a thin top layer over a stiffer base, a thick one over a softer base."""
        L, k, c = meas.bottom_depth, base.get("kappa", 1.3), base.get("C", 1.5e6)
        return [{"d_layer": 0.35 * L, "kappa2": 0.7 * k, "C2": 1.2 * c},
                {"d_layer": 0.65 * L, "kappa2": 1.3 * k, "C2": 0.8 * c}]

    def parameters(self, meas):
        L = meas.bottom_depth
        return [
            Parameter("d_layer", 0.5 * L, 0.002, L - 0.002, prior=Uniform(0.002, L - 0.002),
                      unit="m", description="top layer thickness"),
            Parameter("kappa2", 1.3, 0.05, 20.0, prior=TruncatedNormal(1.5, 1.0, 0.05),
                      unit="W m-1 K-1", description="conductivity below the top layer"),
            Parameter("C2", 1.5e6, 1e5, 8e6, prior=TruncatedNormal(2.0e6, 1.0e6, 1e5),
                      unit="J m-3 K-1", description="heat capacity below the top layer"),
        ]

    def material(self, coeffs, p, model):
        x = model.grid.soil_x  # depth below the soil surface (a skin node above it: < 0)
        dxc = cell_widths(x)
        d = p["d_layer"][:, None]
        # fraction of each cell [x_i, x_i+1] above the interface
        fc = np.clip((d - x[None, :-1]) / dxc, 0.0, 1.0)
        k1, k2 = p["kappa"][:, None], p["kappa2"][:, None]
        coeffs.kappa = 1.0 / (fc / k1 + (1.0 - fc) / k2)
        # fraction of each node's control volume [x_i - dx_{i-1}/2, x_i + dx_i/2] above it
        lo = np.maximum(x - np.r_[dxc[0], dxc] / 2, x[0])
        hi = np.minimum(x + np.r_[dxc, dxc[-1]] / 2, x[-1])
        fn = np.clip((d - lo[None, :]) / (hi - lo)[None, :], 0.0, 1.0)
        c1, c2 = p["C"][:, None], p["C2"][:, None]
        coeffs.C = fn * c1 + (1.0 - fn) * c2


def h_at_times(h: np.ndarray) -> np.ndarray:
    """h of each observation time (n_sets, n_obs) from h per interval (n_sets, n_obs - 1): the
    mean of the two intervals a time joins (the end times: their one interval)."""
    return np.concatenate([h[:, :1], 0.5 * (h[:, 1:] + h[:, :-1]), h[:, -1:]], axis=1)


@register_extension
class SurfaceLayer(Extension):
    r"""A thin, poorly conducting layer (grass, thatch, mulch) above the soil: a thermal
    resistance ``R_surface`` between the surface energy balance and the soil top.

    With no heat capacity the layer passes on, per unit area, the flux
    :math:`G = (q + h (T_a - T_0)) / (1 + h R)`: both the transfer coefficient and the
    radiative forcing the soil feels are damped by :math:`1 + hR` (``h`` the fitted surface
    coefficient, ``T_0`` the soil top). Sensor depths stay measured from the soil surface.

    With ``energy_balance`` (listed before or after it) this is the canopy skin balance
    :math:`R_n = H + LE + G`, :math:`H = h_H (T_k - T_a)`, :math:`G = (T_k - T_0)/R`, solved
    for the skin temperature :math:`T_k = T_0 + R\,G` (:meth:`skin`): the surface an infrared
    thermometer sees (``[data] ir_sigma``), which is what pins ``R`` and the H law.
    """

    name = "surface_layer"
    hint = ("the shallowest sensor's daily wave is damped and late against the net radiation: "
            "a layer of grass, thatch or mulch insulates the soil")
    signals = ("phase_lag", "amplitude", "corr:q_net")
    reads = ("h",)

    def parameters(self, meas):
        return [Parameter("R_surface", 0.0, 0.0, 2.0, prior=Uniform(0.0, 2.0), unit="m2 K W-1",
                          description="thermal resistance of the surface layer")]

    def null_values(self, meas):
        return {"R_surface": 0.0}

    def start_values(self, meas, base):
        return [{"R_surface": 0.05}, {"R_surface": 0.3}]

    def surface(self, coeffs, p, model):
        R = p["R_surface"][:, None]
        q_damp = 1.0 + h_at_times(coeffs.h) * R
        coeffs.h = coeffs.h / (1.0 + coeffs.h * R)
        coeffs.q = coeffs.q / q_damp

    def skin(self, T, G, p, model):
        return T + p["R_surface"][:, None] * G

    def skin_vjp(self, g, T, G, p, model):
        return g, p["R_surface"][:, None] * g, {"R_surface": np.sum(g * G, axis=1)}

    def surface_vjp(self, g_h, g_q, h_in, q_in, p, model):
        R = p["R_surface"][:, None]
        hb = h_at_times(h_in)
        dh, dq = 1.0 + h_in * R, 1.0 + hb * R
        v = -g_q * q_in * R / dq**2  # d loss / d hb
        g_hin = g_h / dh**2
        g_hin[:, 0] += v[:, 0]
        g_hin[:, -1] += v[:, -1]
        g_hin[:, :-1] += 0.5 * v[:, 1:-1]
        g_hin[:, 1:] += 0.5 * v[:, 1:-1]
        g_R = -np.sum(g_h * h_in**2 / dh**2, axis=1) - np.sum(g_q * q_in * hb / dq**2, axis=1)
        return g_hin, g_q / dq, {"R_surface": g_R}
