"""Compare runs: the error ledger (RMSE per sensor, max |r|, lag-1, chi2/dof, hold-out score,
forecast skill), ranked by the forecast.

Every row is computed from a run's problem and point estimate (posterior mean of a stored run);
the out-of-sample score is the leave-one-sensor-out log predictive density per datum with a MAP
refit per fold (:mod:`.holdout`), which keeps each held-out series' time correlation out of the
fit. The forecast (:mod:`.forecast`) refits the start of each run's window and predicts the rest
from the forcing alone; runs are ranked by its log predictive density (higher first). Changes are
reported against the first run.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .forecast import Forecast
from .forecast import forecast as forecast_skill
from .holdout import HoldOut, leave_one_sensor_out
from .residuals import analyse_point


@dataclass
class Row:
    """One run of the ledger (temperatures in degC)."""

    label: str
    model: str
    labels: list[str]
    rmse_sensors: list[float]
    rmse: float
    max_abs: float
    lag1: float
    chi2_dof: float
    n_free: int
    holdout: HoldOut | None
    residuals: np.ndarray
    t: np.ndarray
    forecast: Forecast | None = None

    def to_dict(self) -> dict:
        return {
            "label": self.label,
            "model": self.model,
            "rmse_sensors": dict(zip(self.labels, self.rmse_sensors, strict=True)),
            "rmse": self.rmse,
            "max_abs_residual": self.max_abs,
            "lag1": self.lag1,
            "chi2_per_dof": self.chi2_dof,
            "n_free": self.n_free,
            "holdout": None if self.holdout is None else self.holdout.to_dict(),
            "forecast": None if self.forecast is None else self.forecast.to_dict(),
        }


@dataclass
class Ledger:
    """Rows in input order; deltas are against the first row."""

    rows: list[Row]

    def deltas(self) -> list[dict]:
        a = self.rows[0]
        out = []
        for r in self.rows:
            d = {
                "rmse": r.rmse - a.rmse,
                "rmse_pct": 100 * (r.rmse / a.rmse - 1),
                "max_abs_residual": r.max_abs - a.max_abs,
                "lag1": r.lag1 - a.lag1,
                "chi2_per_dof": r.chi2_dof - a.chi2_dof,
            }
            if r.holdout is not None and a.holdout is not None:
                d["holdout_lpd"] = r.holdout.lpd - a.holdout.lpd
            out.append(d)
        return out

    def by_forecast(self) -> list[Row]:
        """Rows with a forecast, best first (highest log predictive density per datum)."""
        return sorted((r for r in self.rows if r.forecast is not None), key=lambda r: -r.forecast.lpd)

    def to_dict(self) -> dict:
        return {
            "rows": [r.to_dict() for r in self.rows],
            "ranked_by_forecast": [r.label for r in self.by_forecast()],
            "change_vs_first": self.deltas(),
            "holdout_method": "leave-one-sensor-out, MAP refit per fold, plug-in Gaussian "
            "log predictive density per held-out datum",
        }

    def text(self) -> str:
        labs = self.rows[0].labels
        head = (
            f"{'run':<22}{'RMSE':>7}"
            + "".join(f"{s:>8}" for s in labs)
            + f"{'max|r|':>8}{'lag1':>6}{'chi2/dof':>9}{'LOSO lpd':>10}{'dRMSE':>8}"
            + f"{'fc RMSE':>9}{'fc lpd':>8}"
        )
        ranked = self.by_forecast()
        lines = []
        if ranked:
            fc = ranked[0].forecast
            lines += [f"Ranked by forecast of the held-out {fc.horizon:g} h (fit to the first "
                      f"{fc.origins[-1]:g} h, then {fc.driver}): "
                      + " > ".join(f"{r.label} ({r.forecast.rmse:.3f} °C)" for r in ranked), ""]
        lines += [
            "RMSE and residuals in degC; LOSO lpd: leave-one-sensor-out log predictive "
            "density per datum; fc: forecast RMSE and log predictive density per datum (higher "
            "is better)",
            head,
        ]
        for r, d in zip(self.rows, self.deltas(), strict=True):
            lpd = f"{r.holdout.lpd:10.3f}" if r.holdout is not None else f"{'-':>10}"
            lines.append(
                f"{r.label[:21]:<22}{r.rmse:7.3f}"
                + "".join(f"{v:8.3f}" for v in r.rmse_sensors)
                + f"{r.max_abs:8.2f}{r.lag1:6.2f}{r.chi2_dof:9.2f}{lpd}{d['rmse_pct']:+7.1f}%"
                + (f"{r.forecast.rmse:9.3f}{r.forecast.lpd:8.2f}" if r.forecast is not None
                   else f"{'-':>9}{'-':>8}")
            )
        return "\n".join(lines + self._folds_text())

    def _folds_text(self) -> list[str]:
        """The leave-one-sensor-out score fold by fold, and which fold carries each run's change
        of the mean against the first run (one badly predicted sensor can carry all of it)."""
        rows = [r for r in self.rows if r.holdout is not None and r.holdout.lpd_sensors is not None]
        if not rows:
            return []
        labs = rows[0].holdout.labels
        lines = ["", "Leave-one-sensor-out fold by fold: each sensor predicted by a refit without "
                 "it, RMSE °C (log predictive density per datum)",
                 f"{'run':<22}" + "".join(f"{s:>18}" for s in labs)]
        for r in rows:
            h = r.holdout
            lines.append(f"{r.label[:21]:<22}" + "".join(
                f"{f'{e:.3f} ({lp:+.2f})':>18}" for e, lp in zip(h.rmse, h.lpd_sensors, strict=True)))
        first = rows[0]
        for r in rows[1:]:
            change = r.holdout.change_from(first.holdout)
            if change is not None:
                lines.append(f"{r.label} against {first.label}: {change}")
        return lines


def _forecast_or_none(problem, values) -> Forecast | None:
    try:
        return forecast_skill(problem, values)
    except ValueError:  # a window too short to hold a part out
        return None


def ledger(runs: list[tuple[str, object, dict[str, float]]], *, holdout: bool = True,
           forecast: bool = False) -> Ledger:
    """Build the ledger of ``runs``: ``[(label, problem, point estimate by name), ...]``;
    ``forecast``: also each run's forecast skill (:mod:`.forecast`), and rank by it."""
    rows = []
    for label, problem, values in runs:
        rep = analyse_point(problem, values)
        r = rep.residuals
        space = problem.space
        theta = np.array([[float(values.get(n, space[n].value)) for n in space.free]])
        z = problem.posterior.whitened(theta)[0]
        n_free = len(problem.space.free)
        dof = max(r.size - n_free, 1)
        rows.append(
            Row(
                label=label,
                model=problem.model.describe(),
                labels=rep.labels,
                rmse_sensors=[s.rmse for s in rep.sensors],
                rmse=rep.rmse,
                max_abs=float(np.max(np.abs(r))),
                lag1=rep.rho,
                chi2_dof=float(np.sum(z * z) / dof),
                n_free=n_free,
                holdout=(leave_one_sensor_out(problem, values)  # one sensor: no fold
                         if holdout and problem.meas.n_sensors > 1 else None),
                residuals=r,
                t=rep.t,
                forecast=_forecast_or_none(problem, values) if forecast else None,
            )
        )
    return Ledger(rows)
