"""One call for the whole diagnosis of a fitted model: residual report + missing-effect ranking."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .ranking import Ranking, rank_missing_effects
from .residuals import ResidualReport, analyse_point


@dataclass
class Diagnosis:
    """Residual report at the point estimate and (optionally) the missing-effect ranking."""

    problem: object
    values: dict[str, float]
    residuals: ResidualReport
    ranking: Ranking | None

    def to_dict(self) -> dict:
        out = {
            "model": self.problem.model.describe(),
            "point_estimate": self.values,
            "residuals": self.residuals.to_dict(),
        }
        if self.ranking is not None:
            out["ranking"] = self.ranking.to_dict()
        return out


def diagnose(
    problem,
    values: dict[str, float] | None = None,
    *,
    rank: bool = True,
    candidates: list[str] | None = None,
    holdout: bool = True,
) -> Diagnosis:
    """Diagnose a fitted model.

    Parameters
    ----------
    problem : the :class:`~pavement_mcmc.problem.Problem` that was fitted.
    values : its point estimate by parameter name (posterior mean from a stored run, see
        :func:`point_estimate`, or a MAP); default the parameters' values.
    rank : also rank the missing-effect candidates (MAP refits, a few seconds).
    candidates : restrict the candidates (default: the whole catalogue and ``finer_h``).
    holdout : break look-alike ties by a leave-one-sensor-out check.

    Returns
    -------
    Diagnosis
    """
    values = dict(values or {k: float(v[0]) for k, v in problem.space.values().items()})
    rep = analyse_point(problem, values)
    ranking = rank_missing_effects(problem, values, candidates, holdout=holdout) if rank else None
    return Diagnosis(problem, values, rep, ranking)


def point_estimate(run_dir: str | Path, statistic: str = "mean") -> tuple[object, dict[str, float]]:
    """The problem of a stored run and its posterior mean (or median) after burn-in.

    Uses :func:`pavement_mcmc.runner.load_run`; the burn-in is the one stored with the run
    (else half the chain). Never re-runs a sampler.
    """
    from ..runner import load_run

    problem, run = load_run(run_dir)
    chain = np.asarray(run.chain)
    burn = None
    for src in (run.meta, getattr(run.state, "extra", None) or {}):
        if isinstance(src, dict) and isinstance(src.get("burn_in"), int | float):
            burn = int(src["burn_in"])
    if burn is None or burn >= chain.shape[0]:
        burn = chain.shape[0] // 2
    flat = chain[burn:].reshape(-1, chain.shape[2])
    est = np.median(flat, axis=0) if statistic == "median" else flat.mean(axis=0)
    vals = {k: float(v[0]) for k, v in problem.space.values().items()}
    vals.update({n: float(v) for n, v in zip(run.param_names, est, strict=True)})
    return problem, vals
