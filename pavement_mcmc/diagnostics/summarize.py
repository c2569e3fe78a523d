"""The per-parameter posterior summary with its diagnostics (the run's summary table)."""

from __future__ import annotations

import numpy as np

from ._arrays import _as_3d
from .autocorr import _sokal_tau
from .rhat import RHAT_ROWS, split_rhat
from .stationarity import geweke


def summary(
    x: np.ndarray, names: list[str] | None = None, max_steps: int | None = 4000
) -> dict[str, dict[str, float]]:
    """Posterior summary and diagnostics per parameter.

    Parameters
    ----------
    x : array_like, shape (n_steps, n_chains, n_params)
        Post-burn-in chain.
    names : list of str, optional
        Parameter names (default ``p0, p1, ...``).
    max_steps : int or None
        Moments and quantiles use every draw; the IACT and Geweke are computed on the chain
        thinned to at most ``max_steps`` steps (the IACT rescaled to original steps), because
        on long runs (75 000 steps x 32 chains x 115 parameters) they take minutes; thinning by
        k << tau changes them little; None uses every step. Split-R-hat is computed on the
        stopping rule's rows (:data:`~.rhat.RHAT_ROWS`), so a run and its report judge alike.

    Returns
    -------
    dict
        ``{name: {"mean", "sd", "q2.5", "q50", "q97.5", "ess", "mcse", "tau", "rhat",
        "geweke_z", "geweke_rel"}}`` with float values. No length check is applied to ``tau``;
        compare ``tau`` with the chain length yourself (or call :func:`integrated_time`).
    """
    x = _as_3d(x)
    p = x.shape[2]
    names = list(names) if names is not None else [f"p{i}" for i in range(p)]
    if len(names) != p:
        raise ValueError(f"{len(names)} names for {p} parameters")
    flat = x.reshape(-1, p)
    q = np.percentile(flat, [2.5, 50.0, 97.5], axis=0)
    k = max(1, -(-x.shape[0] // max_steps)) if max_steps else 1
    sub = x[::k]
    tau = _sokal_tau(sub, 5) * k
    n_eff = x.shape[0] * x.shape[1] / tau
    sd = flat.std(axis=0, ddof=1)
    rsub = x[:: max(1, x.shape[0] // RHAT_ROWS)]  # the stopping rule's rows (RHAT_ROWS)
    rhat = split_rhat(rsub) if rsub.shape[0] >= 4 else np.full(p, np.nan)
    g = geweke(sub)
    out: dict[str, dict[str, float]] = {}
    for i, name in enumerate(names):
        out[name] = {
            "mean": float(flat[:, i].mean()),
            "sd": float(sd[i]),
            "q2.5": float(q[0, i]),
            "q50": float(q[1, i]),
            "q97.5": float(q[2, i]),
            "ess": float(n_eff[i]),
            "mcse": float(sd[i] / np.sqrt(n_eff[i])),
            "tau": float(tau[i]),
            "rhat": float(rhat[i]),
            "geweke_z": float(g.z[i]),
            "geweke_rel": float(g.rel_diff[i]),
        }
    return out
