"""The plain records of a run (:class:`RunState`, :class:`RunData`) and their JSON encoding."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..samplers.state import RunState


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
