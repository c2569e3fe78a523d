r"""Forecast skill: fit the start of the window, predict the rest from the forcing alone.

Method (one *origin*; several origins roll it forward)
------------------------------------------------------
1. The training problem is the run's problem restricted to the rows up to the origin
   (:func:`training_problem`: same grid, priors, extensions and likelihood; the input-noise
   covariance is the training rows' block of the run's, exact because the inputs act forward in
   time only). It is refitted by MAP (:func:`~.fitting.refit`, a Laplace-level refit).
2. The whole-window model runs with the training MAP from the initial profile to the end of the
   window: the held-out rows are predicted from the forcing (air temperature, net radiation,
   wind, rain, bottom temperature) alone, never from a held-out temperature.
3. Parameters the training fit cannot know (pieces of h(t) after the origin, and any
   per-interval parameter of an extension, i.e. a parameter group) follow the **future rule**:

   - ``"diurnal"`` (default): each future piece of h gets the clock-hour mean of the fitted
     h(t) over the training window, weighted by time (hours the training window does not cover
     get its overall mean);
   - ``"persist"``: the last fitted value, the prediction of the first-order GMRF smoothness
     prior (a random walk) for every future step.

   Measured on clean Case C twins (``benchmarks/forecast_rule.py``), the diurnal rule's
   forecast RMSE lies closer to that of the true h(t); see :data:`DEFAULT_RULE`.
4. Scores on the held-out temperatures: RMSE (degC and sigma) and the plug-in Gaussian log
   predictive density with the likelihood's sd of each datum (``sigma``, or its marginal sd
   with noisy inputs; parameter uncertainty ignored, as in :mod:`.holdout`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..data.times import hour_of_day
from ..parameters import ParameterSpace
from ..physics import Model
from ..physics.hbasis import HBasis
from ..posterior import LogPosterior, Problem
from ..posterior.logpost import default_streams
from ..posterior.observations import with_parameters
from .fitting import Fit, refit
from .residuals import inflation, pooled_lag1

_LOG_2PI = np.log(2 * np.pi)

#: future rules of per-interval parameters (module doc)
RULES = ("diurnal", "persist")
#: the rule used unless asked otherwise (module doc, point 3)
DEFAULT_RULE = "diurnal"
#: the held-out period: the last 24 h of windows of 48 h or more, else the last quarter
HORIZON_HOURS = 24.0


@dataclass
class Forecast:
    """Forecast skill of one model on the held-out end of its window.

    Attributes
    ----------
    rule : the future rule of per-interval parameters (module doc).
    origins : training ends, hours from the window start.
    horizon : held-out hours after each origin.
    rmse : RMSE of the held-out predictions, degC; ``rmse_sigma`` in sigma.
    rmse_sensors : per-sensor RMSE, degC.
    lpd : mean plug-in Gaussian log predictive density per held-out datum.
    elpd : its sum over the held-out data.
    rho : pooled lag-1 autocorrelation of the forecast errors.
    n : number of held-out data.
    t, observed, predicted : the last origin's held-out times (s) and temperatures
        (n_rows, n_sensors), degC, for the figure.
    fits : the training MAP refit of each origin (not serialised).
    top_measured : the surface is a measured sensor (no h(t) to carry forward).
    ground : the base model's :class:`~.ground.GroundForecast` when the ranking made one.
    """

    rule: str
    origins: list[float]
    horizon: float
    rmse: float
    rmse_sigma: float
    rmse_sensors: list[float]
    lpd: float
    elpd: float
    rho: float
    n: int
    t: np.ndarray = field(repr=False)
    observed: np.ndarray = field(repr=False)
    predicted: np.ndarray = field(repr=False)
    fits: list = field(default_factory=list, repr=False)
    top_measured: bool = False
    ground: object | None = field(default=None, repr=False)

    @property
    def driver(self) -> str:
        """What alone drives the held-out period, for a sentence."""
        return "the measured top sensor alone" if self.top_measured else "the forcing alone"

    @property
    def future(self) -> str:
        """What drives the held-out period, for a caption."""
        return f"then {self.driver}" + ("" if self.top_measured else
                                         f"; future h(t): {self.rule} rule")

    def to_dict(self) -> dict:
        keep = ("rule", "origins", "horizon", "rmse", "rmse_sigma", "rmse_sensors", "lpd",
                "elpd", "rho", "n")
        return {k: getattr(self, k) for k in keep}


def split_rows(t: np.ndarray, origin_h: float) -> int:
    """Index of the last training row: the last row at or before ``origin_h`` hours."""
    n = int(np.searchsorted(t, origin_h * 3600.0 + 1e-6, side="right") - 1)
    if n < 2 or n >= t.size - 1:
        raise ValueError(f"forecast origin {origin_h:g} h leaves no training or no held-out rows "
                         f"in a {t[-1] / 3600:g} h window")
    return n


def default_origins(t: np.ndarray, horizon: float | None = None) -> tuple[list[float], float]:
    """One origin: the window end minus :data:`HORIZON_HOURS` (48 h windows and longer), else
    minus a quarter of the window. Returns ``(origins, horizon)`` in hours."""
    T = float(t[-1]) / 3600.0
    if horizon is None:
        horizon = HORIZON_HOURS if T >= 2 * HORIZON_HOURS else T / 4.0
    return [T - horizon], float(horizon)


def _training_basis(basis: HBasis, t: np.ndarray) -> HBasis:
    """The pieces of ``basis`` that start before ``t[-1]``, the last one cut there (same
    names as the first pieces of ``basis``)."""
    e = basis.edges
    k = int(np.searchsorted(e, t[-1] - 1e-6, side="left"))
    edges = np.append(e[:k], t[-1]) / 3600.0
    b = HBasis.pieces(t, edges, basis.smooth)
    return b


def training_problem(problem, n_train: int) -> Problem:
    """``problem`` restricted to the observation rows ``0 .. n_train`` (module doc, point 1)."""
    meas = problem.meas.select_rows(np.arange(n_train + 1))
    m = problem.model
    grid = replace(m.grid, t_obs=m.grid.t_obs[: n_train + 1], substeps=m.grid.substeps[:n_train])
    model = Model(meas, grid, _training_basis(m.h_basis, meas.t), m.extensions, scheme=m.scheme,
                  gamma0=m.gamma0, plates=m.plates)
    flux_sd = None if problem.posterior.flux_sd is None else problem.posterior.flux_sd[:n_train]
    streams = default_streams(model, flux_sd)
    ir = problem.posterior.stream("surface_ir")
    if ir is not None:  # the run's IR stream on the training rows, with its ir_offset
        streams.append(ir.on(meas))
    defaults = with_parameters(model.parameter_space(), streams)
    params = [problem.space[n] if n in problem.space else p for n, p in defaults.params.items()]
    space = ParameterSpace(params, defaults.joint_priors)
    post = LogPosterior(model, space, streams=streams)
    noise = problem.posterior.input_noise
    if noise is not None:
        rows = np.zeros((problem.meas.n_obs - 1, problem.meas.n_sensors), bool)
        rows[:n_train] = True
        post.input_noise = noise.subset(rows.ravel())
    return Problem(problem.cfg, model, space, post, problem.input_ref)


def _diurnal_h(basis: HBasis, values: dict, time0: str, t_end: float) -> np.ndarray:
    """Mean fitted h per clock hour (24,), time-weighted over the training pieces."""
    fine = np.arange(0.0, t_end, 300.0) + 150.0  # 5-min samples of the training window
    k = np.clip(np.searchsorted(basis.edges, fine, side="right") - 1, 0, len(basis.names) - 1)
    h = np.array([values[basis.names[j]] for j in k])
    hour = np.floor(hour_of_day(time0, fine)).astype(int) % 24
    tot = np.bincount(hour, weights=h, minlength=24)
    cnt = np.bincount(hour, minlength=24)
    return np.where(cnt > 0, tot / np.maximum(cnt, 1), h.mean())


def future_values(problem, train: Problem, fitted: dict[str, float], rule: str = DEFAULT_RULE
                  ) -> dict[str, float]:
    """Every parameter of the whole-window ``problem``: the training fit's where it has one,
    the future rule (module doc, point 3) for the rest."""
    if rule not in RULES:
        raise ValueError(f"unknown future rule {rule!r}; valid: {', '.join(RULES)}")
    out = {n: float(v[0]) for n, v in problem.space.values().items()}
    out.update({k: v for k, v in fitted.items() if k in out})
    unknown = [n for n in problem.space.names if n not in fitted]
    if not unknown:
        return out
    basis = problem.model.h_basis
    t_end = float(train.meas.t[-1])
    diurnal = None
    if rule == "diurnal" and not problem.model.replaces_h:
        diurnal = _diurnal_h(train.model.h_basis, fitted, problem.meas.time0, t_end)
    last = {}  # the last fitted value of each parameter group (persistence)
    for n in train.space.names:
        g = train.space[n].group
        if g and n in fitted:
            last[g] = fitted[n]
    for n in unknown:
        g = problem.space[n].group
        if diurnal is not None and n in basis.names:
            j = basis.names.index(n)
            a, b = basis.edges[j], basis.edges[j + 1]
            fine = np.linspace(a, b, max(2, int((b - a) / 300.0)) + 1)
            hour = np.floor(hour_of_day(problem.meas.time0, 0.5 * (fine[1:] + fine[:-1])))
            out[n] = float(np.mean(diurnal[hour.astype(int) % 24]))
        elif g in last:
            out[n] = last[g]
    return out


def held_out(problem, values: dict, n_train: int, n_end: int):
    """Residuals (predicted - measured) and Gaussian log densities of the rows after
    ``n_train`` up to ``n_end`` (arrays (rows, n_sensors)), and the whole prediction, when the
    whole-window model runs with ``values``."""
    p = {k: np.array([v]) for k, v in values.items()}
    pred = problem.model.predict(p)[0]
    obs = problem.meas.T_obs
    r = pred[n_train + 1 : n_end + 1] - obs[n_train + 1 : n_end + 1]
    sd = np.broadcast_to(problem.posterior.marginal_sd(), obs[1:].shape)[n_train:n_end]
    lp = -0.5 * (r / sd) ** 2 - np.log(sd) - 0.5 * _LOG_2PI
    return r, lp, pred


def forecast(problem, start: dict[str, float] | None = None, *, origins=None,
             horizon: float | None = None, rule: str = DEFAULT_RULE,
             max_nfev: int = 100) -> Forecast:
    """Forecast skill of ``problem``'s model (module doc).

    Parameters
    ----------
    problem : a whole-window :class:`~pavement_mcmc.posterior.Problem` (any extensions).
    start : start of the training refits by name (e.g. the run's point estimate).
    origins : training ends, hours from the window start (default :func:`default_origins`).
    horizon : held-out hours after each origin (default: to the next origin or the window end).
    rule : future rule of per-interval parameters, one of :data:`RULES`.
    max_nfev : least-squares iterations of each training refit.

    Returns
    -------
    Forecast
    """
    t = problem.meas.t
    if origins is None:
        origins, horizon = default_origins(t, horizon)
    origins = sorted(float(o) for o in origins)
    res, lps, fits = [], [], []
    for o in origins:
        n_train = split_rows(t, o)
        stop = o + horizon if horizon is not None else t[-1] / 3600.0
        n_end = int(np.searchsorted(t, stop * 3600.0 + 1e-6, side="right") - 1)
        train = training_problem(problem, n_train)
        fit: Fit = refit(train, start, max_nfev=max_nfev)
        vals = future_values(problem, train, fit.values(), rule)
        r, lp, pred = held_out(problem, vals, n_train, n_end)
        res.append(r)
        lps.append(lp)
        fits.append(fit)
    r_all = np.concatenate(res)
    lp_all = np.concatenate(lps)
    rmse = float(np.sqrt(np.mean(r_all**2)))
    rows = slice(n_train + 1, n_end + 1)
    return Forecast(
        rule=rule, origins=origins, top_measured=bool(problem.model.top_measured),
        horizon=float(horizon if horizon is not None else t[-1] / 3600.0 - origins[-1]),
        rmse=rmse, rmse_sigma=rmse / float(problem.meas.sigma),
        rmse_sensors=np.sqrt(np.mean(r_all**2, axis=0)).tolist(),
        lpd=float(np.mean(lp_all)), elpd=float(np.sum(lp_all)),
        rho=float(pooled_lag1(r_all)), n=int(r_all.size),
        t=t[rows].copy(), observed=problem.meas.T_obs[rows].copy(), predicted=pred[rows].copy(),
        fits=fits,
    )


def forecast_from_starts(problem, starts, **kw) -> Forecast:
    """:func:`forecast` from each starting point of ``starts`` (e.g. an extension's
    ``start_values``), the one whose last training refit reached the lowest objective."""
    return min((forecast(problem, st, **kw) for st in starts),
               key=lambda f: f.fits[-1].objective)


def forecast_gain(base: Forecast, cand: Forecast) -> float:
    r"""The claim statistic of a candidate's forecast against the base model's, on the deviance
    scale of the in-sample score: the Gaussian likelihood ratio of the held-out errors with each
    model's forecast variance unknown (profiled out),

    .. math:: F_c = \frac{n}{\phi_r}\,\log\frac{\mathrm{MSE}_r}{\mathrm{MSE}_c},\qquad
              \phi_r = \frac{1+\rho_r}{1-\rho_r}

    (:math:`\phi_r` from the base forecast errors' lag-1 autocorrelation: forecast errors are
    smooth in time, this counts independent held-out data). Not the plug-in density with the
    measurement sd (:func:`plugin_gain`): a forecast's errors are mostly the unknown future h(t)
    (about 2 sigma on clean twins even with the true parameters), and that density reads a 5 %
    smaller forecast error as a gain of 20 (issue 22's campaign, ``docs/VALIDATION.md`` §4)."""
    return gain(base.n, base.rho, base.rmse, cand.rmse)


def gain(n: int, rho: float, rmse_base: float, rmse_cand: float) -> float:
    """:func:`forecast_gain` from the base forecast's ``n`` and lag-1 ``rho`` and the two RMSEs
    (any one unit)."""
    phi = inflation(rho)
    return float(n / phi * np.log(rmse_base**2 / max(rmse_cand**2, 1e-300)))


def ratio_for_gain(n: int, rho: float, F: float) -> float:
    """The factor by which a candidate must cut the base forecast's RMSE for :func:`gain` to
    reach ``F``: exp(F phi / 2n). Few effective held-out values (smooth errors, a short
    horizon) make a margin out of reach of any candidate."""
    phi = inflation(rho)
    return float(np.exp(F * phi / (2.0 * n)))


def plugin_gain(base: Forecast, cand: Forecast) -> float:
    r""":math:`2(\mathrm{elpd}_c - \mathrm{elpd}_r)/\phi_r` with the plug-in Gaussian density of
    each datum (sd: the measurement's): a supporting figure, not the claim statistic
    (:func:`forecast_gain`)."""
    phi = inflation(base.rho)
    return float(2.0 * (cand.elpd - base.elpd) / phi)


def forecast_share(base: Forecast, cand: Forecast, floor: float) -> float:
    """Share of the base forecast's excess mean square error above ``floor`` sigma that the
    candidate's forecast removes (``<= 1``; negative when it forecasts worse)."""
    ex = base.rmse_sigma**2 - floor**2
    if ex <= 0:
        return 1.0 if cand.rmse_sigma <= base.rmse_sigma else -1.0
    return float(1.0 - max(cand.rmse_sigma**2 - floor**2, 0.0) / ex)
