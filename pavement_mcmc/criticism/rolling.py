r"""Next-day forecasts day after day over a long record: does a law forecast better than the
base model more often than chance?

One held-out day is a weak test on a field record: its forecast errors are smooth (lag-1 0.8–0.96
on the two shared records), so a day of 48 rows counts as 3–9 independent data and no model
reaches the criticism's margin on it (``docs/VALIDATION.md`` §5). A record of many days gives many
such tests. For each *origin* (every ``step`` hours from ``start``) both cases are cut to a window
of ``window + horizon`` hours, fitted by MAP on its first ``window`` hours and forecast for the
``horizon`` hours after it from the forcing alone (:func:`~.forecast.forecast`: the future h(t)
of a per-interval base model by its clock-hour mean, a law's parameters as fitted, a daily
coefficient by its last fitted day). Per day: the two forecast RMSEs and the forecast gain F of
the criticism (:func:`~.forecast.gain`, n/φ from the base errors' lag-1).

The statistic is the **count of days** on which the law forecasts better (a lower RMSE; a tie
is not a win), judged by the one-sided sign test against a fair coin: a law no better than the
base wins at most half the days. Per-day F values do not share a scale across records (n/φ per
day about 140 on the clean twins of ``benchmarks/rolling_null.py``, 3–7 on the grass record), so
their sum is reported, not tested. The law is **named** when the sign test's p ≤ :data:`LEVEL`
and the summed F is positive. Consecutive origins share training data; the held-out days do not
overlap (the step is at least the horizon), and the test treats them as independent. On the
twins the law wins 2 of 15 days in the median (clean h) and 4 of 15 (the true law as the base),
so there the coin is a conservative null: ``benchmarks/rolling_null.py`` gives the false-naming
rates, not the level at a true 50/50 null.

What the count credits: everything the law's case has that the base's has not. A law case that
also adds a ground or sensor effect (:data:`~.ground.GROUND_HOOKS`: ``two_layer``, a sensor's
bias...) is credited for both, so the result lists those (:attr:`Rolling.also_added`) and the
verdict gives the command that tests the surface law alone: the base with the same ground
effects. On the SoilVUE desert the energy balance with a shadow wins 19 of 27 July days against
the one-layer base, 13 of 27 against the base with ``two_layer`` (``docs/VALIDATION.md`` §5).
**Starts.** Each window's MAP refit starts from the case's values, from the previous window's
fit and from every extension's ``start_values``, and keeps the lowest training objective
(:func:`fit_starts`). From the case's values alone (``one_start``) the desert base
``desert.toml+two_layer`` stopped on 16 of the 43 windows from 15 August at an in-sample RMSE
of 0.63–1.45 °C where these starts reach 0.06–0.28 °C (objective 60 948 against 765 on the
window of 10 September), and a soil-water law was named on 30 of the 43 days; from these
starts it wins 22 (``docs/VALIDATION.md`` §5): the count had credited the law with days on
which the base's fit failed, not its forecast. More starts lower the chance of such a failure,
they do not rule it out: a window where one side fits in sample at more than
:data:`FIT_RATIO` times the other's RMSE is marked in the table (``fit?``) and counted in the
verdict, so a reader can look at it.

**A still record.** Without a wind column the Priestley–Taylor balance's sensible heat is one
transfer coefficient (:mod:`~pavement_mcmc.physics.catalogue.energy`, the no-wind fallback),
and its forcing, the net radiation and the air temperature, is the base's: with no latent heat
it *is* the base with h(t) held constant. Against a free h(t), carried to the next day by its
clock-hour mean, it can forecast better only by having fewer parameters, not by knowing a
forcing the base does not. On 20 still twins whose truth is exactly that law
(``benchmarks/rolling_null.py --still``: h constant, no wind column, no latent heat; 18 days,
15 windows) the rule named it on 3 (95 %: 3-38 %): the law won 8-12 days of 15 (median 10,
197 of all 300 days), its forecasts within about 1 % of the free h(t)'s. At that rate a sign
test at 0.05 names it over 15, 27 and 43 days with probability 0.19, 0.39 and 0.60. Where the
base has a free h(t), one value per interval, and the law is ``energy_balance_window`` with
nothing else at the surface (ground effects aside) on a windless record, and the law's case
fits no stream the base's does not (:attr:`Rolling.windless`), a verdict that does not name
it gives these figures for its own number of days. A law that reads more (the humidity, the
soil water, a shadow, a canopy, one α a day, the IR) is not covered by them.

Observation streams the law's case fits and the base's does not (the infrared surface
temperature of ``runs/grass_energy.toml``) are listed too (:attr:`Rolling.also_observed`): both
forecasts are scored on the buried sensors alone, but the law's parameters have more data.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.stats import binom
from threadpoolctl import threadpool_limits

from ..data import ConfigError, record_times
from ..data.times import format_time, parse_time, seconds_between
from ..physics.catalogue.energy import EnergyBalanceWindow
from ..posterior.problem import case_measurements
from .forecast import forecast_from_starts, gain
from .ground import ground_extensions
from .point import case_config, case_problem

#: one-sided level of the sign test that names the law
LEVEL = 0.05
#: a window where one side's in-sample RMSE is more than this many times the other's is marked
#: (module doc, *Starts*): a law fits 2-3x a free h(t) on the desert's windows, a failed MAP 5-10x
FIT_RATIO = 5.0
#: days the balance won, of all days, on the still twins where it is the truth (module doc)
STILL_WON, STILL_DAYS = 197, 300
#: window (fitted) and horizon (forecast) hours, and hours between origins
WINDOW_H, HORIZON_H, STEP_H = 72.0, 24.0, 24.0


@dataclass
class Day:
    """One origin: the window ``[start_h, start_h + window)`` h fitted, the next ``horizon``
    forecast. RMSEs in degC; ``n_phi`` the held-out data's effective count."""

    start_h: float
    time: str
    base_rmse: float
    law_rmse: float
    base_fit: float
    law_fit: float
    F: float
    n_phi: float

    @property
    def law_better(self) -> bool:
        return self.law_rmse < self.base_rmse

    @property
    def fit_suspect(self) -> bool:
        """One side fits its window in sample more than :data:`FIT_RATIO` times worse."""
        lo, hi = sorted((self.base_fit, self.law_fit))
        return hi > FIT_RATIO * lo


