"""Shape and FFT-size helpers shared by the diagnostics."""

from __future__ import annotations

import numpy as np

_FFT_BYTES = 2**28  # memory budget of one batch of FFTs


def _as_3d(x: np.ndarray) -> np.ndarray:
    """View ``x`` as ``(n_steps, n_chains, n_params)`` float64."""
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        return x[:, None, None]
    if x.ndim == 2:
        return x[:, :, None]
    if x.ndim == 3:
        return x
    raise ValueError(f"chain must be 1-D, 2-D or 3-D (n_steps, n_chains, n_params); got {x.shape}")


def _next_pow_two(n: int) -> int:
    return 1 << max(0, int(n - 1).bit_length())
