"""emcee's affine-invariant ensemble sampler over the vectorised posterior.

The posterior is called once per half-ensemble move with ``vectorize=True``; it returns, per
walker, ``[logp, rmse_1, ..., rmse_S]`` so emcee keeps the RMSE per sensor as blobs. emcee is
stepped with ``store=False`` and every step is handed to our store; emcee's own legacy
``RandomState`` (seeded from the run's Generator) is saved in the resume state, so a resumed
run continues bit for bit. Default move: the stretch move (``a = 2``). No adaptation: the
burn-in is chosen afterwards from the log-posterior trace.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import emcee
import numpy as np

from .base import Block, Sampler, start_points

#: emcee moves by name, for case files (``[sampler.options] moves = "de"``)
EMCEE_MOVES = {"stretch": emcee.moves.StretchMove, "walk": emcee.moves.WalkMove,
               "de": emcee.moves.DEMove, "desnooker": emcee.moves.DESnookerMove,
               "kde": emcee.moves.KDEMove}


@dataclass(frozen=True)
class EmceeOptions:
    """Options of the ``emcee`` sampler.

    moves : emcee moves as emcee takes them (a move, or a list of ``(move, weight)``), or by
        name: ``"stretch"`` (default), ``"walk"``, ``"de"``, ``"desnooker"``, ``"kde"``, or a
        list of ``[name, weight]`` pairs.
    """

    moves: Any = field(default=None)

    def emcee_moves(self):
        def one(m):
            if isinstance(m, str):
                if m not in EMCEE_MOVES:
                    raise ValueError(f"[sampler.options] moves: unknown emcee move {m!r}; "
                                     f"valid: {', '.join(EMCEE_MOVES)}")
                return EMCEE_MOVES[m]()
            return m

        mv = self.moves
        if isinstance(mv, list | tuple):
            return [(one(m[0]), float(m[1])) if isinstance(m, list | tuple) else one(m) for m in mv]
        return None if mv is None else one(mv)


class EmceeSampler(Sampler):
    """emcee ``EnsembleSampler`` (stretch move by default); the Laplace approximation, when
    given to :meth:`prepare`, sets the start points."""

    name = "emcee"
    Options = EmceeOptions

    @staticmethod
    def default_chains(ndim: int) -> int:
        return max(32, 2 * ndim + 2 + (2 * ndim + 2) % 2)

    def _make(self) -> None:
        self._evals = 0

        def fn(theta):
            self._evals += theta.shape[0]
            lp, bl = self.evaluate(theta)
            return np.column_stack([lp, bl])

        self._emcee = emcee.EnsembleSampler(self.n_chains, self.ndim, fn, vectorize=True,
                                            moves=self.options.emcee_moves())

    def prepare(self, theta0=None, laplace=None) -> None:
        self.theta, _ = start_points(self, theta0, laplace)
        self.logp, self.blobs = self.evaluate(self.theta)
        self.n_prep_evals += self.n_chains
        self._make()
        self._emcee.random_state = np.random.RandomState(
            int(self.rng.integers(2**32))).get_state()

    def step(self, n_steps: int, adapt: bool = False) -> Block:
        # emcee squeezes a single blob per walker to shape (n_walkers,)
        blobs = self.blobs[:, 0] if self.blobs.shape[1] == 1 else self.blobs
        state = emcee.State(self.theta.copy(), log_prob=self.logp.copy(), blobs=blobs.copy(),
                            random_state=self._emcee.random_state)
        rows = []
        self._evals = 0
        prev = self.theta.copy()  # emcee updates its State in place
        for st in self._emcee.sample(state, iterations=n_steps, store=False,
                                     skip_initial_state_check=True):
            acc = np.any(st.coords != prev, axis=1)
            prev = st.coords.copy()
            rows.append((st.coords.copy(), st.log_prob.copy(),
                         np.array(st.blobs, float).reshape(self.n_chains, -1), acc, 0))
        self.theta, self.logp, self.blobs = prev.copy(), rows[-1][1].copy(), rows[-1][2].copy()
        block = Block.stack(rows)
        block.n_evals = self._evals
        return block

    def _extra_state(self):
        name, keys, pos, has_gauss, cached = self._emcee.random_state
        return {"rs": [name, [int(k) for k in keys], int(pos), int(has_gauss), float(cached)]}, {}

    def _load_extra_state(self, extra, arrays):
        self._make()
        name, keys, pos, has_gauss, cached = extra["rs"]
        self._emcee.random_state = (name, np.array(keys, dtype=np.uint32), pos, has_gauss, cached)
