r"""Urban-scale comparison (the paper's last section): the standard wind correlation
:math:`h(v) = 4 + 4 v` against the estimated h(t).

Urban energy-balance models usually take the surface heat transfer coefficient from a wind
correlation, :math:`h = 4 + 4 v` (W m-2 K-1, ``v`` in m s-1), with the wind of a nearby
(airport) station. Here the same ground (kappa, C and every other parameter at the posterior
mean, or at each posterior draw) is driven by the same air temperature and net radiation twice:
once with the estimated h(t), once with the correlation. The differences in surface temperature

.. math:: \Delta T_s(t) = T_s^{\mathrm{standard}}(t) - T_s^{\mathrm{estimated}}(t)

and in emitted long-wave radiation

.. math:: \Delta q_{LW}(t) = \varepsilon \sigma_{SB}
          \left[(T_s^{\mathrm{standard}} + 273.15)^4 - (T_s^{\mathrm{estimated}} + 273.15)^4\right]

show what the choice of h does to an urban simulation (paper: more than 2 °C and about
15 W m-2). The wind is taken at the middle of each observation interval (the mean of its ends),
as h is constant on an interval.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..data.checks import DataError
from ..data.times import parse_time
from ..solver import solve

__all__ = ["STEFAN_BOLTZMANN", "UrbanComparison", "compare", "read_wind_csv", "standard_h"]

STEFAN_BOLTZMANN = 5.670374419e-8  # W m-2 K-4
KELVIN = 273.15


def standard_h(wind: np.ndarray, a: float = 4.0, b: float = 4.0) -> np.ndarray:
    """``h = a + b v`` on each observation interval from the wind at the observation times.

    Parameters
    ----------
    wind : (n_obs,) wind speed, m s-1.
    a, b : W m-2 K-1 and W m-3 K-1 s (the standard correlation: 4 and 4).

    Returns
    -------
    (n_obs - 1,) W m-2 K-1.
    """
    v = np.asarray(wind, float)
    return a + b * 0.5 * (v[1:] + v[:-1])


@dataclass(frozen=True)
class UrbanComparison:
    """Surface temperature and long-wave emission with the standard vs the estimated h.

    Attributes
    ----------
    t : (n_obs,) s. T_air, wind : (n_obs,) degC, m s-1 (the wind used in ``4 + 4 v``).
    emissivity : surface emissivity.
    h_standard, h_estimated : (n_obs - 1,) W m-2 K-1 (estimated: at the posterior mean).
    Ts_standard, Ts_estimated : (n_obs,) surface temperature, degC, at the posterior mean.
    dTs : (n_obs,) ``Ts_standard - Ts_estimated``, degC.
    dq_lw : (n_obs,) difference of emitted long-wave radiation, W m-2.
    Ts_band, dTs_band, dq_lw_band : 95 % bands ``(lo, hi)`` over posterior draws, or None.
    max_abs_dTs_band : 2.5 and 97.5 % quantiles over draws of max |dTs|, or None.
    """

    t: np.ndarray
    T_air: np.ndarray
    wind: np.ndarray
    emissivity: float
    h_standard: np.ndarray
    h_estimated: np.ndarray
    Ts_standard: np.ndarray
    Ts_estimated: np.ndarray
    dTs: np.ndarray
    dq_lw: np.ndarray
    Ts_band: tuple[np.ndarray, np.ndarray] | None = None
    dTs_band: tuple[np.ndarray, np.ndarray] | None = None
    dq_lw_band: tuple[np.ndarray, np.ndarray] | None = None
    max_abs_dTs_band: tuple[float, float] | None = None

    def summary(self) -> dict[str, float]:
        """Headline numbers: max |dTs| (degC), max |dq_LW| (W m-2), their times (h), means."""
        i, j = int(np.argmax(np.abs(self.dTs))), int(np.argmax(np.abs(self.dq_lw)))
        out = {
            "max_abs_dTs": float(abs(self.dTs[i])),
            "dTs_at_max": float(self.dTs[i]),
            "time_of_max_dTs_h": float(self.t[i] / 3600),
            "max_abs_dq_lw": float(abs(self.dq_lw[j])),
            "dq_lw_at_max": float(self.dq_lw[j]),
            "time_of_max_dq_lw_h": float(self.t[j] / 3600),
            "mean_dTs": float(np.mean(self.dTs)),
            "mean_dq_lw": float(np.mean(self.dq_lw)),
            "mean_h_standard": float(np.mean(self.h_standard)),
            "mean_h_estimated": float(np.mean(self.h_estimated)),
            "emissivity": self.emissivity,
        }
        if self.max_abs_dTs_band is not None:
            out["max_abs_dTs_q2.5"], out["max_abs_dTs_q97.5"] = self.max_abs_dTs_band
        return out


def _emission(Ts: np.ndarray, eps: float) -> np.ndarray:
    return eps * STEFAN_BOLTZMANN * (np.asarray(Ts) + KELVIN) ** 4


def _surface(model, p: dict[str, np.ndarray], h: np.ndarray | None) -> np.ndarray:
    """Surface temperature (n_sets, n_obs) with the model's own h or ``h`` (n_sets, n_obs-1)."""
    coeffs = model.coefficients(p)
    if h is not None:
        coeffs.h = np.broadcast_to(h, coeffs.h.shape).copy()
    return solve(model.grid, model.forcing, coeffs, scheme=model.scheme)[..., 0]


