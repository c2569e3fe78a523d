"""Assemble a case config into a ready-to-sample problem: model, parameter space, posterior."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..data import ConfigError, UserError
from ..parameters import ParameterSpace
from ..physics import HBasis, Model
from ..physics.materials import material
from ..solver import Grid
from .grid_choice import build_grid
from .input_noise import InputNoise, input_jacobian
from .logpost import LogPosterior, default_flux_sd, default_streams
from .map import find_map
from .observations import with_parameters
from .surface_ir import SurfaceIR


@dataclass
class Problem:
    """Everything a sampler needs, built once from a config.

    ``input_ref`` is the point (free parameter values by name) at which the inputs' noise was
    linearised (``[data] input_sigma`` and friends), None when the inputs are exact; a run
    stores it so that reading the run back rebuilds the same likelihood without a new MAP.
    """

    cfg: object  # pavement_mcmc.data.CaseConfig
    model: Model
    space: ParameterSpace
    posterior: LogPosterior
    input_ref: dict | None = None
    #: what ``[grid] kind = "auto"`` chose (:func:`.grid_choice.build_grid`); {} if set by hand
    grid_chosen: dict | None = None

    @property
    def meas(self):
        return self.model.meas


def build_problem(cfg, extensions=None, h_spec: dict | None = None, *,
                  input_noise=None, grid: Grid | None = None) -> Problem:
    """Build the :class:`Problem` of a loaded case config.

    Parameters
    ----------
    cfg : a :class:`~pavement_mcmc.data.CaseConfig`.
    extensions : override the config's extension list (names, classes or instances).
    h_spec : override the config's h(t) discretisation (e.g. ``{"kind": "uniform", "n": 12}``).
    input_noise : only used when the case integrates its inputs' noise out (``[data]
        input_sigma`` ...): None (default) linearises at the MAP with exact inputs (a new fit;
        costs a least-squares fit); a dict of parameter values by name linearises there (a
        stored run's ``input_ref``: no optimisation); an
        :class:`~pavement_mcmc.posterior.input_noise.InputNoise` is used as is (a candidate
        model scored against a base model shares the base's data covariance).
    grid : use this solver grid instead of choosing one from ``[grid]`` (a candidate model
        scored against a base model shares the base's grid: the same discretisation, and the
        choice is not repeated).
    """
    try:
        model, space, posterior, grid_chosen = _assemble(cfg, extensions, h_spec, grid)
    except UserError:
        raise
    except ValueError as err:  # a name or value of the case's config: say which file
        raise ConfigError(f"{getattr(cfg, 'path', 'the case')}: {err}") from None
    sigmas = input_sigmas(cfg.data, model.meas)
    ref = None
    if any(np.any(v > 0) for v in sigmas.values()):
        if isinstance(input_noise, InputNoise):
            posterior.input_noise = input_noise
        else:
            theta = None if input_noise is None else _theta_at(space, input_noise)
            ref = attach_input_noise(posterior, sigmas, theta)
    return Problem(cfg, model, space, posterior, ref, grid_chosen)


def case_measurements(cfg):
    """The measurements a case's model sees: its record, with the shallowest sensor as the
    boundary under ``[model] top = "measured"`` (no model built)."""
    if cfg.model.get("top", "surface") == "measured":
        return cfg.measurements.with_measured_top()
    return cfg.measurements


def _assemble(cfg, extensions, h_spec, given: Grid | None = None):
    """Model, parameter space, posterior and the grid's choice of a case (a ValueError for a bad
    config value)."""
    model_cfg = cfg.model
    meas = case_measurements(cfg)
    grid_cfg = cfg.grid
    basis = HBasis.from_config(meas.t, h_spec or model_cfg.get("h", {"kind": "per_interval"}))
    exts = model_cfg.get("extensions", []) if extensions is None else extensions
    gamma_prior = cfg.parameters.get("gamma", {}).get("prior", {})
    gamma0 = float(gamma_prior.get("scale", 2.22))
    data = cfg.data
    # the infrared surface temperature, an offset its nuisance: built first, since a case may
    # set its parameters (``[parameters.ir_offset]``) and the grid's choice configures them
    if data.get("ir_storage_free") and ("ir_sigma" not in data or not any(
            getattr(e, "name", e) == "canopy" for e in exts)):
        raise ValueError("[data] ir_storage_free needs ir_sigma (the IR observed) and the canopy "
                         "extension (whose skin node the IR leads)")
    extra = ([SurfaceIR(meas, data["ir_sigma"], storage_free=data.get("ir_storage_free", False))]
             if "ir_sigma" in data else [])

    def model_on(grid: Grid) -> Model:
        return Model(meas, grid, basis, exts, scheme=grid_cfg.get("scheme", "cn"), gamma0=gamma0,
                     plates=data.get("plates", True))

    def predict(grid: Grid) -> np.ndarray:  # at the parameters' values, for the grid's choice
        m = model_on(grid)
        space = with_parameters(m.parameter_space(), extra).configure(_known(cfg.parameters, m))
        return m.predict(space.expand(space.initial()[None]))[0]

    if given is None:
        grid, chosen = build_grid(meas, grid_cfg, predict)
    else:
        grid, chosen = given, {}
    model = model_on(grid)
    flux_sd = None
    if model.plates:
        flux_sd = default_flux_sd(meas.G_obs[1:], data.get("plate_sigma", 2.0),
                                  data.get("plate_rel_sigma", 0.1))
    streams = default_streams(model, flux_sd) + extra
    space = with_parameters(model.parameter_space(), streams)
    space = space.configure(_known(cfg.parameters, model))
    posterior = LogPosterior(model, space, streams=streams)
    material(model_cfg.get("material"))  # a ValueError listing the materials if unknown
    return model, space, posterior, chosen


def _theta_at(space: ParameterSpace, values: dict) -> np.ndarray:
    """Free-parameter vector from values by name (missing names: the parameter's value)."""
    return np.array([float(values.get(n, space[n].value)) for n in space.free])


#: [data] keys of the input noise sds -> the input kinds they cover
INPUT_SIGMA_KEYS = {"input_sigma": ("bottom", "initial"), "T_air_sigma": ("T_air",),
                    "q_net_sigma": ("q_net",)}


def input_sigmas(data: dict, meas=None) -> dict:
    """Noise sd per input kind from a [data] section (0 where not given). With ``meas`` and
    ``q_net_rel_sigma`` (a fraction of the reading, as radiometers are specified), the q_net sd
    is per reading: ``sqrt(q_net_sigma^2 + (q_net_rel_sigma q_net)^2)``."""
    out = {kind: float(data.get(key, 0.0) or 0.0)
           for key, kinds in INPUT_SIGMA_KEYS.items() for kind in kinds}
    rel = float(data.get("q_net_rel_sigma", 0.0) or 0.0)
    if rel > 0 and meas is not None:
        out["q_net"] = np.sqrt(out["q_net"] ** 2 + (rel * np.asarray(meas.q_net, float)) ** 2)
    if meas is not None and meas.T_top is not None:  # a measured top: its sensor's noise, no
        out["top"] = out["bottom"]  # surface balance (air temperature, net radiation) at all
        out["T_air"] = out["q_net"] = 0.0
    return out


def attach_input_noise(posterior: LogPosterior, sigmas: dict[str, float] | float,
                       theta_ref=None) -> dict[str, float] | None:
    """Integrate the noise of the model's inputs out of ``posterior``'s likelihood
    (:mod:`pavement_mcmc.posterior.input_noise`). ``sigmas``: sd per input kind, a number or one per
    column of that kind (a single number: the bottom and initial temperatures). Linearised at
    ``theta_ref`` (default: the MAP with exact inputs, deterministic, so a resumed run gets the
    same likelihood). Returns the linearisation point by name (None if no input is noisy)."""

    if not isinstance(sigmas, dict):
        sigmas = {"bottom": float(sigmas), "initial": float(sigmas)}
    sigmas = {k: v for k, v in sigmas.items() if np.any(np.asarray(v) > 0)}
    posterior.input_noise = None
    if not sigmas:
        return None
    if theta_ref is None:
        theta_ref = find_map(posterior).theta
    theta_ref = np.asarray(theta_ref, float)
    p = posterior.space.expand(np.atleast_2d(theta_ref))
    U = input_jacobian(posterior.model, p, kinds=tuple(sigmas))
    posterior.input_noise = InputNoise.from_jacobian(U, posterior.sigma, sigmas)
    return {n: float(v) for n, v in zip(posterior.space.free, theta_ref, strict=True)}


def _known(section: dict, model: Model) -> dict:
    """Drop config entries for h pieces / gamma when an extension replaces h (e.g. wind)."""
    if not model.replaces_h:
        return section
    drop = {"h", "gamma", *model.h_basis.names}
    return {k: v for k, v in section.items() if k not in drop}
