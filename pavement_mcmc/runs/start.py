"""Where a refit with added effects starts (``fit --add``): a MAP of the extended model.

A new parameter started at its prior mean (or its null value) can leave the chains stuck at a
bound far from the mode (``fit --add evaporation`` stuck at evap_A ~ 2e-8 with R-hat 16.9
while the MAP route gave 0.30). So the extended model is fitted by MAP first: the base model's
MAP, then every start the new extensions propose
(:meth:`~pavement_mcmc.physics.Extension.start_values`) with their null values, the best of
them kept. ``--add finer_h`` is not an extension but a finer ``[model] h`` setting
(:func:`~pavement_mcmc.physics.hbasis.finer_spec`).
"""

from __future__ import annotations

import numpy as np

from ..data import load_case, merge_overrides
from ..physics.hbasis import FINER_H, finer_spec
from ..posterior import build_problem, find_map


def resolve_finer_h(case, ov: dict, add: list[str]) -> tuple[dict, list[str]]:
    """``(overrides, add)`` with ``finer_h`` taken out of ``add`` and turned into the ``[model]
    h`` override it stands for; ValueError if h is already per interval."""
    if FINER_H not in add:
        return ov, add
    rest = [a for a in add if a != FINER_H]
    adds = {"model": {"extensions": rest}} if rest else None
    cfg = load_case(case, ov or None, additions=adds)
    spec = finer_spec(build_problem(cfg).model)
    if spec is None:
        raise ValueError(f"--add {FINER_H}: h(t) is already one value per interval or given by an "
                         "extension; there is no finer h to fit")
    return merge_overrides(ov, {"model": {"h": spec}}), rest


def _vector(space, values: dict[str, float]) -> np.ndarray:
    lo, hi = space.bounds()
    x = space.initial().astype(float)
    for i, n in enumerate(space.free):
        if n in values and np.isfinite(values[n]):
            x[i] = float(values[n])
    span = np.where(np.isfinite(hi - lo), hi - lo, np.abs(x) + 1.0)
    return np.clip(x, lo + 1e-6 * span, hi - 1e-6 * span)


def map_start(problem, cfg, added: list[str]):
    """The best MAP (a :class:`~pavement_mcmc.posterior.Laplace`) of ``problem`` from the base
    model's MAP and the added extensions' starts; None if nothing was added."""
    names = {e.name for e in problem.model.extensions}
    new = [e for e in problem.model.extensions if e.name in set(added) & names]
    if not new:
        return None
    base = build_problem(cfg, extensions=[e.name for e in problem.model.extensions if e not in new],
                         input_noise=problem.posterior.input_noise)
    lb = find_map(base.posterior)
    base_vals = {**base.space.value_dict(), **dict(zip(lb.names, lb.theta, strict=True))}
    starts = [base_vals]
    for ext in new:
        null = ext.null_values(problem.meas) or {}
        extra = ext.start_values(problem.meas, base_vals) or [{}]
        starts = [{**s, **null, **v} for s in starts for v in extra]
    best, best_lp = None, -np.inf
    for s in starts:
        lap = find_map(problem.posterior, _vector(problem.space, s))
        lp = float(problem.posterior(lap.theta[None, :])[0][0])
        if best is None or lp > best_lp:
            best, best_lp = lap, lp
    return best