def compare(
    model,
    values: Mapping[str, float],
    draws: Mapping[str, np.ndarray] | None = None,
    wind: np.ndarray | None = None,
    emissivity: float = 0.95,
    h_override: np.ndarray | None = None,
) -> UrbanComparison:
    """Compare ``h = 4 + 4 v`` with the estimated h(t) for the same ground and forcing.

    Parameters
    ----------
    model : :class:`~pavement_mcmc.physics.Model`.
    values : every parameter -> its posterior mean (floats); gives the estimated h(t) and the
        ground used in both runs.
    draws : optional ``{name: (n_draws,)}`` posterior draws of every parameter (e.g.
        ``space.expand(theta)``), for 95 % bands; each draw is run with its own h and with the
        standard h, all in one batched solve.
    wind : (n_obs,) wind at the observation times, m s-1; default the site's measured wind.
    emissivity : surface emissivity for the long-wave emission.
    h_override : (n_obs - 1,) use this instead of the estimated h (e.g. to check that
        replacing h by ``4 + 4 v`` gives no difference).

    Returns
    -------
    UrbanComparison

    Raises
    ------
    ValueError
        If no wind is available or its length is wrong, or the emissivity is not in (0, 1].
    """
    meas = model.meas
    if wind is None:
        wind = meas.wind
    if wind is None:
        raise DataError("the case has no 'wind' column: pass a wind record (--wind other.csv)")
    wind = np.asarray(wind, float)
    if wind.shape != (meas.n_obs,):
        raise DataError(f"wind has shape {wind.shape}, expected ({meas.n_obs},)")
    if not np.all(np.isfinite(wind)) or np.any(wind < 0):
        raise DataError("wind must be finite and >= 0 m s-1")
    if not 0 < emissivity <= 1:
        raise DataError(f"emissivity must be in (0, 1], got {emissivity}")
    h_std = standard_h(wind)
    p = {k: np.array([float(np.ravel(v)[0])] * 2) for k, v in values.items()}
    h_est = model.coefficients({k: v[:1] for k, v in p.items()}).h[0]
    if h_override is not None:
        h_est = np.asarray(h_override, float)
    Ts = _surface(model, p, np.stack([h_std, h_est]))
    Ts_std, Ts_est = Ts[0], Ts[1]
    dTs = Ts_std - Ts_est
    dq = _emission(Ts_std, emissivity) - _emission(Ts_est, emissivity)
    kw: dict = {}
    if draws is not None:
        d = {k: np.asarray(v, float) for k, v in draws.items()}
        n = len(next(iter(d.values())))
        both = {k: np.concatenate([v, v]) for k, v in d.items()}
        own = model.coefficients(d).h if h_override is None else np.tile(h_est, (n, 1))
        T = _surface(model, both, np.concatenate([np.tile(h_std, (n, 1)), own]))
        Ts_d, dT_d = T[n:], T[:n] - T[n:]
        dq_d = _emission(T[:n], emissivity) - _emission(T[n:], emissivity)
        q = [2.5, 97.5]
        kw = {"Ts_band": tuple(np.percentile(Ts_d, q, axis=0)),
              "dTs_band": tuple(np.percentile(dT_d, q, axis=0)),
              "dq_lw_band": tuple(np.percentile(dq_d, q, axis=0))}
        kw["max_abs_dTs_band"] = tuple(
            float(x) for x in np.percentile(np.max(np.abs(dT_d), axis=1), q))
    return UrbanComparison(meas.t, meas.T_air, wind, float(emissivity), h_std, h_est, Ts_std,
                           Ts_est, dTs, dq, **kw)


def read_wind_csv(path: str | Path, meas) -> np.ndarray:
    """Another station's wind, interpolated (linearly) onto the case's observation times.

    The CSV needs the columns ``time`` (ISO 8601, UTC if no offset; or a number: hours since
    the case's window start) and ``wind`` (m s-1). It must cover the case's window.

    Returns
    -------
    (n_obs,) m s-1.

    Raises
    ------
    ValueError
        Naming the file, column and row of the problem.
    """
    path = Path(path)
    try:
        fh = open(path, newline="", encoding="utf-8")
    except OSError as err:
        raise DataError(f"{path}: cannot read the wind file ({err.strerror})") from None
    with fh:
        reader = csv.DictReader(fh)
        cols = [c.strip() for c in (reader.fieldnames or [])]
        if "time" not in cols or "wind" not in cols:
            raise DataError(f"{path}: needs the columns 'time' and 'wind', found {cols}")
        reader.fieldnames = cols
        t0 = parse_time(meas.time0)
        ts, vs = [], []
        for i, row in enumerate(reader, start=1):
            try:
                v = float(row["wind"])
            except (TypeError, ValueError):
                raise DataError(f"{path}: column 'wind', data row {i}: {row['wind']!r} is not "
                                 "a number (m s-1)") from None
            raw = (row["time"] or "").strip()
            try:
                s = float(raw) * 3600.0
            except ValueError:
                try:
                    s = (parse_time(raw) - t0).total_seconds()
                except ValueError:
                    raise DataError(f"{path}: column 'time', data row {i}: {raw!r} is neither "
                                     "an ISO 8601 time nor hours") from None
            if not np.isfinite(v) or v < 0:
                raise DataError(f"{path}: column 'wind', data row {i}: {v} must be >= 0 m s-1")
            ts.append(s)
            vs.append(v)
    if len(ts) < 2:
        raise DataError(f"{path}: needs at least two rows")
    ts, vs = np.asarray(ts), np.asarray(vs)
    order = np.argsort(ts, kind="stable")
    ts, vs = ts[order], vs[order]
    if ts[0] > meas.t[0] + 1e-6 or ts[-1] < meas.t[-1] - 1e-6:
        span = f"[{ts[0] / 3600:g}, {ts[-1] / 3600:g}] h"
        raise DataError(f"{path}: the wind record {span} does not cover the case window "
                         f"[0, {meas.t[-1] / 3600:g}] h after {meas.time0}")
    return np.interp(meas.t, ts, vs)



