r"""Chains left behind by their start: moved onto the others once, early in the adaptation.

``hmc`` starts its chains over-dispersed around the mode. A start far in a tail where the
log-density is much steeper than at the mode (SoilVUE desert window, seed 2: kappa and C
10 sd below the mode, log-posterior 9,850 below the other chains') rejects every trajectory at
the step size the other chains tune, and stays where it started; the metric windows then pool
its draws with theirs and the step size falls (0.03 instead of 0.12, 50 leapfrog steps to
the stopping rule: 657k instead of 175k gradients). The draws of the adaptation are never kept,
so such a chain can be moved: at the end of the first ``metric_skip`` steps every chain whose
log-density lies more than ``20 + sqrt(20 d)`` (``d``: the parameters moved) below the chains'
median continues from the state of a chain drawn at random among the others. For a
``d``-variate Gaussian, ``-log p`` above its minimum is ``chi^2_d / 2``, which exceeds
``d/2 + sqrt(20 d) + 20`` with probability below ``e^-20`` (Laurent & Massart 2000, lemma 1),
so no chain in the bulk of the posterior is moved (nor one on a ridge of equal density, as a
Göttingen h near 0).
"""

from __future__ import annotations

import numpy as np


def strays(f: np.ndarray, d: int) -> np.ndarray:
    """Chains (bool, n) whose log-density ``f`` (n,) lies more than ``20 + sqrt(20 d)`` below
    the median (and those of a non-finite ``f``); none if every chain is one."""
    ok = np.isfinite(f)
    with np.errstate(invalid="ignore"):
        out = ~(f >= np.median(f[ok]) - 20.0 - np.sqrt(20.0 * d)) if ok.any() else np.zeros(f.size, bool)
    return out if not out.all() else np.zeros(f.size, bool)


def rejoin(rng: np.random.Generator, lost: np.ndarray, *arrays: np.ndarray) -> None:
    """Overwrite row ``i`` of every array (first axis: the chains) for each ``lost`` chain
    with the row of a chain drawn uniformly among the others (in place; no random draw if
    none is lost)."""
    if not lost.any():
        return
    good = np.flatnonzero(~lost)
    src = good[rng.integers(good.size, size=int(lost.sum()))]
    for a in arrays:
        a[lost] = a[src]
