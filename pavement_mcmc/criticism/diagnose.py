"""One call for the whole diagnosis of a fitted model: residual report + missing-effect ranking."""

from __future__ import annotations

from dataclasses import dataclass, field

from ..physics.materials import check_values, declared_material
from .energy import EnergyBalance, energy_balance
from .ranking import Ranking, rank_missing_effects
from .residuals import ResidualReport, analyse_point


@dataclass
class Diagnosis:
    """Residual report at the point estimate, the plausibility findings of its kappa, C and h,
    the energy balance of the surface (:mod:`.energy`) and (optionally) the missing-effect ranking."""

    problem: object
    values: dict[str, float]
    residuals: ResidualReport
    ranking: Ranking | None
    findings: list = field(default_factory=list)
    energy: EnergyBalance | None = None

    def to_dict(self) -> dict:
        out = {
            "model": self.problem.model.describe(),
            "point_estimate": self.values,
            "residuals": self.residuals.to_dict(),
        }
        out["plausibility"] = [f.text() for f in self.findings]
        if self.energy is not None:
            out["energy_balance"] = self.energy.to_dict()
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
    problem : the :class:`~pavement_mcmc.posterior.Problem` that was fitted.
    values : its point estimate by parameter name (posterior mean from a stored run, see
        :func:`point_estimate`, or a MAP); default the parameters' values.
    rank : also rank the missing-effect candidates (MAP refits, a few seconds).
    candidates : restrict the candidates (default: the whole catalogue and ``finer_h``).
    holdout : break look-alike ties by a leave-one-sensor-out check.

    Returns
    -------
    Diagnosis
    """
    values = dict(values or problem.space.value_dict())
    rep = analyse_point(problem, values)
    space = problem.space
    h = [values[n] for n in space.free if space[n].group == "h" and n in values]
    declared = declared_material(problem)
    findings = check_values(values.get("kappa"), values.get("C"), h or None, declared)
    energy = None
    if not problem.model.top_measured:
        alarm = any(f.level == "alarm" and f.quantity in ("kappa", "C") for f in findings)
        energy = energy_balance(problem, values, top_fit=alarm or bool(problem.model.plates))
    ranking = (rank_missing_effects(problem, values, candidates, holdout=holdout, energy=energy,
                                    report=rep) if rank else None)
    return Diagnosis(problem, values, rep, ranking, findings, energy)