@dataclass
class Rolling:
    """Rolling next-day forecasts of a base case and a law (module doc)."""

    base: str
    law: str
    window_h: float
    horizon_h: float
    days: list[Day] = field(default_factory=list)
    #: ground or sensor effects in the law's case and not in the base's (module doc)
    also_added: list[str] = field(default_factory=list)
    #: observation streams the law's case fits and the base's does not (module doc)
    also_observed: list[str] = field(default_factory=list)
    #: the still twins' setting: a free h(t) per interval against energy_balance_window with
    #: nothing else at the surface, on a record without wind (module doc, *A still record*)
    windless: bool = False
    #: the base's case as given (``CASE.toml+ext``), for the command the verdict suggests
    base_case: str = "BASE.toml"

    @property
    def n(self) -> int:
        return len(self.days)

    @property
    def wins(self) -> int:
        return int(sum(d.law_better for d in self.days))

    @property
    def p_value(self) -> float:
        """One-sided sign test: P(at least ``wins`` of ``n`` days | a fair coin)."""
        return float(binom.sf(self.wins - 1, self.n, 0.5)) if self.n else 1.0

    @property
    def F_sum(self) -> float:
        return float(sum(d.F for d in self.days))

    @property
    def named(self) -> bool:
        return self.n > 0 and self.p_value <= LEVEL and self.F_sum > 0

    def medians(self) -> dict[str, float]:
        keys = ("base_rmse", "law_rmse", "base_fit", "law_fit")
        return {k: float(np.median([getattr(d, k) for d in self.days])) for k in keys}

    def verdict(self) -> str:
        m = self.medians()
        how = (f"{self.law} forecasts the next {self.horizon_h:g} h better than {self.base} on "
               f"{self.wins} of {self.n} days (sign test p = {self.p_value:.3f}; median forecast "
               f"RMSE {m['base_rmse']:.3f} → {m['law_rmse']:.3f} °C; F summed {self.F_sum:+.1f})")
        if self.named:
            out = f"named: {how}: the law predicts what the base model's free parameters cannot."
        else:
            out = (f"not named: {how}: not more often than a fair coin at the {LEVEL:g} level"
                   + (", and F summed is not positive" if self.F_sum <= 0 else "") + ".")
        if self.also_added:
            extra = ", ".join(self.also_added)
            out += (f" The law's case also adds {extra} (in the ground or a sensor, not at the "
                    "surface), which the base lacks: the count credits both. To test the surface "
                    f"law alone, give the base the same: {self.base_case}+"
                    + "+".join(self.also_added) + " (with the law case's settings of them).")
        if self.also_observed:
            out += (f" The law's case also fits {', '.join(self.also_observed)}, which the base "
                    "does not: both forecasts are scored on the buried sensors alone, but the "
                    "law's parameters are fitted to these data too, so the count credits them "
                    "as well.")
        if self.windless and not self.named:
            rate = STILL_WON / STILL_DAYS
            need = next((k for k in range(self.n + 1) if binom.sf(k - 1, self.n, 0.5) <= LEVEL),
                        None)  # None: too few days for the sign test to name anything
            power = 0.0 if need is None else binom.sf(need - 1, self.n, rate)
            out += (" The record has no wind and the law is the balance with one latent-heat "
                    "coefficient and nothing else at the surface: its sensible heat is one "
                    "transfer coefficient and its forcing (the net radiation, the air "
                    "temperature) is the base's; over a dry surface it is the base with h(t) "
                    "held constant, and forecasts better only by having fewer parameters. On "
                    f"still twins where it is exactly the truth it won {STILL_WON} of "
                    f"{STILL_DAYS} days (docs/VALIDATION.md §5); at that rate "
                    + (f"a sign test over {self.n} days names it with probability {power:.2f}"
                       if need is not None else f"{self.n} days are too few for the sign test "
                       "to name it")
                    + f", and {self.wins} or fewer wins have probability "
                    f"{binom.cdf(self.wins, self.n, rate):.3f}.")
        odd = [d for d in self.days if d.fit_suspect]
        if odd:
            won = sum(d.law_better for d in odd)
            out += (f" On {len(odd)} of the {self.n} windows (marked fit?) one side fits in sample "
                    f"more than {FIT_RATIO:g} times worse than the other (the law wins {won} of "
                    "them): a MAP stopped far from its mode would decide those days; look at "
                    "them before trusting the count.")
        return out

    def text(self) -> str:
        lines = [self.verdict(), "",
                 f"{'window start':<22}{'forecast °C: base':>18}{'law':>8}{'fit °C: base':>14}"
                 f"{'law':>8}{'F':>8}{'n/φ':>7}"]
        for d in self.days:
            lines.append(f"{d.time:<22}{d.base_rmse:>18.3f}{d.law_rmse:>8.3f}{d.base_fit:>14.3f}"
                         f"{d.law_fit:>8.3f}{d.F:>+8.1f}{d.n_phi:>7.1f}"
                         + ("  law better" if d.law_better else "")
                         + ("  fit?" if d.fit_suspect else ""))
        m = self.medians()
        lines.append(f"{'median':<22}{m['base_rmse']:>18.3f}{m['law_rmse']:>8.3f}"
                     f"{m['base_fit']:>14.3f}{m['law_fit']:>8.3f}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"base": self.base, "law": self.law, "window_h": self.window_h,
                "horizon_h": self.horizon_h, "n": self.n, "wins": self.wins,
                "p_value": self.p_value, "F_sum": self.F_sum, "named": self.named,
                "level": LEVEL, "medians": self.medians(), "also_added": list(self.also_added),
                "also_observed": list(self.also_observed), "windless": self.windless,
                "fit_suspect": [d.time for d in self.days if d.fit_suspect],
                "days": [dict(vars(d)) for d in self.days]}


