"""Step 4, the posterior: the model's predictions against the data, and its priors.

- :mod:`.logpost`: :class:`LogPosterior`, the vectorised log-posterior, its whitened residuals
  (the one misfit every other module uses) and its gradient;
- :mod:`.observations`: the :class:`Observation` streams it loops over (temperatures, plates);
  :mod:`.surface_ir`: the infrared surface temperature, a stream with an offset nuisance;
- :mod:`.input_noise`: noisy boundary, initial and forcing inputs integrated out of the likelihood;
- :mod:`.problem`: :func:`build_problem`, a case config -> model, parameter space, posterior;
- :mod:`.map`: the MAP by least squares and its Laplace approximation;
- :mod:`.marginal`: the smoothness precision integrated out, and the marginal MAP;
- :mod:`.starts`: a MAP from several starts (an extended model's new parameters).
"""

from .input_noise import InputNoise, input_jacobian
from .logpost import LogPosterior
from .map import Laplace, find_map
from .marginal import MarginalGMRF, MarginalMAP, find_marginal_map, gmrf_of
from .observations import Observation
from .problem import Problem, attach_input_noise, build_problem, input_sigmas

__all__ = [
    "InputNoise",
    "Laplace",
    "LogPosterior",
    "MarginalGMRF",
    "MarginalMAP",
    "Observation",
    "Problem",
    "attach_input_noise",
    "build_problem",
    "find_map",
    "find_marginal_map",
    "gmrf_of",
    "input_jacobian",
    "input_sigmas",
]
