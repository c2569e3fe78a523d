"""What a sampler needs to continue a run exactly: :class:`RunState` (positions, adaptation state
and the ``numpy.random.Generator`` state; every float round-trips exactly). The storage step
stores it with each block."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def rng_from_state(state: dict) -> np.random.Generator:
    """A new ``Generator`` whose bit generator (same class as recorded) is in ``state``."""
    cls = getattr(np.random, str(state.get("bit_generator")), None)
    if not (isinstance(cls, type) and issubclass(cls, np.random.BitGenerator)):
        raise ValueError(f"unknown bit generator {state.get('bit_generator')!r}")
    bg = cls()
    bg.state = state
    return np.random.Generator(bg)


@dataclass
class RunState:
    """What a sampler needs to continue a run exactly.

    Attributes
    ----------
    position : (n_chains, n_params) current position of every chain.
    log_prob : (n_chains,) log-posterior at ``position``.
    blobs : (n_chains, n_blobs) blobs at ``position``.
    rng_state : ``rng.bit_generator.state`` of the sampler's Generator, or None.
    extra : free-form JSON-serialisable dict (e.g. step sizes, iteration counters).
    arrays : named float arrays (e.g. an adapted proposal covariance).
    """

    position: np.ndarray
    log_prob: np.ndarray
    blobs: np.ndarray
    rng_state: dict | None = None
    extra: dict = field(default_factory=dict)
    arrays: dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def capture(
        cls,
        position,
        log_prob,
        blobs,
        rng: np.random.Generator | None = None,
        extra: dict | None = None,
        arrays: dict | None = None,
    ) -> RunState:
        """Build a state, copying arrays and recording ``rng``'s bit-generator state."""
        position = np.array(position, dtype=float)
        blobs = np.zeros((len(position), 0)) if blobs is None else np.array(blobs, dtype=float)
        return cls(
            position,
            np.array(log_prob, dtype=float),
            blobs,
            None if rng is None else rng.bit_generator.state,
            dict(extra or {}),
            {k: np.array(v, dtype=float) for k, v in (arrays or {}).items()},
        )

    def make_rng(self) -> np.random.Generator:
        """A new Generator continuing exactly where the recorded one stopped."""
        if self.rng_state is None:
            raise ValueError("this run state has no recorded random-generator state")
        return rng_from_state(self.rng_state)
