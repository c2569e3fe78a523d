"""Independent twin-data generator (never the inversion's solver: no inverse crime).

A deep ground column on a fine finite-volume grid (0.25 mm cells around the sensors of the
paper's 0-5 cm geometry, 1 mm for deeper field geometries), driven by a synthetic weather
generator (summer over asphalt, or spring over grass) through a full surface energy balance,
with a 48 h spin-up; the bottom temperature is itself an output. Hidden effects (two-layer
ground, sensor depth errors and biases, wind-driven convection, evaporation after rain,
temperature-dependent conductivity, a radiation factor; a thatch layer and
evapotranspiration; and the off-catalogue sensor lag, shading and buried heat source) can be
switched on with realistic default strengths, see :mod:`pavement_mcmc.synthetic.effects`.
Heat-flux plates (``flux_depths_cm``) add ``G_<d>cm`` columns; a top-soil water content
(``swc_fc``) adds an ``SWC`` column and a latent heat it limits (:mod:`.soil_water`). Named,
reproducible twins with the inversion settings to use on them are in
:mod:`pavement_mcmc.synthetic.corpus`.

>>> columns, truth = simulate(SyntheticSpec(seed=1, effects={"two_layer": {}}))
>>> meas = to_measurements(columns, sigma=truth.sigma)
"""

from .effects import (
    ALL_EFFECTS,
    DEFAULT_RAIN,
    EFFECTS,
    NEW_CATALOGUE_EFFECTS,
    OFF_CATALOGUE_EFFECTS,
    TwinEffect,
    default_effect,
    register_twin_effect,
    twin_effect,
)
from .io import to_measurements, truth_record, write_case
from .simulate import (
    PAPER_H_KNOTS,
    SyntheticSpec,
    Truth,
    flux_columns,
    resolved_grid,
    simulate,
    temperature_columns,
)

__all__ = [
    "ALL_EFFECTS",
    "DEFAULT_RAIN",
    "EFFECTS",
    "NEW_CATALOGUE_EFFECTS",
    "OFF_CATALOGUE_EFFECTS",
    "PAPER_H_KNOTS",
    "SyntheticSpec",
    "Truth",
    "TwinEffect",
    "default_effect",
    "flux_columns",
    "register_twin_effect",
    "resolved_grid",
    "simulate",
    "temperature_columns",
    "to_measurements",
    "truth_record",
    "twin_effect",
    "write_case",
]
