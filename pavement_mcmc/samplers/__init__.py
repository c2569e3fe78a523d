"""Samplers by name: ``"emcee"`` (affine-invariant ensemble), ``"mh"`` (the paper's random-walk
Metropolis–Hastings), ``"fast"`` (MAP + Laplace-preconditioned moves + exact gamma Gibbs) and
``"hmc"`` (Hamiltonian trajectories with adjoint gradients + exact gamma Gibbs).

Every sampler steps many chains with one vectorised posterior call per step, returns
:class:`~pavement_mcmc.samplers.base.Block` arrays and resumes exactly from a stored
:class:`~pavement_mcmc.storage.RunState`; :func:`~pavement_mcmc.runs.loop.run_sampler`
drives any of them through one store.
"""

from __future__ import annotations

import importlib

from .base import Block, Sampler
from .ensemble import EmceeSampler
from .fast import FastSampler
from .hmc import HMCSampler
from .mh import MHSampler
from .moves import MOVES, BlockGMRF, LaplacePCN, MarginalRW, Move
from .state import RunState

#: name -> sampler class
SAMPLERS: dict[str, type[Sampler]] = {
    "emcee": EmceeSampler,
    "mh": MHSampler,
    "fast": FastSampler,
    "hmc": HMCSampler,
}


def register_sampler(cls: type[Sampler]) -> type[Sampler]:
    """Class decorator: make ``cls`` selectable by its ``name`` (``[sampler] kind = NAME``)."""
    if not (isinstance(cls, type) and issubclass(cls, Sampler)):
        raise TypeError(f"{cls!r} is not a Sampler subclass")
    if cls.name in SAMPLERS and SAMPLERS[cls.name] is not cls:
        raise ValueError(f"a sampler named {cls.name!r} is already registered")
    SAMPLERS[cls.name] = cls
    return cls


def sampler_names() -> list[str]:
    return sorted(SAMPLERS)


def sampler_class(kind) -> type[Sampler]:
    """A sampler class from a name, a ``"module:Class"`` path or the class itself.

    Raises ``ValueError`` listing the valid names for an unknown ``kind``.
    """
    if isinstance(kind, type) and issubclass(kind, Sampler):
        return kind
    if isinstance(kind, str) and ":" in kind:
        mod, _, attr = kind.partition(":")
        try:
            cls = getattr(importlib.import_module(mod), attr)
        except (ImportError, AttributeError) as err:
            raise ValueError(f"cannot import sampler {kind!r}: {err}") from None
        if not (isinstance(cls, type) and issubclass(cls, Sampler)):
            raise ValueError(f"{kind!r} is not a pavement_mcmc.samplers.Sampler subclass")
        return cls
    if kind in SAMPLERS:
        return SAMPLERS[kind]
    raise ValueError(f"unknown sampler {kind!r}; valid: {', '.join(sampler_names())} "
                     "(or 'module:Class' for your own)")


def get_sampler(kind, posterior, n_chains: int | None = None, seed: int | None = None,
                options=None) -> Sampler:
    """A sampler instance by name, ``"module:Class"`` or class, with its typed ``options``
    (a mapping or the sampler's ``Options`` instance; unknown keys are refused)."""
    return sampler_class(kind)(posterior, n_chains=n_chains, seed=seed, options=options)


__all__ = ["MOVES", "SAMPLERS", "Block", "BlockGMRF", "EmceeSampler", "FastSampler",
           "HMCSampler", "LaplacePCN", "MHSampler", "MarginalRW", "Move", "RunState", "Sampler",
           "get_sampler", "register_sampler", "sampler_class", "sampler_names"]
