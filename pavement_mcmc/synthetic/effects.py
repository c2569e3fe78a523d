"""The hidden effects a twin dataset can carry, their parameters and realistic default strengths.

Parameter names, units and meanings are those of the inversion's extension catalogue
(:mod:`pavement_mcmc.physics.catalogue`), so a fit can be compared with ``Truth.effects``
directly. ``<s>`` is a sensor label such as ``0cm`` (``Measurements.sensor_labels``).

==========================  ===============================================================
effect                      parameters (units) and default ("realistic") strength
==========================  ===============================================================
two_layer                   ``d_layer`` (m) top-layer thickness with (kappa, C) above and
                            ``kappa2`` (W m-1 K-1), ``C2`` (J m-3 K-1) below.
                            Default: 0.02, 0.6 kappa, 1.3 C.
sensor_depth                ``dz_<s>`` (m), per observed sensor: true depth = nominal + dz.
                            Default: +3, +4, -3, +5, -4 mm (pattern cycled over the sensors;
                            a true depth is never above the surface).
sensor_bias                 ``bias_<s>`` (degC), per observed sensor: recorded = true + bias.
                            Default: +0.5 on the middle observed sensor, 0 elsewhere.
wind_convection             ``h_a`` (W m-2 K-1), ``h_b`` (W m-3 K-1 s): h(t) = h_a + h_b v(t),
                            v the recorded wind (m s-1). Default: 4, 3.
evaporation                 ``evap_A`` (W m-2 per mm), ``evap_tau`` (h): latent flux out of the
                            ground evap_A sum_{t_k <= t} r_k exp(-(t - t_k) / evap_tau), r_k the
                            rain (mm) recorded at row time t_k; evaluated at the row times and
                            linear in between. Default: 30, 3 (with a 4 mm shower at 09-10 h).
conductivity_temperature    ``kappa_beta`` (1/K): kappa(T) = kappa (1 + kappa_beta (T - 20 degC)),
                            in every layer. Default: -0.005.
radiation_factor            ``rad_factor`` (-): the ground absorbs rad_factor x (recorded q_net).
                            Default: 0.85.
==========================  ===============================================================
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

EFFECTS = (
    "two_layer",
    "sensor_depth",
    "sensor_bias",
    "wind_convection",
    "evaporation",
    "conductivity_temperature",
    "radiation_factor",
)
"""Names of the hidden effects a twin dataset can carry."""

DEFAULT_RAIN = ((9.0, 1.0, 4.0),)
"""Shower used when ``evaporation`` is on and no rain is given: (start h, duration h, mm)."""

_OFFSET_PATTERN = (0.003, 0.004, -0.003, 0.005, -0.004)

# reference truth.json key of each effect (the shipped reference case's format)
REFERENCE_KEYS = {
    "two_layer": "layer",
    "sensor_depth": "sensor_depth",
    "wind_convection": "h_wind",
    "evaporation": "evap",
    "sensor_bias": "bias",
    "radiation_factor": "rad_error",
    "conductivity_temperature": "k_temp",
}


def sensor_labels(depths_cm) -> list[str]:
    """Labels of observed sensors from their depths in cm, e.g. ``'1cm'`` (as in Measurements)."""
    return [f"{d:g}cm" for d in depths_cm]


def default_effect(name: str, kappa: float, C: float, depths_cm=(0, 1, 2, 3, 4)) -> dict:
    """Realistic-strength parameters of one effect.

    Parameters
    ----------
    name : one of :data:`EFFECTS`.
    kappa : conductivity of the (top) ground, W m-1 K-1.
    C : volumetric heat capacity of the (top) ground, J m-3 K-1.
    depths_cm : nominal depths of the observed sensors, cm (for per-sensor parameters).

    Returns
    -------
    dict of catalogue parameter name -> value (float).
    """
    check_name(name)
    labels = sensor_labels(depths_cm)
    if name == "two_layer":
        return {"d_layer": 0.02, "kappa2": 0.6 * kappa, "C2": 1.3 * C}
    if name == "sensor_depth":
        pattern = np.resize(_OFFSET_PATTERN, len(labels))
        return {f"dz_{lab}": float(v) for lab, v in zip(labels, pattern, strict=True)}
    if name == "sensor_bias":
        return {f"bias_{lab}": 0.5 if i == len(labels) // 2 else 0.0 for i, lab in enumerate(labels)}
    if name == "wind_convection":
        return {"h_a": 4.0, "h_b": 3.0}
    if name == "evaporation":
        return {"evap_A": 30.0, "evap_tau": 3.0}
    if name == "conductivity_temperature":
        return {"kappa_beta": -0.005}
    return {"rad_factor": 0.85}  # radiation_factor


def check_name(name: str) -> None:
    """Raise ValueError naming the valid effects if ``name`` is not one of them."""
    if name not in EFFECTS:
        raise ValueError(f"unknown hidden effect {name!r}; valid effects: {', '.join(EFFECTS)}")


def resolve_effects(
    effects: Mapping[str, Mapping | None], kappa: float, C: float, depths_cm, bottom_cm: float
) -> dict[str, dict]:
    """Complete user-given effect parameters with the defaults and validate them.

    Parameters
    ----------
    effects : effect name -> parameter overrides (None or {} for the defaults).
    kappa, C : top-layer properties (W m-1 K-1, J m-3 K-1).
    depths_cm : nominal observed sensor depths, cm.
    bottom_cm : depth of the bottom sensor, cm.

    Returns
    -------
    effect name -> complete parameter dict (floats), in the order of :data:`EFFECTS`.
    """
    for name in effects:
        check_name(name)
    out = {}
    for name in EFFECTS:
        if name not in effects:
            continue
        params = default_effect(name, kappa, C, depths_cm)
        given = dict(effects[name] or {})
        unknown = set(given) - set(params)
        if unknown:
            raise ValueError(
                f"effect {name!r}: unknown parameter(s) {sorted(unknown)}; valid: {list(params)}"
            )
        params.update({k: float(v) for k, v in given.items()})
        if name == "sensor_depth":  # never above the surface, always above the bottom sensor
            for d, key in zip(depths_cm, params, strict=True):
                params[key] = max(params[key], -d / 100.0)
                if d / 100.0 + params[key] >= bottom_cm / 100.0:
                    raise ValueError(f"effect 'sensor_depth': {key} puts the sensor below the bottom")
        _check_ranges(name, params)
        out[name] = params
    return out


def _check_ranges(name: str, p: dict) -> None:
    bad = None
    if name == "two_layer" and not (0 < p["d_layer"] and p["kappa2"] > 0 and p["C2"] > 0):
        bad = "d_layer, kappa2 and C2 must be positive"
    elif name == "evaporation" and not (p["evap_A"] >= 0 and p["evap_tau"] > 0):
        bad = "evap_A must be >= 0 and evap_tau > 0"
    elif name == "radiation_factor" and not p["rad_factor"] > 0:
        bad = "rad_factor must be positive"
    elif name == "conductivity_temperature" and not abs(p["kappa_beta"]) < 0.02:
        bad = "|kappa_beta| must be < 0.02 1/K (kappa would change sign within 0-70 degC)"
    if bad:
        raise ValueError(f"effect {name!r}: {bad}")
