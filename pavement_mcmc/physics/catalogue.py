"""The shipped catalogue of physical effects a base model may be missing.

Each class is one effect: explicit parameter names with bounds and priors, and one hook.
Parameterisations match :mod:`pavement_mcmc.synthetic`, which can hide each of them in twin data.

Two optional attributes serve the criticism (:mod:`pavement_mcmc.criticism`), any extension may
define them: ``signals`` names the residual patterns that point at the effect (keys of
:func:`pavement_mcmc.criticism.residuals.plain_signals`, e.g. ``"corr:wind"``), and
``start_values(meas, base)`` returns a list of starting points (dicts by parameter name) for a
quick refit from the fitted values ``base`` of the model without the effect.
"""

from __future__ import annotations

import numpy as np

from ..parameters import Parameter
from ..parameters.priors import Normal, TruncatedNormal, Uniform
from .base import Extension
from .observe import interpolate, interpolation_weights
from .registry import register_extension


@register_extension
class TwoLayer(Extension):
    """A top layer of thickness ``d_layer`` (kappa, C) over a second material (kappa2, C2).

    Cells straddling the interface take the series (harmonic) conductivity and nodes the
    volume-weighted heat capacity, so predictions vary smoothly with ``d_layer``.
    """

    name = "two_layer"
    hint = "residuals grow with depth and lag the surface: the ground is layered"
    signals = ("depth_growth", "phase_lag", "amplitude")

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
        x = model.grid.x
        dx = x[1] - x[0]
        d = p["d_layer"][:, None]
        # fraction of each cell [x_i, x_i+1] above the interface
        fc = np.clip((d - x[None, :-1]) / dx, 0.0, 1.0)
        k1, k2 = p["kappa"][:, None], p["kappa2"][:, None]
        coeffs.kappa = 1.0 / (fc / k1 + (1.0 - fc) / k2)
        # fraction of each node's control volume [x_i - dx/2, x_i + dx/2] (clipped) above it
        lo = np.maximum(x - dx / 2, x[0])
        hi = np.minimum(x + dx / 2, x[-1])
        fn = np.clip((d - lo[None, :]) / (hi - lo)[None, :], 0.0, 1.0)
        c1, c2 = p["C"][:, None], p["C2"][:, None]
        coeffs.C = fn * c1 + (1.0 - fn) * c2


def _sensor_params(meas, prefix: str, make) -> list[Parameter]:
    return [make(f"{prefix}_{lab}", z) for lab, z in zip(meas.sensor_labels, meas.depths)]


@register_extension
class SensorDepth(Extension):
    """A depth offset per observed sensor: it really sits at nominal depth + ``dz_<sensor>``."""

    name = "sensor_depth"
    hint = "misfit at single sensors, amplitude too large or small for their nominal depth"
    signals = ("sensor_pattern", "amplitude")

    def parameters(self, meas):
        def make(name, z):
            lo = max(-0.01, -z)
            return Parameter(name, 0.0, lo, 0.01, prior=Normal(0.0, 0.004), unit="m",
                             description="sensor depth offset (positive = deeper)")

        return _sensor_params(meas, "dz", make)

    def null_values(self, meas):
        return {p.name: 0.0 for p in self.parameters(meas)}

    def observe(self, pred, T_nodes, p, model):
        labels = model.meas.sensor_labels
        dz = np.stack([p[f"dz_{lab}"] for lab in labels], axis=-1)  # (n_sets, n_sensors)
        i, w = interpolation_weights(model.grid.x, model.meas.depths[None, :] + dz)
        shifted = interpolate(T_nodes, i, w)
        # add the depth change to what the earlier hooks made (e.g. sensor_bias), not replace it
        return pred + shifted - model.observe_nominal(T_nodes)


@register_extension
class SensorBias(Extension):
    """A constant offset per observed sensor (calibration error): recorded = true + bias."""

    name = "sensor_bias"
    hint = "a constant offset at one sensor"
    signals = ("single_sensor",)

    def parameters(self, meas):
        return _sensor_params(
            meas, "bias",
            lambda n, z: Parameter(n, 0.0, -5.0, 5.0, prior=Normal(0.0, 0.5), unit="degC",
                                   description="sensor calibration offset"),
        )

    def null_values(self, meas):
        return {p.name: 0.0 for p in self.parameters(meas)}

    def observe(self, pred, T_nodes, p, model):
        b = np.stack([p[f"bias_{lab}"] for lab in model.meas.sensor_labels], axis=-1)
        return pred + b[:, None, :]


