r"""Where the model fails: residual statistics per sensor, against forcing and against depth.

All functions take the residuals ``r = predicted - observed`` (degC) at the observation times
``t[1:]`` (the first row is the initial condition and carries no information) of a fitted
model. Nothing here refits or samples.

Statistics per sensor
---------------------
- RMSE and mean (bias), also in units of sigma;
- lag-1 autocorrelation :math:`\rho_1` and the Ljung–Box portmanteau statistic
  :math:`Q = n(n+2)\sum_{k=1}^{m}\hat\rho_k^2/(n-k)` with its :math:`\chi^2_m` p-value
  (``m = min(10, n/5)``);
- the diurnal (24 h) harmonic: ``a + b t + c cos(wt) + d sin(wt)`` fitted by least squares to
  the measured and to the predicted series; amplitude ratio predicted/measured and phase
  error in hours (positive: the model's wave comes *later* than the measured one);
- the correlation of the residuals with forcing and derived signals (q_net, its daytime part
  q_net+ = max(q_net, 0), wind, T_air - T_s,
  dT_s/dt, rain (decayed with a 3 h memory), the sensor's own temperature, time of day sin/cos),
  with a z-score that uses Bartlett's effective sample size
  :math:`n_\mathrm{eff} = n (1-\rho_x\rho_y)/(1+\rho_x\rho_y)` for two AR(1) series, so that
  smooth series are not over-counted.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ..data.times import hour_of_day as clock_hours

DAY = 86400.0
SIGNALS = ("q_net", "q_net+", "wind", "T_air-T_s", "dT_s/dt", "rain", "T_sensor", "tod_sin", "tod_cos")
#: what each signal is, in the words and units a figure gives it
SIGNAL_LABELS = {"q_net": "net radiation (W m⁻²)", "q_net+": "daytime net radiation (> 0)",
                 "wind": "wind (m s⁻¹)", "T_air-T_s": "air − surface temperature",
                 "dT_s/dt": "surface warming rate", "rain": "rain (mm)",
                 "T_sensor": "the sensor's own temperature", "tod_sin": "time of day (sine)",
                 "tod_cos": "time of day (cosine)"}


def lag1(x: np.ndarray) -> float:
    """Lag-1 autocorrelation of a 1D series (0 for a constant series)."""
    x = np.asarray(x, float) - np.mean(x)
    d = float(x @ x)
    return 0.0 if d == 0 else float(x[1:] @ x[:-1] / d)


def ljung_box(x: np.ndarray, m: int | None = None) -> tuple[float, float]:
    """Ljung–Box statistic and its chi-square p-value over lags 1..m (default min(10, n//5))."""
    x = np.asarray(x, float) - np.mean(x)
    n = x.size
    m = m or max(1, min(10, n // 5))
    d = float(x @ x)
    if d == 0:
        return 0.0, 1.0
    rho = np.array([x[k:] @ x[:-k] / d for k in range(1, m + 1)])
    Q = float(n * (n + 2) * np.sum(rho**2 / (n - np.arange(1, m + 1))))
    return Q, float(stats.chi2.sf(Q, m))


def pooled_lag1(r: np.ndarray) -> float:
    """Mean lag-1 autocorrelation over the columns of ``r`` (n_time, n_series), in [0, 0.98]."""
    r = np.atleast_2d(np.asarray(r, float).T).T
    return float(np.clip(np.mean([lag1(r[:, s]) for s in range(r.shape[1])]), 0.0, 0.98))


def inflation(rho: float) -> float:
    """phi = (1 + rho) / (1 - rho): how many correlated values of lag-1 ``rho`` count as one
    independent value (an AR(1) series' variance inflation of a mean); ``n / phi`` is the
    effective count of ``n`` such values."""
    return (1 + rho) / (1 - rho)


def harmonic(t: np.ndarray, y: np.ndarray, period: float = DAY) -> tuple[float, float]:
    """Amplitude and phase (s, time of the maximum within a period) of the ``period`` harmonic.

    Fits ``a + b t + c cos(wt) + d sin(wt)`` by least squares (the trend keeps a warming or
    cooling spell out of the harmonic).
    """
    w = 2 * np.pi / period
    tt = t - t[0]
    A = np.column_stack([np.ones_like(tt), tt / period, np.cos(w * tt), np.sin(w * tt)])
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    amp = float(np.hypot(coef[2], coef[3]))
    phase = float(np.arctan2(coef[3], coef[2]) / w) % period  # time of the maximum
    return amp, phase


@dataclass
class SensorStats:
    """Residual statistics of one sensor (degC unless stated)."""

    label: str
    depth: float
    rmse: float
    bias: float
    rmse_sigma: float
    bias_sigma: float
    lag1: float
    ljung_box_q: float
    ljung_box_p: float
    amp_obs: float
    amp_pred: float
    amp_ratio: float
    phase_error_h: float
    correlations: dict[str, tuple[float, float]] = field(default_factory=dict)  # r, z

    def to_dict(self) -> dict:
        d = dict(self.__dict__)
        d["correlations"] = {k: {"r": v[0], "z": v[1]} for k, v in self.correlations.items()}
        return d


@dataclass
class ResidualReport:
    """Where the fit fails.

    Attributes
    ----------
    t : (n,) times of the residual rows, s.
    depths : (n_sensors,) m.
    labels : sensor labels.
    residuals : (n, n_sensors) predicted - observed, degC.
    sigma : noise sd, degC.
    whitened : (n, n_sensors) the residuals whitened by the posterior's likelihood
        (:meth:`~pavement_mcmc.posterior.LogPosterior.standardized_residuals`: ``r / sigma``,
        or ``Sigma^(-1/2) r`` when the inputs' noise is integrated out); every "in sigma"
        figure here is read from them.
    sensors : per-sensor :class:`SensorStats`.
    rmse : overall RMSE, degC.
    rho : pooled lag-1 autocorrelation of the residuals.
    signals : the signals used for the correlations, name -> (n,) series.
    """

    t: np.ndarray
    depths: np.ndarray
    labels: list[str]
    residuals: np.ndarray
    sigma: float
    sensors: list[SensorStats]
    rmse: float
    rho: float
    signals: dict[str, np.ndarray]
    whitened: np.ndarray

    @property
    def rmse_sigma(self) -> float:
        """Overall misfit in noise units, ``sqrt(mean(whitened^2))``."""
        return float(np.sqrt(np.mean(self.whitened**2)))

    def structured(self, floor: float = 1.25, lag1_max: float = 0.3, p_min: float = 1e-3) -> bool:
        """True if the residuals show more than the misfit floor (not :func:`noise_like`)."""
        return not noise_like(self, floor, lag1_max, p_min)

    def strongest_correlations(self, z_min: float = 3.0, k: int = 4) -> list[tuple[str, str, float, float]]:
        """The ``k`` strongest (sensor, signal, r, z) with ``|z| >= z_min``, strongest first."""
        rows = [
            (s.label, name, r, z)
            for s in self.sensors
            for name, (r, z) in s.correlations.items()
            if abs(z) >= z_min
        ]
        return sorted(rows, key=lambda x: -abs(x[3]))[:k]

    def to_dict(self) -> dict:
        return {
            "rmse": self.rmse,
            "rmse_sigma": self.rmse_sigma,
            "rho": self.rho,
            "sigma": self.sigma,
            "sensors": [s.to_dict() for s in self.sensors],
            "depth_profile": {
                "depth_m": self.depths.tolist(),
                "rmse": [s.rmse for s in self.sensors],
                "bias": [s.bias for s in self.sensors],
            },
        }


def noise_like(rep: ResidualReport, floor: float = 1.25, lag1_max: float = 0.3, p_min: float = 1e-3) -> bool:
    """Residuals consistent with the misfit floor: overall RMSE within ``floor`` sigma, no sensor
    with RMSE above ``floor + 0.15`` sigma, and no sensor that is both autocorrelated at lag 1
    beyond ``lag1_max`` and rejected by the Ljung–Box test at level ``p_min``."""
    if rep.rmse_sigma > floor:
        return False
    for s in rep.sensors:
        if s.rmse_sigma > floor + 0.15:
            return False
        if s.lag1 > lag1_max and s.ljung_box_p < p_min:
            return False
    return True


def hour_of_day(meas) -> np.ndarray:
    """UTC hour of day of every observation time."""
    try:
        return clock_hours(meas.time0, meas.t)
    except ValueError:
        return np.mod(meas.t / 3600.0, 24.0)


def derived_signals(meas, T_surface: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Forcing and derived signals at every observation time, name -> (n_obs,) array.

    ``T_surface`` is the modelled surface temperature (default: the shallowest sensor). A
    signal with a gap (forcing that a measured top does not need) is left out.
    """
    Ts = meas.T_obs[:, 0] if T_surface is None else np.asarray(T_surface, float)
    out = {"q_net": np.asarray(meas.q_net, float)}
    out["q_net+"] = np.maximum(out["q_net"], 0.0)
    if meas.wind is not None:
        out["wind"] = np.asarray(meas.wind, float)
    out["T_air-T_s"] = meas.T_air - Ts
    out["dT_s/dt"] = np.gradient(meas.T_obs[:, 0], meas.t) * 3600.0
    if meas.rain is not None and np.any(meas.rain > 0):
        wet = np.zeros(meas.n_obs)
        for j in range(meas.n_obs):
            wet[j] = wet[j - 1] * np.exp(-(meas.t[j] - meas.t[j - 1]) / (3 * 3600.0)) if j else 0.0
            wet[j] += meas.rain[j]
        out["rain"] = wet
    hod = hour_of_day(meas)
    out["tod_sin"] = np.sin(2 * np.pi * hod / 24.0)
    out["tod_cos"] = np.cos(2 * np.pi * hod / 24.0)
    return {k: v for k, v in out.items() if np.isfinite(v).all()}  # a gap: no correlation


def _corr(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    x = x - x.mean()
    y = y - y.mean()
    den = np.sqrt((x @ x) * (y @ y))
    if den == 0:
        return 0.0, 0.0
    r = float(x @ y / den)
    rr = np.clip(lag1(x) * lag1(y), -0.98, 0.98)
    n_eff = max(3.0, x.size * (1 - rr) / (1 + rr))
    z = float(np.arctanh(np.clip(r, -0.999, 0.999)) * np.sqrt(n_eff - 3))
    return r, z


def analyse(meas, predicted: np.ndarray, T_surface: np.ndarray | None = None,
            posterior=None) -> ResidualReport:
    """Residual statistics of a prediction.

    Parameters
    ----------
    meas : the :class:`~pavement_mcmc.data.Measurements`.
    predicted : (n_obs, n_sensors) predicted temperatures at the sensors, degC.
    T_surface : (n_obs,) modelled surface temperature (for T_air - T_s); default the
        shallowest sensor's record.
    posterior : the :class:`~pavement_mcmc.posterior.LogPosterior` whose likelihood whitens
        the residuals (its input noise included); default: independent errors of sd
        ``meas.sigma`` (a prediction scored without a fitted problem).

    Returns
    -------
    ResidualReport
    """
    pred = np.asarray(predicted, float)
    obs = meas.T_obs
    r = pred[1:] - obs[1:]
    t = meas.t[1:]
    signals = {k: v[1:] for k, v in derived_signals(meas, T_surface).items()}
    if posterior is None:
        sigma = float(meas.sigma)
        white = r / sigma
    else:
        sigma = float(posterior.sigma)
        white = posterior.standardized_residuals(r[None])[0].reshape(r.shape)
    sensors = []
    for s, (lab, z) in enumerate(zip(meas.sensor_labels, meas.depths, strict=True)):
        rs = r[:, s]
        Q, p = ljung_box(rs)
        a_o, ph_o = harmonic(t, obs[1:, s])
        a_p, ph_p = harmonic(t, pred[1:, s])
        dph = ((ph_p - ph_o + DAY / 2) % DAY - DAY / 2) / 3600.0
        corr = {k: _corr(rs, v) for k, v in signals.items()}
        corr["T_sensor"] = _corr(rs, obs[1:, s])
        rmse = float(np.sqrt(np.mean(rs**2)))
        bias = float(np.mean(rs))
        sensors.append(
            SensorStats(
                label=lab,
                depth=float(z),
                rmse=rmse,
                bias=bias,
                rmse_sigma=float(np.sqrt(np.mean(white[:, s] ** 2))),
                bias_sigma=float(np.mean(white[:, s])),
                lag1=lag1(rs),
                ljung_box_q=Q,
                ljung_box_p=p,
                amp_obs=a_o,
                amp_pred=a_p,
                amp_ratio=a_p / a_o if a_o > 0 else np.nan,
                phase_error_h=float(dph),
                correlations=corr,
            )
        )
    return ResidualReport(
        t=t,
        depths=np.asarray(meas.depths, float),
        labels=list(meas.sensor_labels),
        residuals=r,
        sigma=sigma,
        sensors=sensors,
        rmse=float(np.sqrt(np.mean(r**2))),
        rho=pooled_lag1(r),
        signals=signals,
        whitened=white,
    )


def analyse_point(problem, values: dict[str, float]) -> ResidualReport:
    """:func:`analyse` of the problem's prediction at the parameter ``values`` (by name)."""
    p = {k: np.array([v]) for k, v in _complete(problem, values).items()}
    nodes = problem.model.solve(p)
    pred = problem.model.observe(nodes, p)[0]
    return analyse(problem.meas, pred, nodes[0, :, 0], problem.posterior)


def _complete(problem, values: dict[str, float]) -> dict[str, float]:
    base = problem.space.value_dict()
    base.update({k: float(v) for k, v in values.items() if k in base})
    return base


def plain_signals(rep: ResidualReport, z_min: float = 3.0) -> dict[str, str]:
    """Residual patterns in plain words, keyed by pattern name (only those present).

    Keys: ``depth_growth``, ``phase_lag``, ``amplitude``, ``single_sensor``,
    ``sensor_pattern``, and ``corr:<signal>`` for significant correlations.
    """
    out: dict[str, str] = {}
    S = rep.sensors
    if len(S) >= 3:
        rm = np.array([s.rmse for s in S])
        rho_s = stats.spearmanr(rep.depths, rm)[0] if np.ptp(rm) > 0 else 0.0
        if rho_s > 0.6 and rm[-1] > 1.3 * rm[0] and rm.max() > 1.2 * rep.sigma:
            out["depth_growth"] = (
                f"residuals grow with depth (RMSE {rm[0]:.2f} °C at {S[0].label} -> "
                f"{rm[-1]:.2f} °C at {S[-1].label})"
            )
    deep = S[len(S) // 2 :]
    ph = np.array([s.phase_error_h for s in deep])
    if np.all(np.abs(ph) > 0.15) and np.all(np.sign(ph) == np.sign(ph[0])):
        word = "late" if ph[0] > 0 else "early"
        out["phase_lag"] = (
            f"the modelled daily wave arrives {word} at depth "
            f"({', '.join(f'{s.label}: {s.phase_error_h:+.2f} h' for s in deep)})"
        )
    ratios = np.array([s.amp_ratio for s in S])
    bad = [s for s in S if abs(s.amp_ratio - 1) > 0.05]
    if bad:
        out["amplitude"] = "daily amplitude off: " + ", ".join(f"{s.label} x{s.amp_ratio:.2f}" for s in bad)
    if ratios.size >= 3 and bad:
        signs = np.sign(ratios - 1)
        if np.any(signs[1:] != signs[:-1]) and len(bad) >= 2:
            out["sensor_pattern"] = (
                "amplitude errors alternate in sign between neighbouring "
                "sensors (not a smooth function of depth)"
            )
    b = np.array([abs(s.bias_sigma) for s in S])
    k = int(np.argmax(b))
    others = np.delete(b, k)
    if b[k] > 0.8 and (others.size == 0 or b[k] > 2.0 * np.max(others)):
        out["single_sensor"] = (
            f"one sensor is offset: {S[k].label} mean residual "
            f"{S[k].bias:+.2f} °C ({S[k].bias_sigma:+.1f} σ), the others "
            f"within {np.max(others) if others.size else 0:.1f} σ"
        )
    for lab, name, r, z in rep.strongest_correlations(z_min=z_min, k=6):
        key = f"corr:{name}"
        if key not in out:
            out[key] = f"residuals at {lab} correlate with {name} (r = {r:+.2f}, z = {z:+.1f})"
    return out
