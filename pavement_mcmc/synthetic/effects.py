"""The hidden effects a twin dataset can carry, their parameters and realistic default strengths.

Each effect is a small :class:`TwinEffect` class (its realistic defaults, the checks of its
parameters), registered by name like the inversion's extensions are
(:class:`~pavement_mcmc.data.plugins.Registry`); the simulator applies its physics by name. Three
groups (all selected the same way, by name in ``SyntheticSpec.effects``):

- :data:`EFFECTS`: the seven the inversion's extension catalogue
  (:mod:`pavement_mcmc.physics.catalogue`) models today, with its parameter names, units and
  meanings, so a fit can be compared with ``Truth.effects`` directly.
- :data:`NEW_CATALOGUE_EFFECTS`: ``surface_layer`` and ``evapotranspiration``, planned catalogue
  entries. The simulator's physics differs from the planned extension on purpose (no inverse
  crime): a real thatch layer with heat capacity where the extension has a pure resistance
  ``R_surface``, and Priestley-Taylor on R_n - G where the extension uses ``max(q_net, 0)``.
  The parameters the extension will share (``R_surface``, ``et_alpha``) are recorded.
- :data:`OFF_CATALOGUE_EFFECTS`: ``sensor_lag``, ``shading``, ``buried_source``, which no
  extension models: the diagnosis should answer "none of these".

``<s>`` is a sensor label such as ``0cm`` (``Measurements.sensor_labels``). Depths are measured
from the soil surface (below a ``surface_layer``, if any).

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
surface_layer               ``layer_thickness`` (m), ``layer_kappa`` (W m-1 K-1), ``layer_C``
                            (J m-3 K-1): thatch / grass / mulch above the soil; the surface
                            energy balance acts on its top, every sensor and plate sits
                            layer_thickness deeper in the column than its nominal (soil) depth.
                            Recorded, derived: ``R_surface`` = thickness / layer_kappa
                            (m2 K W-1). Default: 0.015, 0.06, 0.3e6 (R_surface 0.25).
evapotranspiration          ``et_alpha`` (-): latent heat leaving the surface,
                            LE = et_alpha s/(s + gamma) max(R_n - G, 0), s the slope of the
                            saturation vapour pressure (Tetens) at T_air, gamma = 0.066 kPa/K,
                            R_n = absorbed SW + LW_down - emitted LW, G the conductive flux into
                            the ground (lagged one solver step); with the spec's
                            ``et_available = "net"``: max(R_n, 0), the form of the
                            inversion's ``energy_balance``. Default: 1.0. The series is
                            recorded in ``Truth.q_et``.
sensor_lag                  ``lag_sensor_cm`` (cm, nominal depth of one observed sensor),
                            ``lag_minutes`` (min): that sensor reads a first-order lag of its
                            true temperature (poor thermal contact). Default: the middle
                            observed sensor, 60.
shading                     ``shade_fraction`` (-), ``shade_start``, ``shade_end`` (clock hours
                            of the spec's time0 clock): a shadow removes this fraction of the
                            absorbed short-wave every day between the two hours, with 10 min
                            linear edges centred on them (the recorded q_net, from a
                            radiometer in the sun, does not see it).
                            Default: 0.6, 13.5, 16.5 (edges off the whole hours: on them,
                            1 h pieces of h(t) absorb most of the shadow).
buried_source               ``source_flux`` (W m-2, > 0 heats), ``source_depth`` (m): a steady
                            heat source concentrated at that depth (a warm pipe, a heating
                            cable on low power). Default: 50, halfway between the second and
                            third observed sensor (between the last two sensors, bottom
                            included, if there are fewer); 15 W m-2 is mostly absorbed by
                            kappa in a fit of the 0-5 cm geometry.
sensor_sun                  ``sun_sensor_cm`` (cm, nominal depth of one observed sensor),
                            ``sun_gain`` (K per kW m-2): that sensor, in the sun, reads warm
                            by sun_gain x the absorbed short-wave. Default: the shallowest
                            observed sensor, 1.5 (about +1.2 K at noon in summer).
==========================  ===============================================================

Default strengths of the off-catalogue effects were chosen with MAP refits of the base model
(1 h pieces of h(t), kappa / C priors +-5 % centred 3 % off, sigma 0.2 degC, the corpus'
settings; seeds 21-23): refit RMSE 0.23 degC without an effect; sensor_lag 1.26-1.28
(lag-1 autocorrelation 0.9); shading 0.64-0.68 (0.27-0.28 with edges at 13 and 17 h);
buried_source 0.28-0.30 (0.23-0.24 at 15 W m-2).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..data.plugins import Registry

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


class TwinEffect:
    """A hidden effect of the twin simulator: its parameters' realistic defaults and checks.

    A subclass sets ``name``, ``group`` (``"catalogue"``, ``"new_catalogue"`` or
    ``"off_catalogue"``) and its ``default`` values (or overrides :meth:`defaults` when they
    depend on the ground or the sensors); the other hooks do nothing by default.
    Depths are in cm (``depths_cm``: the observed sensors, ``bottom_cm``: the bottom sensor).
    """

    name: str = ""
    group: str = "catalogue"
    default: dict[str, float] = {}

    def defaults(self, kappa: float, C: float, depths_cm, bottom_cm: float) -> dict[str, float]:
        """Parameter name -> realistic default value (kappa, C: the top ground's)."""
        return dict(self.default)

    def refuse(self, given: dict) -> str | None:
        """Why the user-given parameters ``given`` cannot be taken (None: they can)."""
        return None

    def place(self, p: dict, depths_cm, bottom_cm: float) -> None:
        """Check (ValueError) and adjust ``p`` in place against the sensor geometry."""

    def bad(self, p: dict) -> str | None:
        """What is out of range in the complete parameters ``p`` (None: nothing)."""
        return None

    def derive(self, p: dict) -> None:
        """Add the recorded, derived parameters to ``p`` in place."""


_TWIN_EFFECTS: Registry[type[TwinEffect]] = Registry(TwinEffect, "hidden effect")
register_twin_effect = _TWIN_EFFECTS.register


@register_twin_effect
class TwoLayer(TwinEffect):
    name = "two_layer"

    def defaults(self, kappa, C, depths_cm, bottom_cm):
        return {"d_layer": 0.02, "kappa2": 0.6 * kappa, "C2": 1.3 * C}

    def bad(self, p):
        ok = 0 < p["d_layer"] and p["kappa2"] > 0 and p["C2"] > 0
        return None if ok else "d_layer, kappa2 and C2 must be positive"


@register_twin_effect
class SensorDepth(TwinEffect):
    name = "sensor_depth"

    def defaults(self, kappa, C, depths_cm, bottom_cm):
        labels = sensor_labels(depths_cm)
        pattern = np.resize(_OFFSET_PATTERN, len(labels))
        return {f"dz_{lab}": float(v) for lab, v in zip(labels, pattern, strict=True)}

    def place(self, p, depths_cm, bottom_cm):  # never above the surface, always above the bottom
        for d, key in zip(depths_cm, p, strict=True):
            p[key] = max(p[key], -d / 100.0)
            if d / 100.0 + p[key] >= bottom_cm / 100.0:
                raise ValueError(f"effect 'sensor_depth': {key} puts the sensor below the bottom")


@register_twin_effect
class SensorBias(TwinEffect):
    name = "sensor_bias"

    def defaults(self, kappa, C, depths_cm, bottom_cm):
        labels = sensor_labels(depths_cm)
        return {f"bias_{lab}": 0.5 if i == len(labels) // 2 else 0.0 for i, lab in enumerate(labels)}


@register_twin_effect
class WindConvection(TwinEffect):
    name = "wind_convection"
    default = {"h_a": 4.0, "h_b": 3.0}


@register_twin_effect
class Evaporation(TwinEffect):
    name = "evaporation"
    default = {"evap_A": 30.0, "evap_tau": 3.0}

    def bad(self, p):
        return None if p["evap_A"] >= 0 and p["evap_tau"] > 0 else "evap_A must be >= 0 and evap_tau > 0"


@register_twin_effect
class ConductivityTemperature(TwinEffect):
    name = "conductivity_temperature"
    default = {"kappa_beta": -0.005}

    def bad(self, p):
        ok = abs(p["kappa_beta"]) < 0.02
        return None if ok else "|kappa_beta| must be < 0.02 1/K (kappa would change sign within 0-70 degC)"


@register_twin_effect
class RadiationFactor(TwinEffect):
    name = "radiation_factor"
    default = {"rad_factor": 0.85}

    def bad(self, p):
        return None if p["rad_factor"] > 0 else "rad_factor must be positive"


@register_twin_effect
class SurfaceLayer(TwinEffect):
    name = "surface_layer"
    group = "new_catalogue"
    default = {"layer_thickness": 0.015, "layer_kappa": 0.06, "layer_C": 0.3e6, "R_surface": 0.25}

    def refuse(self, given):
        if "R_surface" in given:
            return ("R_surface is derived (layer_thickness / layer_kappa); give layer_thickness "
                    "and layer_kappa instead")
        return None

    def bad(self, p):
        ok = 0 < p["layer_thickness"] <= 0.2 and p["layer_kappa"] > 0 and p["layer_C"] > 0
        return None if ok else "layer_thickness must be in (0, 0.2] m, layer_kappa and layer_C positive"

    def derive(self, p):
        p["R_surface"] = p["layer_thickness"] / p["layer_kappa"]


@register_twin_effect
class Evapotranspiration(TwinEffect):
    name = "evapotranspiration"
    group = "new_catalogue"
    default = {"et_alpha": 1.0}

    def bad(self, p):
        ok = 0 <= p["et_alpha"] <= 1.3
        return None if ok else "et_alpha must be in [0, 1.3] (Priestley-Taylor: 1.26 over wet ground)"


@register_twin_effect
class SensorLag(TwinEffect):
    name = "sensor_lag"
    group = "off_catalogue"

    def defaults(self, kappa, C, depths_cm, bottom_cm):
        return {"lag_sensor_cm": float(depths_cm[len(depths_cm) // 2]), "lag_minutes": 60.0}

    def place(self, p, depths_cm, bottom_cm):
        if not any(abs(p["lag_sensor_cm"] - d) < 1e-9 for d in depths_cm):
            raise ValueError(
                f"effect 'sensor_lag': lag_sensor_cm={p['lag_sensor_cm']:g} is not an observed "
                f"sensor; valid: {', '.join(f'{d:g}' for d in depths_cm)}"
            )

    def bad(self, p):
        return None if p["lag_minutes"] > 0 else "lag_minutes must be positive"


@register_twin_effect
class Shading(TwinEffect):
    name = "shading"
    group = "off_catalogue"
    default = {"shade_fraction": 0.6, "shade_start": 13.5, "shade_end": 16.5}

    def bad(self, p):
        ok = 0 < p["shade_fraction"] <= 1 and 0 <= p["shade_start"] < p["shade_end"] <= 24
        why = "shade_fraction must be in (0, 1] and 0 <= shade_start < shade_end <= 24 (clock hours)"
        return None if ok else why


@register_twin_effect
class BuriedSource(TwinEffect):
    name = "buried_source"
    group = "off_catalogue"

    def defaults(self, kappa, C, depths_cm, bottom_cm):
        column = [*depths_cm, bottom_cm]
        around = column[1:3] if len(depths_cm) >= 3 else column[-2:]
        return {"source_flux": 50.0, "source_depth": float(np.mean(around)) / 100.0}

    def place(self, p, depths_cm, bottom_cm):
        if not 0 < p["source_depth"] < bottom_cm / 100.0:
            raise ValueError(
                f"effect 'buried_source': source_depth={p['source_depth']:g} m must lie "
                f"between the surface and the bottom sensor ({bottom_cm / 100.0:g} m)"
            )


@register_twin_effect
class SensorSun(TwinEffect):
    name = "sensor_sun"
    group = "off_catalogue"

    def defaults(self, kappa, C, depths_cm, bottom_cm):
        return {"sun_sensor_cm": float(depths_cm[0]), "sun_gain": 1.5}

    def place(self, p, depths_cm, bottom_cm):
        if not any(abs(p["sun_sensor_cm"] - d) < 1e-9 for d in depths_cm):
            raise ValueError(f"effect 'sensor_sun': sun_sensor_cm={p['sun_sensor_cm']:g} is "
                             f"not an observed sensor; valid: {', '.join(f'{d:g}' for d in depths_cm)}")


def _group(group: str) -> tuple[str, ...]:
    return tuple(n for n, cls in _TWIN_EFFECTS.classes.items() if cls.group == group)


EFFECTS = _group("catalogue")
"""Names of the hidden effects the inversion's catalogue models today."""

NEW_CATALOGUE_EFFECTS = _group("new_catalogue")
"""Effects with planned catalogue entries (the simulator uses different physics)."""

OFF_CATALOGUE_EFFECTS = _group("off_catalogue")
"""Effects no catalogue entry models: a diagnosis should name none of its candidates."""

ALL_EFFECTS = EFFECTS + NEW_CATALOGUE_EFFECTS + OFF_CATALOGUE_EFFECTS
"""Every hidden effect the simulator can carry, in the order ``Truth.effects`` lists them."""


def twin_effect(name: str) -> TwinEffect:
    """The :class:`TwinEffect` called ``name``; ValueError naming the valid effects if none."""
    check_name(name)
    return _TWIN_EFFECTS.get(name)()


def default_effect(
    name: str, kappa: float, C: float, depths_cm=(0, 1, 2, 3, 4), bottom_cm: float = 5.0
) -> dict:
    """Realistic-strength parameters of one effect.

    Parameters
    ----------
    name : one of :data:`ALL_EFFECTS`.
    kappa : conductivity of the (top) ground, W m-1 K-1.
    C : volumetric heat capacity of the (top) ground, J m-3 K-1.
    depths_cm : nominal depths of the observed sensors, cm (for per-sensor parameters).
    bottom_cm : nominal depth of the bottom sensor, cm (for ``buried_source``).

    Returns
    -------
    dict of catalogue parameter name -> value (float).
    """
    return twin_effect(name).defaults(kappa, C, depths_cm, bottom_cm)


def check_name(name: str) -> None:
    """Raise ValueError naming the valid effects if ``name`` is not one of them."""
    if name not in ALL_EFFECTS:
        raise ValueError(f"unknown hidden effect {name!r}; valid effects: {', '.join(ALL_EFFECTS)}")


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
    effect name -> complete parameter dict (floats), in the order of :data:`ALL_EFFECTS`.
    """
    for name in effects:
        check_name(name)
    out = {}
    for name in ALL_EFFECTS:
        if name not in effects:
            continue
        effect = twin_effect(name)
        params = effect.defaults(kappa, C, depths_cm, bottom_cm)
        given = dict(effects[name] or {})
        refused = effect.refuse(given)
        if refused:
            raise ValueError(f"effect {name!r}: {refused}")
        unknown = set(given) - set(params)
        if unknown:
            raise ValueError(
                f"effect {name!r}: unknown parameter(s) {sorted(unknown)}; valid: {list(params)}"
            )
        params.update({k: float(v) for k, v in given.items()})
        effect.place(params, depths_cm, bottom_cm)
        bad = effect.bad(params)
        if bad:
            raise ValueError(f"effect {name!r}: {bad}")
        effect.derive(params)
        out[name] = params
    return out
