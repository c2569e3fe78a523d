r"""A daily shadow on the measured spot: obstacles (shrubs, a mast, walls of a street canyon)
keep the direct sun off the ground at the same clock hours every day, while the radiometer, in
the open, records the full net radiation.

.. math::

    q(t) = q_\mathrm{net}(t) - f\,s(t)\,\max(q_\mathrm{net}(t), 0)

- ``s(t)`` is 1 in the shade and 0 in the sun, by the clock: the shadow starts
  ``shade_start`` hours after the record's midday (-12 … 12, a negative value is before midday)
  and lasts ``shade_length`` hours (0 … 24, through midnight if need be). A shadow starting at
  ``+3.5`` and lasting 16.5 h covers the afternoon from 3.5 h after midday, the night and the
  morning until 4 h before midday: a spot that sees the sun only when it stands high over the
  obstacles around it. One starting at ``+1`` and lasting 3 h is one obstacle's in the
  afternoon. Its edges ramp linearly over one step of the record (the solver reads the forcing
  linearly between the rows). A length, not an end hour: with an end hour a shadow of 24 h and
  none were neighbours (the end just before or just after the start), and the misfit jumped
  between them; in length the shadow grows continuously from none (0) to all day (24).
- The record's **midday** is the clock time of the daily harmonic's peak of ``q_net`` over the
  whole file the window was cut from (:func:`record_midday`): solar noon, give or take the
  radiometer's footprint, so the hours do not depend on the time zone or the longitude, and a
  fit, its training part and the forecast of the next day keep the same hours. The sun's path
  changes slowly, so the edges hold for days or a few weeks, not a season.
- ``f`` (``shade_fraction``) is the share of the positive net radiation the shadow takes: the
  direct beam's share of the short-wave, about 0.7-0.9 under a clear sky. Above 1 the shaded
  spot loses long-wave as it does at night (up to 1.5).

Fitted MAP and posterior values are reported with these units; the forecast of a day the fit has
not seen keeps the same hours. The shadow acts on the flux into the ground of any model: with
the free h(t) it competes with h for the same daily pattern (a free h per interval absorbs much
of a shadow), with ``energy_balance`` it does not. Not a candidate of the criticism's ranking
(named with ``--add shading``, like ``energy_balance``).
"""

from __future__ import annotations

import numpy as np

from ...data.times import daily_peak_hour, hour_of_day
from ...parameters import Parameter
from ...parameters.priors import TruncatedNormal, Uniform
from ..base import Extension
from ..registry import register_extension

DAY_H = 24.0


def record_midday(meas) -> float:
    """UTC clock hour (0-24) at which the daily harmonic of ``q_net`` peaks: over the whole file
    the window was cut from (``meas.midday``, so a fit, its training part and its forecast keep
    the same hours), else over the window."""
    if getattr(meas, "midday", None) is not None:
        return float(meas.midday)
    return daily_peak_hour(hour_of_day(meas.time0, meas.t), meas.q_net)


def shade(hours: np.ndarray, start: np.ndarray, length: np.ndarray, ramp: float) -> np.ndarray:
    """The share of the hour around ``hours`` after midday (n_obs,) spent in the shadow, for
    shadows that start ``start`` hours after midday and last ``length`` hours (n_sets,; 0 … 24),
    every day: the daily shadow averaged over a window of ``ramp`` hours, so its edges ramp
    linearly over ``ramp`` (n_sets, n_obs). Continuous in both: a shadow of no length shades
    nothing, one of 24 h everything."""
    length = np.clip(np.asarray(length, float), 0.0, DAY_H)[:, None]

    def shaded_until(x):  # hours of shadow from the start of the first shadow to x
        return np.floor(x / DAY_H) * length + np.minimum(np.mod(x, DAY_H), length)

    u = hours[None, :] - np.asarray(start, float)[:, None]  # hours since a shadow began
    return np.clip((shaded_until(u + 0.5 * ramp) - shaded_until(u - 0.5 * ramp)) / ramp, 0.0, 1.0)


@register_extension
class Shading(Extension):
    """A shadow at the same clock hours every day takes ``shade_fraction`` of the positive net
    radiation off the measured spot (see the module docstring)."""

    name = "shading"
    hint = ("the ground warms later in the morning or cools earlier in the afternoon than the "
            "net radiation says, at the same clock hours every day")
    candidate = False  # named with --add; its twins are the off-catalogue `shading` ones
    signals = ("corr:tod_sin", "corr:tod_cos", "corr:q_net")

    def parameters(self, meas):
        if getattr(meas, "T_top", None) is not None:
            raise ValueError(f"{self.name} acts on the surface energy balance, but a measured top "
                             "has none (its top node is a buried sensor): the shadow's "
                             "parameters would not enter the likelihood")
        q = getattr(meas, "q_net", None)
        if q is None:
            raise ValueError(f"{self.name} needs the net radiation (a 'q_net' column, W m-2)")
        if not np.any(np.asarray(q, float) > 0.0):
            raise ValueError(f"{self.name}: q_net is never positive in the window: a shadow "
                             "takes a share of the positive net radiation, there is none")
        return [
            Parameter("shade_start", 4.0, -12.0, 12.0, prior=Uniform(-12.0, 12.0), unit="h",
                      description="the shadow begins, hours after the record's midday"),
            Parameter("shade_length", 16.0, 0.0, DAY_H, prior=Uniform(0.0, DAY_H), unit="h",
                      description="the shadow lasts, hours (through midnight if need be)"),
            Parameter("shade_fraction", 0.8, 0.0, 1.5, prior=TruncatedNormal(0.8, 0.4),
                      unit="-", description="share of the positive net radiation the shadow "
                      "takes"),
        ]

    def start_values(self, meas, base):
        """A spot in the sun only around midday (three widths), or shaded in the afternoon or
        in the morning."""
        return [{"shade_start": a, "shade_length": n, "shade_fraction": 0.8}
                for a, n in ((2.5, 19.0), (3.5, 17.0), (4.5, 15.0), (1.0, 3.0), (-4.0, 3.0))]

    def surface(self, coeffs, p, model):
        coeffs.q -= self.kept_off(p, model)

    def kept_off(self, p, model) -> np.ndarray:
        """The net radiation the shadow keeps off the spot (n_sets, n_obs), W m-2."""
        meas = model.meas
        hours = np.mod(hour_of_day(meas.time0, meas.t) - record_midday(meas) + 12.0,
                       DAY_H) - 12.0
        step = float(np.median(np.diff(meas.t))) / 3600.0 if meas.t.size > 1 else 1.0
        s = shade(hours, np.asarray(p["shade_start"], float),
                  np.asarray(p["shade_length"], float), max(step, 1.0 / 6.0))
        qp = np.clip(np.asarray(meas.q_net, float), 0.0, None)
        return np.asarray(p["shade_fraction"], float)[:, None] * s * qp[None, :]
