"""Independent twin-data generator (never the inversion's solver: no inverse crime).

A deep (30 cm) ground column on a fine finite-volume grid (0.25 mm cells around the sensors),
driven by a synthetic summer weather generator through a full surface energy balance, with a
48 h spin-up; the 5 cm "bottom" temperature is itself an output. Hidden effects (two-layer
ground, sensor depth errors and biases, wind-driven convection, evaporation after rain,
temperature-dependent conductivity, a radiation factor) can be switched on with realistic
default strengths, see :mod:`pavement_mcmc.synthetic.effects`.

>>> columns, truth = simulate(SyntheticSpec(seed=1, effects={"two_layer": {}}))
>>> meas = to_measurements(columns, sigma=truth.sigma)
"""

from .effects import DEFAULT_RAIN, EFFECTS, default_effect
from .io import to_measurements, truth_record, write_case
from .simulate import PAPER_H_KNOTS, SyntheticSpec, Truth, simulate, temperature_columns

__all__ = [
    "DEFAULT_RAIN",
    "EFFECTS",
    "PAPER_H_KNOTS",
    "SyntheticSpec",
    "Truth",
    "default_effect",
    "simulate",
    "temperature_columns",
    "to_measurements",
    "truth_record",
    "write_case",
]
