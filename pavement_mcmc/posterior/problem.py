"""Assemble a case config into a ready-to-sample problem: model, parameter space, posterior."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..parameters import ParameterSpace
from ..physics import HBasis, Model
from ..solver import Grid
from .logpost import LogPosterior


@dataclass
class Problem:
    """Everything a sampler needs, built once from a config."""

    cfg: object  # pavement_mcmc.data.CaseConfig
    model: Model
    space: ParameterSpace
    posterior: LogPosterior

    @property
    def meas(self):
        return self.model.meas


def build_problem(cfg, extensions=None, h_spec: dict | None = None) -> Problem:
    """Build the :class:`Problem` of a loaded case config.

    Parameters
    ----------
    cfg : a :class:`~pavement_mcmc.data.CaseConfig`.
    extensions : override the config's extension list (names, classes or instances).
    h_spec : override the config's h(t) discretisation (e.g. ``{"kind": "uniform", "n": 12}``).
    """
    meas = cfg.measurements
    model_cfg = cfg.model
    grid_cfg = cfg.grid
    grid_kw = {k: grid_cfg[k] for k in ("dx", "dt") if grid_cfg.get(k) is not None}
    grid = Grid.build(meas, **grid_kw)
    basis = HBasis.from_config(meas.t, h_spec or model_cfg.get("h", {"kind": "per_interval"}))
    exts = model_cfg.get("extensions", []) if extensions is None else extensions
    gamma_prior = cfg.parameters.get("gamma", {}).get("prior", {})
    gamma0 = float(gamma_prior.get("scale", 2.22))
    model = Model(meas, grid, basis, exts, scheme=grid_cfg.get("scheme", "cn"), gamma0=gamma0)
    space = model.parameter_space().configure(_known(cfg.parameters, model))
    posterior = LogPosterior(model, space)
    sigmas = input_sigmas(cfg.data, meas)
    if any(np.any(v > 0) for v in sigmas.values()):
        attach_input_noise(posterior, sigmas)
    return Problem(cfg, model, space, posterior)


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
    return out


def attach_input_noise(posterior: LogPosterior, sigmas: dict[str, float] | float,
                       theta_ref=None) -> None:
    """Integrate the noise of the model's inputs out of ``posterior``'s likelihood
    (:mod:`pavement_mcmc.posterior.input_noise`). ``sigmas``: sd per input kind, a number or one per
    column of that kind (a single number: the bottom and initial temperatures). Linearised at
    ``theta_ref`` (default: the MAP with exact inputs, deterministic, so a resumed run gets the
    same likelihood)."""
    from .input_noise import InputNoise, input_jacobian
    from .map import find_map

    if not isinstance(sigmas, dict):
        sigmas = {"bottom": float(sigmas), "initial": float(sigmas)}
    sigmas = {k: v for k, v in sigmas.items() if np.any(np.asarray(v) > 0)}
    posterior.input_noise = None
    if not sigmas:
        return
    if theta_ref is None:
        theta_ref = find_map(posterior).theta
    p = posterior.space.expand(np.atleast_2d(np.asarray(theta_ref, float)))
    U = input_jacobian(posterior.model, p, kinds=tuple(sigmas))
    posterior.input_noise = InputNoise.from_jacobian(U, posterior.sigma, sigmas)


def _known(section: dict, model: Model) -> dict:
    """Drop config entries for h pieces / gamma when an extension replaces h (e.g. wind)."""
    if not model.replaces_h:
        return section
    drop = {"h", "gamma", *model.h_basis.names}
    return {k: v for k, v in section.items() if k not in drop}
