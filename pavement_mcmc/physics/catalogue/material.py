"""Material laws: a conductivity that varies with temperature."""

from __future__ import annotations

import numpy as np

from ...parameters import Parameter
from ...parameters.priors import Normal
from ..base import Extension
from ..registry import register_extension


@register_extension
class ConductivityTemperature(Extension):
    """kappa(T) = kappa (1 + kappa_beta (T - 20 degC))."""

    name = "conductivity_temperature"
    hint = "misfit that grows with temperature: conductivity depends on T"
    signals = ("corr:T_sensor", "amplitude")
    adjoint = False  # kappa(T) makes each step of the solve depend on the temperatures

    def parameters(self, meas):
        return [Parameter("kappa_beta", 0.0, -0.03, 0.03, prior=Normal(0.0, 0.005), unit="K-1",
                          description="relative temperature coefficient of kappa")]

    def null_values(self, meas):
        return {"kappa_beta": 0.0}

    def material(self, coeffs, p, model):
        coeffs.beta = np.asarray(p["kappa_beta"], float)
        coeffs.T_ref = 20.0