def origins(case: str | Path, *, window_h: float = WINDOW_H, horizon_h: float = HORIZON_H,
            step_h: float = STEP_H, start_h: float = 0.0, days: int | None = None) -> list[float]:
    """Window starts (hours from the record's first row) every ``step_h`` from ``start_h``, each
    moved to the first row at or after it, whose window and forecast fit in the record; at most
    ``days`` of them. The forecast days must not overlap (``step_h >= horizon_h``): the sign
    test counts them as separate trials."""
    return _starts(_hours(record_times(_toml(case))), str(case), window_h, horizon_h, step_h,
                   start_h, days)


def _toml(case: str | Path) -> str:
    """The case file of ``CASE.toml+ext``."""
    return str(case).split("+")[0]


def _hours(times: list[str]) -> np.ndarray:
    return seconds_between(times) / 3600.0


def _starts(rows: np.ndarray, case: str, window_h: float, horizon_h: float, step_h: float,
            start_h: float, days: int | None) -> list[float]:
    """:func:`origins` on the record's row hours ``rows``."""
    for name, v in (("window", window_h), ("horizon", horizon_h), ("step", step_h)):
        if not (np.isfinite(v) and v > 0):
            raise ConfigError(f"the {name} must be positive hours, got {v!r}")
    if step_h < horizon_h:
        raise ConfigError(f"a step of {step_h:g} h is shorter than the {horizon_h:g} h forecast: "
                          "the forecast days would overlap (the sign test counts them apart)")
    if not (np.isfinite(start_h) and start_h >= 0):
        raise ConfigError(f"the first window start must be >= 0 h, got {start_h!r}")
    if days is not None and (isinstance(days, bool) or not isinstance(days, int | np.integer)
                             or days < 1):
        raise ConfigError(f"the number of windows must be an integer >= 1, got {days!r}")
    span = float(rows[-1])
    out = []
    for a in np.arange(start_h, span - window_h - horizon_h + 1e-9, step_h):
        a = float(rows[np.searchsorted(rows, a - 1e-6)])  # the row the window starts on
        if a + window_h + horizon_h <= span + 1e-9 and (not out or a > out[-1]):
            out.append(a)
    out = out[:days] if days is not None else out
    if not out:
        raise ConfigError(f"{case}: a {window_h:g} h window and a {horizon_h:g} h forecast from "
                          f"{start_h:g} h do not fit in the {span:g} h record")
    return out


