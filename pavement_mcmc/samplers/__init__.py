"""Samplers by name: ``"emcee"`` (affine-invariant ensemble), ``"mh"`` (the paper's random-walk
Metropolis–Hastings), ``"fast"`` (MAP + Laplace-preconditioned moves + exact gamma Gibbs) and
``"hmc"`` (Hamiltonian trajectories with adjoint gradients + exact gamma Gibbs).

Every sampler steps many chains with one vectorised posterior call per step, returns
:class:`~pavement_mcmc.samplers.base.Block` arrays and resumes exactly from a stored
:class:`~pavement_mcmc.storage.RunState`; :func:`~pavement_mcmc.runs.loop.run_sampler`
drives any of them through one store.
"""

from __future__ import annotations

from ..data.plugins import Registry
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
_SAMPLERS: Registry[type[Sampler]] = Registry(Sampler, "sampler", SAMPLERS)


def register_sampler(cls: type[Sampler]) -> type[Sampler]:
    """Class decorator: make ``cls`` selectable by its ``name`` (``[sampler] kind = NAME``)."""
    return _SAMPLERS.register(cls)


def sampler_names() -> list[str]:
    return _SAMPLERS.names()


def sampler_class(kind) -> type[Sampler]:
    """A sampler class from a name, a ``"module:Class"`` path or the class itself.

    Raises ``ValueError`` listing the valid names for an unknown ``kind``.
    """
    return _SAMPLERS.get(kind)


def get_sampler(kind, posterior, n_chains: int | None = None, seed: int | None = None,
                options=None) -> Sampler:
    """A sampler instance by name, ``"module:Class"`` or class, with its typed ``options``
    (a mapping or the sampler's ``Options`` instance; unknown keys are refused)."""
    return sampler_class(kind)(posterior, n_chains=n_chains, seed=seed, options=options)


__all__ = ["MOVES", "SAMPLERS", "Block", "BlockGMRF", "EmceeSampler", "FastSampler",
           "HMCSampler", "LaplacePCN", "MHSampler", "MarginalRW", "Move", "RunState", "Sampler",
           "get_sampler", "register_sampler", "sampler_class", "sampler_names"]
