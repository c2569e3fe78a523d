"""Sensor errors: depth offsets and calibration biases of the observed sensors."""

from __future__ import annotations

import numpy as np

from ...parameters import Parameter
from ...parameters.priors import Normal
from ..base import Extension
from ..observe import interpolate, interpolation_weights
from ..registry import register_extension


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
        i, w = interpolation_weights(model.grid.x,
                                     model.meas.depths[None, :] + model.grid.soil_top + dz)
        shifted = interpolate(T_nodes, i, w)
        # add the depth change to what the earlier hooks made (e.g. sensor_bias), not replace it
        return pred + shifted - model.observe_nominal(T_nodes)

    def observe_vjp(self, g_pred, T_nodes, p, model):
        labels = model.meas.sensor_labels
        dz = np.stack([p[f"dz_{lab}"] for lab in labels], axis=-1)
        x = model.grid.x
        i, w = interpolation_weights(x, model.meas.depths[None, :] + model.grid.soil_top + dz)
        rows = np.arange(T_nodes.shape[0])[:, None]
        times = np.arange(T_nodes.shape[1])[None, :]
        gT = np.zeros(T_nodes.shape)
        grads = {}
        for k, lab in enumerate(labels):
            ik, wk, gk = i[:, k:k + 1], w[:, k:k + 1], g_pred[..., k]  # (n_sets, 1) x2, (n_sets, n_obs)
            np.add.at(gT, (rows, times, ik), gk * (1.0 - wk))
            np.add.at(gT, (rows, times, ik + 1), gk * wk)
            slope = T_nodes[rows, times, ik + 1] - T_nodes[rows, times, ik]
            grads[f"dz_{lab}"] = np.sum(gk * slope, axis=1) / np.diff(x)[ik[:, 0]]
        gT -= model.observe_nominal_transpose(g_pred)
        return g_pred, gT, grads


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

    def observe_vjp(self, g_pred, T_nodes, p, model):
        grads = {f"bias_{lab}": g_pred[..., k].sum(axis=1)
                 for k, lab in enumerate(model.meas.sensor_labels)}
        return g_pred, np.zeros(T_nodes.shape), grads
