"""Split-R-hat, optionally rank-normalised (Vehtari et al. 2021)."""

from __future__ import annotations

import numpy as np
from scipy import special

from ._arrays import _as_3d

#: steps a kept chain is thinned to for split-R-hat, by the stopping rule and the summaries alike
#: (a run the rule stops must not be judged otherwise by its report: the two once disagreed
#: at 1.009 against 1.011 on the Göttingen energy case)
RHAT_ROWS = 500


def _rhat_basic(x: np.ndarray) -> np.ndarray:
    """Classic potential scale reduction for ``(n, m, p)`` chains (no splitting)."""
    n = x.shape[0]
    means = x.mean(axis=0)
    w = x.var(axis=0, ddof=1).mean(axis=0)
    b_over_n = means.var(axis=0, ddof=1)
    var_hat = (n - 1) / n * w + b_over_n
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.sqrt(var_hat / w)
    return np.where((w == 0) & (b_over_n == 0), 1.0, r)


def _average_ranks(a: np.ndarray) -> np.ndarray:
    """Ranks 1..N along the last axis, ties sharing their average rank (MH chains repeat)."""
    order = np.argsort(a, axis=-1)
    s = np.take_along_axis(a, order, axis=-1)
    n = a.shape[-1]
    ranks = np.empty(a.shape)
    first = np.ones(a.shape, dtype=bool)
    first[..., 1:] = s[..., 1:] != s[..., :-1]
    if first.all():  # no ties (continuous draws): rank = place in the sorted order
        np.put_along_axis(ranks, order, np.broadcast_to(np.arange(1.0, n + 1.0), a.shape), axis=-1)
        return ranks
    idx = np.broadcast_to(np.arange(n), a.shape)
    last = np.ones(a.shape, dtype=bool)
    last[..., :-1] = first[..., 1:]
    start = np.maximum.accumulate(np.where(first, idx, 0), axis=-1)
    stop = np.flip(np.minimum.accumulate(np.flip(np.where(last, idx, n - 1), -1), axis=-1), -1)
    np.put_along_axis(ranks, order, (start + stop) / 2.0 + 1.0, axis=-1)
    return ranks


def _rank_normalize(x: np.ndarray) -> np.ndarray:
    """Rank-normalise over all draws of each parameter (Vehtari et al. 2021, eq. 14)."""
    n, m, p = x.shape
    flat_t = np.ascontiguousarray(x.reshape(n * m, p).T)  # (p, N): sort contiguous rows
    z = special.ndtri((_average_ranks(flat_t) - 0.375) / (n * m + 0.25))
    return z.T.reshape(n, m, p)


def split_rhat(x: np.ndarray, rank_normalized: bool = True) -> np.ndarray:
    r"""Split-:math:`\hat R` per parameter.

    Each chain is cut into halves (the middle draw is dropped if ``n_steps`` is odd) and the
    Gelman–Rubin statistic is computed over the ``2 n_chains`` half-chains. With
    ``rank_normalized`` (default) this is the rank-normalised version of Vehtari, Gelman,
    Simpson, Carpenter & Bürkner (2021): the maximum of the bulk R-hat (rank-normalised draws) and
    the tail R-hat (rank-normalised absolute deviations from the median). Values above 1.01
    (strict) or 1.1 (lenient) indicate non-convergence.

    emcee's walkers are not independent chains, so R-hat across walkers is optimistic: walkers
    that move together look converged to each other. Prefer several independent runs, or use the
    integrated autocorrelation time.

    Returns
    -------
    ndarray, shape (n_params,)
    """
    x = _as_3d(x)
    half = x.shape[0] // 2
    if half < 2:
        raise ValueError(f"split_rhat needs at least 4 steps; got {x.shape[0]}")
    split = np.concatenate([x[:half], x[-half:]], axis=1)
    if not rank_normalized:
        return _rhat_basic(split)
    bulk = _rhat_basic(_rank_normalize(split))
    folded = np.abs(split - np.median(split.reshape(-1, split.shape[2]), axis=0))
    tail = _rhat_basic(_rank_normalize(folded))
    return np.maximum(bulk, tail)
