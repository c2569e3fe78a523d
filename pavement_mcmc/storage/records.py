"""The plain records of a run (:class:`RunState`, :class:`RunData`) and their JSON encoding."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np


def _encode(obj: Any) -> Any:
    """Make ``obj`` JSON-serialisable; ndarrays become ``{"__ndarray__": list, "dtype": str}``."""
    if isinstance(obj, dict):
        return {str(k): _encode(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_encode(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return {"__ndarray__": obj.tolist(), "dtype": obj.dtype.str}
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def _decode_hook(d: dict) -> Any:
    if "__ndarray__" in d:
        return np.array(d["__ndarray__"], dtype=d["dtype"])
    return d


def _dumps(obj: Any) -> str:
    return json.dumps(_encode(obj), sort_keys=True)


def _loads(s: str | bytes) -> Any:
    return json.loads(s, object_hook=_decode_hook)


def rng_from_state(state: dict) -> np.random.Generator:
    """A new ``Generator`` whose bit generator (same class as recorded) is in ``state``."""
    cls = getattr(np.random, str(state.get("bit_generator")), None)
    if not (isinstance(cls, type) and issubclass(cls, np.random.BitGenerator)):
        raise ValueError(f"unknown bit generator {state.get('bit_generator')!r}")
    bg = cls()
    bg.state = state
    return np.random.Generator(bg)


def config_diff(old: Any, new: Any, path: str = "") -> list[str]:
    """Key paths where two JSON-like values differ, as ``'a.b: old -> new'`` strings."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for k in sorted(set(old) | set(new), key=str):
            p = f"{path}.{k}" if path else str(k)
            if k not in new:
                out.append(f"{p}: removed (was {old[k]!r})")
            elif k not in old:
                out.append(f"{p}: added ({new[k]!r})")
            else:
                out.extend(config_diff(old[k], new[k], p))
        return out
    if isinstance(old, list) and isinstance(new, list) and len(old) == len(new):
        return [
            d
            for i, (a, b) in enumerate(zip(old, new, strict=True))
            for d in config_diff(a, b, f"{path}[{i}]")
        ]
    return [] if old == new else [f"{path or '<root>'}: {old!r} -> {new!r}"]


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


@dataclass
class RunData:
    """A stored run as plain numpy arrays (committed steps only)."""

    chain: np.ndarray  # (n_saved, n_chains, n_params)
    log_prob: np.ndarray  # (n_saved, n_chains)
    blobs: np.ndarray  # (n_saved, n_chains, n_blobs)
    accepted: np.ndarray  # (n_saved, n_chains) bool
    param_names: list[str]
    blob_names: list[str]
    meta: dict
    state: RunState | None

    @property
    def n_saved(self) -> int:
        return int(self.chain.shape[0])

    def get_chain(self, discard: int = 0, thin: int = 1, flat: bool = False) -> np.ndarray:
        """``chain[discard::thin]``, flattened to (n, n_params) over steps and chains if ``flat``."""
        c = self.chain[discard::thin]
        return c.reshape(-1, c.shape[2]) if flat else c
