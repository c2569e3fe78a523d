r"""A dew point estimated from the air temperature, for a record without a humidity series.

FAO-56 (Allen et al. 1998, eq. 48 and Annex 6): where humidity is not measured, the dew point
is about the day's minimum air temperature, since the air near the ground cools at night to
about its dew point; over arid or semi-arid ground the night air stays drier, and the dew point
lies 2-4 K below the minimum. So

.. math:: T_d(t) = \min_{|t' - t| \le 12\,\mathrm{h}} T_a(t') - \Delta,

the minimum over the 24 h centred on each time (no calendar day, so no time zone is needed),
:math:`\Delta` = ``[data] dew_below_tmin`` (K, >= 0), taken over the whole record, so a time's
dew point does not depend on the window it is read in (a window, a rolling window a day
later, a forecast's longer one); only at the record's own ends does the 24 h shrink to what
the record holds. The estimate becomes the record's
``T_dew`` extra (degC), which the Penman–Monteith energy balance
(:mod:`pavement_mcmc.physics.catalogue.penman`) reads when there is no ``RH``. It is an
estimate: it misses humid days after dry nights and dry air advected by day; where the record
measures ``RH`` or ``T_dew`` the option is refused.
"""

from __future__ import annotations

from dataclasses import replace
from types import MappingProxyType

import numpy as np

from .checks import DataError
from .times import parse_time

__all__ = ["HALF_WINDOW", "dew_from_tmin", "with_dew_from_tmin"]

#: half the window of the running minimum, s
HALF_WINDOW = 12 * 3600.0


def dew_from_tmin(t: np.ndarray, T_air: np.ndarray, below: float = 0.0) -> np.ndarray:
    """Dew point (n_obs,), degC: the minimum of ``T_air`` within 12 h of each time ``t`` (s),
    less ``below`` (K). Missing air temperatures (NaN) are skipped; NaN where all are."""
    t = np.asarray(t, float)
    T = np.asarray(T_air, float)
    lo = np.searchsorted(t, t - HALF_WINDOW, side="left")
    hi = np.searchsorted(t, t + HALF_WINDOW, side="right")
    low = [T[a:b][np.isfinite(T[a:b])] for a, b in zip(lo, hi, strict=True)]
    return np.array([x.min() if x.size else np.nan for x in low]) - float(below)


def with_dew_from_tmin(meas, below: float, stamps: np.ndarray, T_air: np.ndarray):
    """``meas`` with a ``T_dew`` extra estimated by :func:`dew_from_tmin` over the whole
    record (``stamps``, s since the epoch, and ``T_air`` of every row:
    :func:`~.record.record_air_temperature`) at the window's times (a DataError if the record
    measures its humidity). Where the record has no air temperature within 12 h the dew point
    is NaN, and the Penman–Monteith law refuses the window if it is used (a measured-top case
    with gaps in its air temperature, which needs none, still loads)."""
    have = [k for k in ("RH", "T_dew") if k in meas.extras]
    if have:
        raise DataError(f"{meas.source}: dew_below_tmin estimates the humidity, but the record "
                        f"measures it ({', '.join(have)}): drop dew_below_tmin to use it")
    start = parse_time(meas.time0).timestamp()
    rows = np.searchsorted(stamps, start + meas.t - 0.5)
    if np.any(rows >= stamps.size) or np.any(np.abs(stamps[np.minimum(rows, stamps.size - 1)]
                                                 - (start + meas.t)) > 0.5):
        raise DataError(f"{meas.source}: the window's times are not rows of the record")
    dew = dew_from_tmin(stamps - stamps[0], T_air, below)[rows]
    dew.flags.writeable = False
    return replace(meas, extras=MappingProxyType({**meas.extras, "T_dew": dew}))