def _window(a: float, window_h: float, horizon_h: float) -> dict:
    return {"data": {"window_hours": [a, a + window_h + horizon_h]}}


def fit_starts(problem, warm: dict[str, float] | None = None) -> list[dict | None]:
    """Where a window's MAP refits start (module doc, *Starts*): the case's values (None), the
    previous window's fit (``warm``) and every extension's ``start_values`` given the current
    estimate (the previous fit over the case's values); a start that sets none of the free
    parameters repeats the first and is dropped."""
    base = {**problem.space.value_dict(), **(warm or {})}
    free = set(problem.space.free)
    ext = [s for e in problem.model.extensions for s in e.start_values(problem.meas, base)
           if free & set(s)]
    return [None, *([warm] if warm else []), *ext]


def _one(case: str, a: float, window_h: float, horizon_h: float, max_nfev: int, built=None,
         warm=None, one_start=False):
    problem, label = built or case_problem(case, _window(a, window_h, horizon_h))
    starts = [None] if one_start else fit_starts(problem, warm)
    fc = forecast_from_starts(problem, starts, origins=[window_h], horizon=horizon_h,
                              max_nfev=max_nfev)
    return fc, fc.fits[-1].rmse, label


def rolling_forecast(base: str | Path, law: str | Path, *, window_h: float = WINDOW_H,
                     horizon_h: float = HORIZON_H, step_h: float = STEP_H, start_h: float = 0.0,
                     days: int | None = None, max_nfev: int = 200, one_start: bool = False,
                     progress: Callable[[int, int, Day], None] | None = None) -> Rolling:
    """Rolling next-day forecasts of two cases over their record (module doc).

    Parameters
    ----------
    base, law : case TOMLs on the same record, ``CASE.toml+ext`` adds extensions (e.g.
        ``runs/grass.toml+energy_balance_window``); their ``window_hours`` are replaced.
    window_h, horizon_h, step_h : fitted hours, forecast hours, hours between window starts.
    start_h, days : the first window start (hours from the record's first row) and the number
        of windows (default: as many as fit).
    max_nfev : least-squares iterations of each MAP refit.
    one_start : fit each window from the case's values alone (the earlier rule, to reproduce
        its figures) instead of from every start of :func:`fit_starts`.
    progress : called as ``progress(i, n, day)`` after each window (library code prints nothing).

    The refits run with one BLAS thread whatever ``OMP_NUM_THREADS`` says (as the command line
    and the fits do, ``runs/threads.py``): BLAS threads fight the compiled solver for the cores
    (a day 1.6x slower on an idle 2-core machine, minutes under load) and change the last
    digits of a refit.
    """
    with threadpool_limits(limits=1, user_api="blas"):
        return _rolling(base, law, window_h, horizon_h, step_h, start_h, days, max_nfev,
                        one_start, progress)


