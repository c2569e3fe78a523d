"""Moves of the ``fast`` sampler: small proposal objects a user can pass, configure or write.

A move is a dataclass whose fields are its options (``MarginalRW(first_window=200)``); the
sampler calls :meth:`Move.prepare` once, then :meth:`Move.step` once per step, and stores what
:meth:`Move.state` returns with the chain so :meth:`Move.restore` continues a run exactly. A
move reads and updates the chains through the sampler it is given (``sampler.theta``,
``sampler.logp``, ``sampler.blobs``, ``sampler.rng``, ``sampler.evaluate``); its own adaptation
state lives on the move.

- :class:`LaplacePCN` (``"pcn"``): Laplace-preconditioned Crank-Nicolson (any case);
- :class:`MarginalRW` (``"rw"``): random walk on the gamma-marginal target (GMRF case);
- :class:`BlockGMRF` (``"block"``): joint (gamma, h) block move mixed with pCN (GMRF case).
"""

from .base import Move
from .block import BlockGMRF
from .marginal_rw import MarginalRW
from .pcn import LaplacePCN

#: name -> move class (``[sampler.options] move = "block"``)
MOVES: dict[str, type[Move]] = {"pcn": LaplacePCN, "rw": MarginalRW, "block": BlockGMRF}

__all__ = ["MOVES", "BlockGMRF", "LaplacePCN", "MarginalRW", "Move"]
