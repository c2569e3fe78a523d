"""The candidate models of a ranking: a finer h(t), or the run's model plus one catalogue
extension, each refitted by MAP from the base fit (see :mod:`.ranking`)."""

from __future__ import annotations

import numpy as np

from ..physics.hbasis import finer_spec
from ..posterior import build_problem
from ..posterior.starts import best_start, extension_starts
from .fitting import Fit, refit


def finer_h_spec(problem) -> dict | None:
    """A finer h(t) than the problem's (pieces <= 2 h, at least halved); None if h is already
    per interval or replaced by an extension (:func:`~pavement_mcmc.physics.hbasis.finer_spec`)."""
    return finer_spec(problem.model)


def h_spec_of(problem) -> dict:
    b = problem.model.h_basis
    return {"kind": "pieces", "edges_hours": (b.edges / 3600.0).tolist(), "smooth": bool(b.smooth)}


def h_start(problem_from, values: dict[str, float], problem_to) -> dict[str, float]:
    """Start values of ``problem_to``'s h pieces from the pieces of ``problem_from``."""
    bf, bt = problem_from.model.h_basis, problem_to.model.h_basis
    out = {}
    if problem_from.model.replaces_h or problem_to.model.replaces_h:
        return out
    mid = 0.5 * (bt.edges[1:] + bt.edges[:-1])
    j = np.clip(np.searchsorted(bf.edges, mid) - 1, 0, len(bf.names) - 1)
    for name, jj in zip(bt.names, j, strict=True):
        if bf.names[jj] in values:
            out[name] = values[bf.names[jj]]
    return out


def _predict(problem, values: dict[str, float]) -> np.ndarray:
    p = {k: v.copy() for k, v in problem.space.values().items()}
    p.update({k: np.array([float(v)]) for k, v in values.items() if k in p})
    return problem.model.predict(p)[0]


def _candidate_problem(ref_problem, ref_fit: Fit, name, h_spec: dict):
    """The reference model plus the candidate, appended to its extensions.

    If that changes the reference model's predictions at the candidate's null values (a hook that
    recomputes what an earlier extension produced instead of editing it, e.g. ``sensor_depth``'s
    ``observe`` after ``sensor_bias``), the candidate is placed first instead, where it nests the
    reference model. Returns ``(problem, extension)``.
    """
    present = list(ref_problem.model.extensions)
    prob = variant(ref_problem, [*present, name], h_spec)
    ext = prob.model.extensions[-1]
    null = ext.null_values(prob.meas)
    if not present or not null:
        return prob, ext
    vals = ref_fit.values()
    ref_pred = _predict(ref_problem, vals)
    for i, order in enumerate(([*present, ext], [ext, *present])):
        cand = prob if i == 0 else variant(ref_problem, order, h_spec)
        if np.allclose(_predict(cand, {**vals, **null}), ref_pred, rtol=0.0, atol=1e-9):
            return cand, ext
    return prob, ext


def variant(problem, extensions, h_spec):
    """``problem``'s case with other extensions or h(t), scored with the same likelihood: a
    candidate shares the base problem's data covariance (noisy inputs integrated out) and its
    solver grid."""
    return build_problem(problem.cfg, extensions=extensions, h_spec=h_spec,
                         input_noise=problem.posterior.input_noise, grid=problem.model.grid)


def fit_extension(ref_problem, ref_fit: Fit, name: str, h_spec: dict) -> Fit:
    prob, ext = _candidate_problem(ref_problem, ref_fit, name, h_spec)
    starts = extension_starts([ext], prob.meas, ref_fit.values())
    return best_start(lambda s: refit(prob, s), starts, score=lambda f: -f.objective)
