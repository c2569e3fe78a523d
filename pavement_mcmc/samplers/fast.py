r"""The ``fast`` sampler: many chains driven by one move, with the smoothness precision drawn exactly.

The work is done by a move (:mod:`.moves`): by default the Laplace-preconditioned Crank–Nicolson
move (:class:`~.moves.LaplacePCN`) and, for a case with a free smoothness precision gamma
(Case C), the random walk on the gamma-marginal target (:class:`~.moves.MarginalRW`); the joint
(gamma, h) block move (:class:`~.moves.BlockGMRF`) is the third shipped move. Pick one by name
(``[sampler.options] move = "block"``), with options (``move = {kind = "block", block_prob =
0.3}``), or pass an instance (``options={"move": BlockGMRF(block_prob=0.3)}``); a move of your
own subclasses :class:`~.moves.Move`.

Written with a :class:`numpy.random.Generator` rather than as emcee moves, so the whole state
(positions, the move's adaptation state, the Generator) is one stored
:class:`~pavement_mcmc.samplers.state.RunState`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..posterior.marginal import gmrf_of
from .base import Block, Sampler
from .moves import MOVES, Move
from .options import options_from


@dataclass(frozen=True)
class FastOptions:
    """Options of the ``fast`` sampler.

    move : ``"auto"`` (``"rw"`` for a case with a free smoothness precision, else ``"pcn"``),
        a move name (``"pcn"``, ``"rw"``, ``"block"``), a table ``{kind = NAME, option =
        value, ...}`` or a :class:`~pavement_mcmc.samplers.moves.Move` instance.
    """

    move: Any = "auto"


class FastSampler(Sampler):
    """Many chains driven by one :class:`~pavement_mcmc.samplers.moves.Move` (see the module
    docstring)."""

    name = "fast"
    adaptive = True
    Options = FastOptions

    def __init__(self, posterior, n_chains=None, seed=None, options=None):
        super().__init__(posterior, n_chains, seed, options)
        self.move = self._make_move(self.options.move)

    @staticmethod
    def default_chains(ndim: int) -> int:
        return 64

    def adapt_length(self) -> int:
        return max(150, 10 * self.ndim)

    def _make_move(self, spec) -> Move:
        gmrf = gmrf_of(self.posterior.space) is not None
        if isinstance(spec, Move):
            move = spec
        else:
            kind, opts = (spec.get("kind", "auto"), {k: v for k, v in spec.items() if k != "kind"}) \
                if isinstance(spec, Mapping) else (spec, {})
            if kind == "auto":
                kind = "rw" if gmrf else "pcn"
            if kind not in MOVES:
                raise ValueError(f"[sampler.options] of sampler 'fast': unknown move {kind!r}; "
                                 f"valid: auto, {', '.join(MOVES)}")
            move = options_from(MOVES[kind], opts, f"[sampler.options] move {kind!r}")
        if move.needs_gmrf and not gmrf:
            raise ValueError(f"move {move.name!r} needs a case with a free smoothness precision "
                             "gamma (h per interval with smooth = true); use move = 'pcn'")
        return move

    def needs_laplace(self) -> bool:
        return self.move.needs_laplace()

    def prepare(self, theta0=None, laplace=None) -> None:
        self.move.prepare(self, theta0, laplace)

    def step(self, n_steps: int, adapt: bool = False) -> Block:
        return Block.stack([self.move.step(self, adapt) for _ in range(n_steps)])

    def _extra_state(self):
        return self.move.state()

    def _load_extra_state(self, extra, arrays):
        self.move.restore(self, extra, arrays)
