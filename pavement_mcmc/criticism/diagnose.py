"""One call for the whole diagnosis of a fitted model: residual report + missing-effect ranking."""

from __future__ import annotations

from dataclasses import dataclass, field

from ..physics.materials import check_values, declared_material
from .energy import EnergyBalance, energy_balance
from .forecast import Forecast
from .forecast import forecast as forecast_skill
from .ranking import Ranking, rank_missing_effects
from .residuals import ResidualReport, analyse_point


@dataclass
class Diagnosis:
    """Residual report at the point estimate, the plausibility findings of its kappa, C and h,
    the energy balance of the surface (:mod:`.energy`), (optionally) the missing-effect ranking
    and the forecast skill of the base model (:mod:`.forecast`)."""

    problem: object
    values: dict[str, float]
    residuals: ResidualReport
    ranking: Ranking | None
    findings: list = field(default_factory=list)
    energy: EnergyBalance | None = None
    forecast: Forecast | None = None

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
        if self.forecast is not None:
            out["forecast"] = self.forecast.to_dict()
        return out


def diagnose(
    problem,
    values: dict[str, float] | None = None,
    *,
    rank: bool = True,
    candidates: list[str] | None = None,
    holdout: bool = True,
    forecast: bool | dict = False,
    energy_law: bool | None = None,
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
    forecast : forecast skill of the base fit and of every candidate, and the claim rule that
        rests on it (:mod:`.entries`): True or options of :func:`~.forecast.forecast`. A window
        too short to hold a part out falls back to the in-sample rule.
    energy_law : also try the surface energy balance as a candidate
        (:func:`~.ranking.energy_candidate`: None where the energy check says the surface
        boundary is wrong, True always, False never).

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
        alarm = any(f.level == "alarm" and f.quantity in ("kappa", "C", "h") for f in findings)
        energy = energy_balance(problem, values, top_fit=alarm or bool(problem.model.plates))
    ranking = (rank_missing_effects(problem, values, candidates, holdout=holdout, energy=energy,
                                    report=rep, forecast=forecast, energy_law=energy_law)
               if rank else None)
    fc = None if ranking is None else ranking.forecast
    if fc is None and forecast is not False:
        try:
            fc = forecast_skill(problem, values, **({} if forecast is True else dict(forecast)))
        except ValueError:  # a window too short to hold a part out
            fc = None
    return Diagnosis(problem, values, rep, ranking, findings, energy, fc)
