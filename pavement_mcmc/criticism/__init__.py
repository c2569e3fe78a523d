"""Model criticism: where the model fails, which effect is missing, and run comparison.

>>> from pavement_mcmc.criticism import diagnose
>>> dx = diagnose(problem, values)          # values: point estimate by parameter name
>>> print(dx.ranking.verdict)

Public API
----------
- :func:`diagnose` (problem, point estimate) -> :class:`Diagnosis` (residual report + ranking);
- :func:`~.residuals.analyse` / :func:`~.residuals.analyse_point` -> :class:`~.residuals.ResidualReport`;
- :func:`~.ranking.rank_missing_effects` -> :class:`~.entries.Ranking` (claim rules in
  :mod:`.entries`; "none of these" in :mod:`.unexplained`);
- :func:`~.guards.check_run` -> findings on a stored run before it is judged;
- :func:`~.campaign.diagnose_twins` / :func:`~.campaign.rates` -> the validation campaigns;
- :func:`~.ledger.ledger` -> :class:`~.ledger.Ledger` (compare runs);
- :func:`~.holdout.leave_one_sensor_out` -> :class:`~.holdout.HoldOut`;
- :func:`~.fitting.refit` -> :class:`~.fitting.Fit` (quick MAP refit);
- :func:`~.point.load_point` -> the point estimate of a run folder or a case TOML to judge;
- :func:`~.rolling.rolling_forecast` -> :class:`~.rolling.Rolling` (next-day forecasts of two
  cases a day apart over a record; ``pavement-mcmc rolling``);
"""

from __future__ import annotations

from .diagnose import Diagnosis, diagnose
from .entries import Entry, Ranking
from .fitting import Fit, refit
from .holdout import HoldOut, leave_one_sensor_out
from .ledger import Ledger, ledger
from .point import load_point
from .ranking import finer_h_spec, rank_missing_effects
from .residuals import ResidualReport, analyse, analyse_point, noise_like, plain_signals
from .rolling import Rolling, rolling_forecast
from .unexplained import Unexplained

__all__ = [
    "Diagnosis",
    "Entry",
    "Fit",
    "HoldOut",
    "Ledger",
    "Ranking",
    "ResidualReport",
    "Rolling",
    "Unexplained",
    "analyse",
    "analyse_point",
    "diagnose",
    "finer_h_spec",
    "leave_one_sensor_out",
    "ledger",
    "load_point",
    "noise_like",
    "plain_signals",
    "rank_missing_effects",
    "refit",
    "rolling_forecast",
]
