"""The chain over time: rolling acceptance and per-segment summaries (early versus late)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._arrays import _as_3d


def acceptance_over_time(accepted: np.ndarray, window: int) -> np.ndarray:
    """Rolling acceptance fraction.

    Parameters
    ----------
    accepted : array_like of bool, shape (n_steps, n_chains) or (n_steps,)
    window : int
        Number of steps in the trailing window.

    Returns
    -------
    ndarray, shape (n_steps,)
        Entry ``i`` is the fraction of accepted proposals over steps
        ``max(0, i - window + 1) .. i`` and all chains (shorter windows at the start).
    """
    if window < 1:
        raise ValueError(f"window must be >= 1; got {window}")
    a = np.asarray(accepted, dtype=float)
    per_step = a.mean(axis=1) if a.ndim == 2 else a
    csum = np.concatenate([[0.0], np.cumsum(per_step)])
    idx = np.arange(1, per_step.size + 1)
    lo = np.maximum(idx - window, 0)
    return (csum[idx] - csum[lo]) / (idx - lo)


@dataclass(frozen=True)
class SegmentSummary:
    """Per-segment statistics for early-versus-late box plots.

    Attributes
    ----------
    edges : (n_segments + 1,) step indices; segment ``s`` is ``edges[s]:edges[s + 1]``.
    samples : list of (n_seg_steps * n_chains, n_params) arrays, the draws of each segment.
    mean : (n_segments, n_params).
    sd : (n_segments, n_params).
    quantiles : (n_segments, 5, n_params) at ``levels``.
    levels : (5,) the percentiles 2.5, 25, 50, 75, 97.5.
    """

    edges: np.ndarray
    samples: list[np.ndarray]
    mean: np.ndarray
    sd: np.ndarray
    quantiles: np.ndarray
    levels: np.ndarray


def segment_summary(x: np.ndarray, n_segments: int) -> SegmentSummary:
    """Split the chain into ``n_segments`` consecutive, nearly equal segments and summarise each.

    Returns
    -------
    SegmentSummary
    """
    x = _as_3d(x)
    n, m, p = x.shape
    if not 1 <= n_segments <= n:
        raise ValueError(f"n_segments must be in [1, {n}]; got {n_segments}")
    edges = np.linspace(0, n, n_segments + 1).astype(int)
    levels = np.array([2.5, 25.0, 50.0, 75.0, 97.5])
    samples = [x[lo:hi].reshape(-1, p) for lo, hi in zip(edges[:-1], edges[1:], strict=True)]
    return SegmentSummary(
        edges=edges,
        samples=samples,
        mean=np.array([s.mean(axis=0) for s in samples]),
        sd=np.array([s.std(axis=0, ddof=1) if len(s) > 1 else np.zeros(p) for s in samples]),
        quantiles=np.array([np.percentile(s, levels, axis=0) for s in samples]),
        levels=levels,
    )
