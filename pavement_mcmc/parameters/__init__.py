"""Step 2, the unknowns: parameters (value, bounds, ``vary``, prior) and prior distributions.

- :mod:`.space`: :class:`Parameter` and the ordered :class:`ParameterSpace` a sampler sees as a
  matrix of free values;
- :mod:`.priors`: vectorised univariate priors and the first-order GMRF smoothness prior on h.

The physics (step 3) declares its parameters with these; the posterior (step 4) evaluates them.
"""

from .priors import (
    Flat,
    GMRFSmoothness,
    Normal,
    Prior,
    Rayleigh,
    TruncatedNormal,
    Uniform,
    prior_from_config,
)
from .space import Parameter, ParameterSpace, PriorResiduals, parameter_values

__all__ = [
    "Flat",
    "GMRFSmoothness",
    "Normal",
    "Parameter",
    "ParameterSpace",
    "PriorResiduals",
    "Prior",
    "Rayleigh",
    "TruncatedNormal",
    "Uniform",
    "parameter_values",
    "prior_from_config",
]