@register_extension
class WindConvection(Extension):
    """h(t) = h_a + h_b v(t) from the measured wind, instead of free h pieces."""

    name = "wind_convection"
    hint = "surface misfit that follows the wind speed"
    replaces_h = True
    signals = ("corr:wind", "corr:T_air-T_s")

    def start_values(self, meas, base):
        """Start from the still-air and windy h the fitted pieces suggest (2 starts)."""
        return [{"h_a": 5.0, "h_b": 3.0}, {"h_a": 10.0, "h_b": 1.0}]

    def parameters(self, meas):
        if meas.wind is None:
            raise ValueError("wind_convection needs a 'wind' column in the data")
        return [
            Parameter("h_a", 5.0, 0.0, 100.0, prior=TruncatedNormal(5.0, 5.0), unit="W m-2 K-1",
                      description="still-air heat transfer coefficient"),
            Parameter("h_b", 3.0, 0.0, 50.0, prior=TruncatedNormal(3.0, 3.0),
                      unit="W m-3 K-1 s", description="wind sensitivity of h"),
        ]

    def surface(self, coeffs, p, model):
        v = model.meas.wind
        v_mid = 0.5 * (v[:-1] + v[1:])
        coeffs.h = p["h_a"][:, None] + p["h_b"][:, None] * v_mid[None, :]


@register_extension
class Evaporation(Extension):
    r"""A latent heat sink at the surface after rain, driven by the ``rain`` column.

    .. math:: q_{evap}(t) = A \sum_{k: t_k \le t} r_k \exp(-(t - t_k)/\tau)

    with ``evap_A`` (W m-2 per mm of rain) and ``evap_tau`` (hours); flux out of the ground.
    """

    name = "evaporation"
    hint = "surface too warm after rain"
    signals = ("corr:rain",)

    def parameters(self, meas):
        if meas.rain is None:
            raise ValueError("evaporation needs a 'rain' column in the data")
        return [
            Parameter("evap_A", 0.0, 0.0, 500.0, prior=TruncatedNormal(0.0, 50.0),
                      unit="W m-2 mm-1", description="latent sink per mm of rain"),
            Parameter("evap_tau", 3.0, 0.25, 48.0, prior=TruncatedNormal(3.0, 3.0, 0.25),
                      unit="h", description="drying time scale"),
        ]

    def null_values(self, meas):
        return {"evap_A": 0.0, "evap_tau": 3.0}

    def surface(self, coeffs, p, model):
        t, rain = model.meas.t, model.meas.rain
        tau = p["evap_tau"] * 3600.0
        s = np.zeros_like(tau)
        sink = np.empty((tau.size, t.size))
        for j in range(t.size):  # short recursion over observation times, vectorised over sets
            if j:
                s = s * np.exp(-(t[j] - t[j - 1]) / tau)
            s = s + rain[j]
            sink[:, j] = s
        coeffs.q -= p["evap_A"][:, None] * sink


@register_extension
class ConductivityTemperature(Extension):
    """kappa(T) = kappa (1 + kappa_beta (T - 20 degC))."""

    name = "conductivity_temperature"
    hint = "misfit that grows with temperature: conductivity depends on T"
    signals = ("corr:T_sensor", "amplitude")

    def parameters(self, meas):
        return [Parameter("kappa_beta", 0.0, -0.03, 0.03, prior=Normal(0.0, 0.005), unit="K-1",
                          description="relative temperature coefficient of kappa")]

    def null_values(self, meas):
        return {"kappa_beta": 0.0}

    def material(self, coeffs, p, model):
        coeffs.beta = np.asarray(p["kappa_beta"], float)
        coeffs.T_ref = 20.0


@register_extension
class RadiationFactor(Extension):
    """The ground absorbs ``rad_factor`` x the recorded q_net (radiometer calibration).

    Not identifiable on its own: scaling kappa, C, h and this factor together leaves the
    equations unchanged, only the priors on kappa or C pin it.
    """

    name = "radiation_factor"
    hint = "daytime amplitude wrong at every depth in proportion to net radiation"
    signals = ("corr:q_net", "amplitude")

    def parameters(self, meas):
        return [Parameter("rad_factor", 1.0, 0.3, 2.0, prior=TruncatedNormal(1.0, 0.1),
                          description="scale on the recorded net radiation")]

    def null_values(self, meas):
        return {"rad_factor": 1.0}

    def surface(self, coeffs, p, model):
        coeffs.q += (p["rad_factor"] - 1.0)[:, None] * model.meas.q_net[None, :]
