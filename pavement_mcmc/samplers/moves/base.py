"""The move interface (see :mod:`pavement_mcmc.samplers.moves`)."""

from __future__ import annotations

from typing import ClassVar

import numpy as np


class Move:
    """Base class of a ``fast`` sampler move. Subclasses are dataclasses of their options.

    Attributes
    ----------
    name : the move's name in configs.
    needs_gmrf : the move works only on the gamma-marginal target of a case with a free
        smoothness precision gamma.
    """

    name: ClassVar[str] = "move"
    needs_gmrf: ClassVar[bool] = False

    def needs_laplace(self) -> bool:
        """Whether :meth:`prepare` wants the sampler's Laplace approximation (``find_map``)."""
        return False

    def prepare(self, sampler, theta0=None, laplace=None) -> None:
        """Set the reference, the adaptation state and the chains' start (``sampler.theta``,
        ``.logp``, ``.blobs``; count solves in ``sampler.n_prep_evals``)."""
        raise NotImplementedError

    def step(self, sampler, adapt: bool) -> tuple:
        """Advance every chain one step; return ``(theta, logp, blobs, accepted, n_solved)``."""
        raise NotImplementedError

    def state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """(JSON dict, named float arrays) that :meth:`restore` continues from."""
        raise NotImplementedError

    def restore(self, sampler, extra: dict, arrays: dict[str, np.ndarray]) -> None:
        raise NotImplementedError
