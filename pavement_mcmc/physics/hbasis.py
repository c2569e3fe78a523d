"""Discretisations of the surface heat transfer coefficient h(t).

h(t) = sum_k h_k eta_k(t): each observation interval [t_i, t_i+1] receives the time-weighted
average of the pieces overlapping it, so ``h_interval = H @ W.T`` with ``W`` (n_intervals,
n_pieces) of overlap fractions (rows sum to 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..parameters import Parameter
from ..parameters.priors import TruncatedNormal
from ..parameters.space import columns


@dataclass(frozen=True)
class HBasis:
    """Piecewise-constant h(t) on given edges.

    Attributes
    ----------
    names : parameter names ``h_1 .. h_K``.
    edges : (K+1,) piece edges, s since the window start.
    W : (n_intervals, K) overlap fractions of each observation interval with each piece.
    smooth : True if the pieces carry the first-order GMRF smoothness prior (Case C).
    """

    names: tuple[str, ...]
    edges: np.ndarray
    W: np.ndarray
    smooth: bool = False

    @classmethod
    def pieces(cls, t_obs: np.ndarray, edges_hours, smooth: bool = False) -> HBasis:
        """Pieces between ``edges_hours`` (hours from the window start; must cover the window)."""
        e = np.asarray(edges_hours, float) * 3600.0
        if e.ndim != 1 or e.size < 2 or np.any(np.diff(e) <= 0):
            raise ValueError(f"h edges must be increasing with >= 2 values, got {edges_hours}")
        if e[0] > t_obs[0] + 1e-6 or e[-1] < t_obs[-1] - 1e-6:
            raise ValueError(
                f"h edges {list(edges_hours)} h do not cover the data window "
                f"[0, {t_obs[-1] / 3600:g}] h"
            )
        a, b = t_obs[:-1, None], t_obs[1:, None]
        overlap = np.clip(np.minimum(b, e[None, 1:]) - np.maximum(a, e[None, :-1]), 0, None)
        W = overlap / (b - a)
        empty = np.flatnonzero(W.sum(axis=0) == 0)
        if empty.size:
            k = int(empty[0])
            raise ValueError(f"h piece h_{k + 1} ({e[k] / 3600:g}-{e[k + 1] / 3600:g} h) holds no "
                             f"observation interval of the data window [0, {t_obs[-1] / 3600:g}] "
                             "h: nothing could estimate it; give edges within the window")
        names = tuple(f"h_{k + 1}" for k in range(e.size - 1))
        return cls(names, e, W, smooth)

    @classmethod
    def per_interval(cls, t_obs: np.ndarray, smooth: bool = True) -> HBasis:
        """One value per observation interval (the paper's Case C, N_t = n_obs - 1)."""
        return cls.pieces(t_obs, np.asarray(t_obs) / 3600.0, smooth=smooth)

    @classmethod
    def from_config(cls, t_obs: np.ndarray, spec: dict) -> HBasis:
        """``{kind = "pieces", edges_hours = [...]}``, ``{kind = "per_interval"}`` or
        ``{kind = "uniform", n = 12}`` (equal pieces); ``smooth`` optional."""
        kind = spec.get("kind", "pieces")
        if kind == "pieces":
            return cls.pieces(t_obs, spec["edges_hours"], bool(spec.get("smooth", False)))
        if kind == "per_interval":
            return cls.per_interval(t_obs, bool(spec.get("smooth", True)))
        if kind == "uniform":
            n = int(spec["n"])
            return cls.pieces(
                t_obs, np.linspace(0, t_obs[-1] / 3600, n + 1), bool(spec.get("smooth", False))
            )
        raise ValueError(f"unknown h kind {kind!r}; valid: pieces, per_interval, uniform")

    def parameters(self) -> list[Parameter]:
        prior = TruncatedNormal(10.0, 5.0)
        return [
            Parameter(n, 10.0, 0.0, 500.0, prior=prior, unit="W m-2 K-1",
                      description=f"surface heat transfer coefficient, piece {i + 1}", group="h")
            for i, n in enumerate(self.names)
        ]

    @cached_property
    def identity(self) -> bool:
        """One piece per observation interval (``W`` the identity: no product needed)."""
        return self.W.shape[0] == self.W.shape[1] and np.array_equal(self.W, np.eye(len(self.W)))

    def evaluate(self, p: dict[str, np.ndarray]) -> np.ndarray:
        """h on each observation interval, shape (n_sets, n_intervals)."""
        H = columns(p, self.names)
        return np.array(H) if self.identity else H @ self.W.T  # a fresh array: hooks may edit it

    def grad(self, g_h: np.ndarray) -> np.ndarray:
        """Adjoint of :meth:`evaluate`: d loss / d h per interval -> per piece (n_sets, K)."""
        return g_h if self.identity else g_h @ self.W


#: the name under which a finer h(t) is a candidate of the criticism and a ``fit --add`` value
FINER_H = "finer_h"


def finer_spec(model) -> dict | None:
    """The ``[model] h`` setting of an h(t) finer than ``model``'s: every piece longer than 2 h
    cut into pieces of at most 2 h, shorter ones halved. None if h is already one value per
    interval or given by an extension."""
    if model.replaces_h:
        return None
    b = model.h_basis
    if len(b.names) >= model.meas.n_obs - 1:
        return None
    e = b.edges / 3600.0
    new = []
    for a, c in zip(e[:-1], e[1:], strict=True):
        k = max(2, math.ceil((c - a) / 2.0 - 1e-9))
        new.extend(np.linspace(a, c, k + 1)[:-1].tolist())
    new.append(float(e[-1]))
    return {"kind": "pieces", "edges_hours": [round(x, 6) for x in new], "smooth": bool(b.smooth)}
