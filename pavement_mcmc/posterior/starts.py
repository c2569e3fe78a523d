"""A MAP from several starts: the one multi-start rule of ``fit --add`` and of the criticism.

A parameter a new extension brings, started at its prior mean, can leave an optimiser (and the
chains after it) stuck at a bound far from the mode. So a model extended by new effects is
fitted from every start the new extensions propose
(:meth:`~pavement_mcmc.physics.Extension.start_values`), each with their null values over a
base fit's values, and the best fit kept. Used by
:func:`pavement_mcmc.runs.start.map_start` (best by log-posterior) and
:func:`pavement_mcmc.criticism.candidates.fit_extension` (best by the MAP objective).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import TypeVar

F = TypeVar("F")

__all__ = ["best_start", "extension_starts"]


def extension_starts(extensions: Iterable, meas, values: dict[str, float]) -> list[dict[str, float]]:
    """Start points (values by name) of a model extended by ``extensions`` from a base fit's
    ``values``: each extension's null values, then each of its proposed starts (every
    combination, in order; one start per extension that proposes none)."""
    starts = [dict(values)]
    for ext in extensions:
        null = ext.null_values(meas) or {}
        extra = ext.start_values(meas, values) or [{}]
        starts = [{**s, **null, **v} for s in starts for v in extra]
    return starts


def best_start(fit: Callable[[dict], F], starts: Iterable[dict], score: Callable[[F], float]) -> F:
    """``fit(s)`` for every start ``s``, the one of highest ``score`` (the first of equals)."""
    return max((fit(s) for s in starts), key=score)
