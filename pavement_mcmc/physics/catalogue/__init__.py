"""The shipped catalogue of physical effects a base model may be missing.

Each class is one effect: explicit parameter names with bounds and priors, and one hook.
Parameterisations match :mod:`pavement_mcmc.synthetic`, which can hide each of them in twin data.

Two optional attributes serve the criticism (:mod:`pavement_mcmc.criticism`), any extension may
define them: ``signals`` names the residual patterns that point at the effect (keys of
:func:`pavement_mcmc.criticism.residuals.plain_signals`, e.g. ``"corr:wind"``), and
``start_values(meas, base)`` returns a list of starting points (dicts by parameter name) for a
quick refit from the fitted values ``base`` of the model without the effect.
"""

from . import canopy, energy, layers, material, penman, sensors, shading, soil_water, surface  # noqa: F401  (register the shipped effects)