def _rolling(base, law, window_h, horizon_h, step_h, start_h, days, max_nfev, one_start,
             progress) -> Rolling:
    times = record_times(_toml(base))
    starts = _starts(_hours(times), str(base), window_h, horizon_h, step_h, start_h, days)
    # two records fail on their data alone; a bad case or extension when the first window's
    # models are built (which may fit a MAP, for inputs' noise): both before the rolling fits
    first = _window(starts[0], window_h, horizon_h)
    mb, ml = (case_measurements(case_config(c, first)[0]) for c in (base, law))
    same = (record_times(_toml(law)) == times and np.array_equal(mb.depths, ml.depths)
            and np.array_equal(mb.t, ml.t) and np.allclose(mb.T_obs, ml.T_obs, equal_nan=True))
    if not same:
        raise ConfigError(f"{base} and {law} read different records or sensors (their times or "
                          "observed temperatures differ): the two cases must be fitted to the "
                          "same data")
    built = {c: case_problem(c, first) for c in (str(base), str(law))}  # the first window's
    also = _also_added(built[str(base)][0].model, built[str(law)][0].model)
    seen = _also_observed(built[str(base)][0].posterior, built[str(law)][0].posterior)
    windless = not seen and _windless(built[str(base)][0].model, built[str(law)][0].model)
    t0 = parse_time(times[0]).timestamp()
    out, warm = None, {}
    for i, a in enumerate(starts):
        fb, fit_b, label_b = _one(str(base), a, window_h, horizon_h, max_nfev,
                                  built.pop(str(base), None), warm.get("base"), one_start)
        fl, fit_l, label_l = _one(str(law), a, window_h, horizon_h, max_nfev,
                                  built.pop(str(law), None), warm.get("law"), one_start)
        warm = {"base": fb.fits[-1].values(), "law": fl.fits[-1].values()}
        if out is None:
            out = Rolling(label_b, label_l, float(window_h), float(horizon_h), also_added=also,
                          also_observed=seen, windless=windless, base_case=str(base))
        day = Day(start_h=a, time=format_time(t0 + a * 3600.0), base_rmse=fb.rmse,
                  law_rmse=fl.rmse, base_fit=float(fit_b), law_fit=float(fit_l),
                  F=gain(fb.n, fb.rho, fb.rmse, fl.rmse),
                  n_phi=fb.n * (1 - fb.rho) / (1 + fb.rho))
        out.days.append(day)
        if progress is not None:
            progress(i + 1, len(starts), day)
    return out


def _also_added(base_model, law_model) -> list[str]:
    """Names of the ground or sensor extensions of ``law_model`` that ``base_model`` lacks."""
    have = {e.name for e in base_model.extensions}
    return [e.name for e in ground_extensions(law_model) if e.name not in have]


def _windless(base_model, law_model) -> bool:
    """Whether ``base_model`` has a free h(t), one value per interval, and ``law_model`` on a
    record without wind is ``energy_balance_window`` with no other surface effect than the
    base's (ground effects aside; module doc, *A still record*): the still twins' setting."""
    if base_model.replaces_h or not base_model.h_basis.identity or law_model.meas.wind is not None:
        return False
    have = {e.name for e in base_model.extensions} | {e.name for e in ground_extensions(law_model)}
    more = [e for e in law_model.extensions if e.name not in have]
    return len(more) == 1 and type(more[0]) is EnergyBalanceWindow


def _also_observed(base_posterior, law_posterior) -> list[str]:
    """``stream (labels)`` of each observation stream of the law's posterior whose columns the
    base's does not fit."""
    have = {(o.name, lab) for o in base_posterior.streams for lab in o.labels}
    out = []
    for o in law_posterior.streams:
        new = [lab for lab in o.labels if (o.name, lab) not in have]
        if new:
            out.append(f"{o.name} ({', '.join(new)})")
    return out
