"""Samplers by name: ``"emcee"`` (affine-invariant ensemble), ``"mh"`` (the paper's random-walk
Metropolis–Hastings), ``"fast"`` (MAP + Laplace-preconditioned moves + exact gamma Gibbs) and
``"hmc"`` (Hamiltonian trajectories with adjoint gradients + exact gamma Gibbs).

Every sampler steps many chains with one vectorised posterior call per step, returns
:class:`~pavement_mcmc.samplers.base.Block` arrays and resumes exactly from a stored
:class:`~pavement_mcmc.storage.RunState`; :func:`~pavement_mcmc.runs.loop.run_sampler`
drives any of them through one store.
"""

from __future__ import annotations

from .base import Block, Sampler
from .ensemble import EmceeSampler
from .fast import FastSampler
from .hmc import HMCSampler
from .mh import MHSampler

#: name -> sampler class
SAMPLERS: dict[str, type[Sampler]] = {
    "emcee": EmceeSampler,
    "mh": MHSampler,
    "fast": FastSampler,
    "hmc": HMCSampler,
}


def sampler_names() -> list[str]:
    return sorted(SAMPLERS)


def get_sampler(kind, posterior, n_chains: int | None = None, seed: int | None = None,
                **options) -> Sampler:
    """A sampler instance by name (or pass a :class:`Sampler` subclass).

    Raises ``ValueError`` listing the valid names for an unknown ``kind``.
    """
    if isinstance(kind, type) and issubclass(kind, Sampler):
        cls = kind
    elif kind in SAMPLERS:
        cls = SAMPLERS[kind]
    else:
        raise ValueError(f"unknown sampler {kind!r}; valid: {', '.join(sampler_names())}")
    return cls(posterior, n_chains=n_chains, seed=seed, **options)


__all__ = ["SAMPLERS", "Block", "EmceeSampler", "FastSampler", "MHSampler", "Sampler",
           "get_sampler", "sampler_names"]
