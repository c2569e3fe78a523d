"""ISO 8601 times of the data contract: the one place they are parsed and written.

Times with a UTC offset are converted to UTC; naive times are taken as UTC; written times are
``YYYY-MM-DDTHH:MM:SSZ``.
"""

from __future__ import annotations

from collections.abc import Iterable
from datetime import UTC, datetime, timedelta

import numpy as np

ISO_FORMAT = "%Y-%m-%dT%H:%M:%SZ"


def parse_time(text: str) -> datetime:
    """An aware UTC-comparable datetime from ISO 8601 text (``Z``, an offset, or naive = UTC).

    Raises ``ValueError`` for text that is not ISO 8601.
    """
    stamp = datetime.fromisoformat(str(text).strip())
    return stamp if stamp.tzinfo is not None else stamp.replace(tzinfo=UTC)


def format_time(stamp: datetime | float) -> str:
    """``YYYY-MM-DDTHH:MM:SSZ`` of a datetime or of seconds since the Unix epoch."""
    if not isinstance(stamp, datetime):
        stamp = datetime.fromtimestamp(float(stamp), tz=UTC)
    return stamp.astimezone(UTC).strftime(ISO_FORMAT)


def times_after(time0: str, seconds: Iterable[float]) -> list[str]:
    """ISO times ``time0 + s`` for every ``s`` (seconds)."""
    start = parse_time(time0)
    return [format_time(start + timedelta(seconds=float(s))) for s in seconds]


def seconds_between(stamps: Iterable[str]) -> np.ndarray:
    """Seconds of every ISO time after the first one."""
    parsed = [parse_time(s) for s in stamps]
    return np.array([(s - parsed[0]).total_seconds() for s in parsed])


def hour_of_day(time0: str, t: np.ndarray) -> np.ndarray:
    """UTC clock hour (0-24) at ``time0 + t`` (t in seconds)."""
    start = parse_time(time0)
    h0 = start.hour + start.minute / 60 + start.second / 3600
    return np.mod(h0 + np.asarray(t, float) / 3600.0, 24.0)


def daily_peak_hour(hours_utc: np.ndarray, values: np.ndarray) -> float | None:
    """UTC clock hour (0-24) at which the 24 h harmonic of ``values`` peaks (their finite
    entries, at UTC clock hours ``hours_utc``); None when nothing is finite."""
    v = np.asarray(values, float)
    ok = np.isfinite(v)
    if not ok.any():
        return None
    w = 2.0 * np.pi * np.asarray(hours_utc, float)[ok] / 24.0
    c, s = np.sum(v[ok] * np.cos(w)), np.sum(v[ok] * np.sin(w))
    return float(np.mod(np.arctan2(s, c) * 24.0 / (2.0 * np.pi), 24.0))
