r"""A daily shadow on the measured spot: obstacles (shrubs, a mast, walls of a street canyon)
keep the direct sun off the ground at the same clock hours every day, while the radiometer, in
the open, records the full net radiation.

.. math::

    q(t) = q_\mathrm{net}(t) - f\,s(t)\,\max(q_\mathrm{net}(t), 0)

- ``s(t)`` is 1 in the shade and 0 in the sun, by the clock: the shadow starts
  ``shade_start`` hours after the record's midday and ends ``shade_end`` hours after it (mod 24;
  both in -12 … 12, a negative value is before midday). A shadow from ``+3.5`` to ``-4`` covers
  the afternoon from 3.5 h after midday, the night and the morning until 4 h before midday: a
  spot that sees the sun only when it stands high over the obstacles around it. A shadow from
  ``+1`` to ``+4`` is one obstacle's in the afternoon. Its edges ramp linearly over one step of
  the record (the solver reads the forcing linearly between the rows).
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


def shade(hours: np.ndarray, start: np.ndarray, end: np.ndarray, ramp: float) -> np.ndarray:
    """1 in the shadow, 0 in the sun, at ``hours`` after midday (n_obs,), for shadows from
    ``start`` to ``end`` (n_sets,) hours after midday (mod 24): the signed distance to the
    shadow's nearer edge, ramped linearly over ``ramp`` hours (n_sets, n_obs)."""
    u = np.mod(hours[None, :] - start[:, None], DAY_H)  # hours since the shadow began
    length = np.mod(end - start, DAY_H)[:, None]
    inside = u < length
    dist = np.where(inside, np.minimum(u, length - u), -np.minimum(u - length, DAY_H - u))
    return np.clip(dist / ramp + 0.5, 0.0, 1.0)


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
            Parameter("shade_end", -4.0, -12.0, 12.0, prior=Uniform(-12.0, 12.0), unit="h",
                      description="the shadow ends, hours after the record's midday"),
            Parameter("shade_fraction", 0.8, 0.0, 1.5, prior=TruncatedNormal(0.8, 0.4),
                      unit="-", description="share of the positive net radiation the shadow "
                      "takes"),
        ]

    def start_values(self, meas, base):
        """A spot in the sun only around midday (three widths), or shaded in the afternoon or
        in the morning."""
        return [{"shade_start": a, "shade_end": b, "shade_fraction": 0.8}
                for a, b in ((2.5, -2.5), (3.5, -3.5), (4.5, -4.5), (1.0, 4.0), (-4.0, -1.0))]

    def surface(self, coeffs, p, model):
        coeffs.q -= self.kept_off(p, model)

    def kept_off(self, p, model) -> np.ndarray:
        """The net radiation the shadow keeps off the spot (n_sets, n_obs), W m-2."""
        meas = model.meas
        hours = np.mod(hour_of_day(meas.time0, meas.t) - record_midday(meas) + 12.0,
                       DAY_H) - 12.0
        step = float(np.median(np.diff(meas.t))) / 3600.0 if meas.t.size > 1 else 1.0
        s = shade(hours, np.asarray(p["shade_start"], float),
                  np.asarray(p["shade_end"], float), max(step, 1.0 / 6.0))
        qp = np.clip(np.asarray(meas.q_net, float), 0.0, None)
        return np.asarray(p["shade_fraction"], float)[:, None] * s * qp[None, :]
