"""The units of a batch: windows of one long record and/or many case TOMLs, and their seeds.

A :class:`Unit` is one fit: a case TOML, optionally cut to a window of its record, with a key
that names its run folder. Seeds come from the batch seed and the unit's key alone
(:func:`unit_seed`), so a unit's chain does not depend on the number of workers, the order in
which units run, or which other units are in the batch.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..data import ConfigError, load_case, record_times
from ..data.times import format_time, parse_time, seconds_between

_DURATION = re.compile(r"^\s*([0-9]*\.?[0-9]+)\s*([smhd]?)\s*$")
_SECONDS = {"s": 1.0, "m": 60.0, "h": 3600.0, "d": 86400.0, "": 3600.0}


@dataclass(frozen=True)
class Unit:
    """One fit of a batch.

    Attributes
    ----------
    key : unique name of the unit and of its run folder (``site`` or ``site@start-end h``).
    case : the case TOML (absolute path).
    site : the case's name.
    window_hours : ``(start, end)`` in hours from the record's first row, or None (the case's
        own window).
    start_time : ISO 8601 time of the window's first row ("" if not known).
    overrides : further config overrides of this unit (``--set``-style nested dict).
    """

    key: str
    case: str
    site: str
    window_hours: tuple[float, float] | None = None
    start_time: str = ""
    overrides: dict = field(default_factory=dict, hash=False, compare=False)

    def config_overrides(self, seed: int) -> dict:
        """The unit's overrides: its window and its seed on top of :attr:`overrides`."""
        from ..data import merge_overrides

        ov = merge_overrides(self.overrides, {"sampler": {"seed": int(seed)}})
        if self.window_hours is not None:
            ov = merge_overrides(ov, {"data": {"window_hours": list(self.window_hours)}})
        return ov


def parse_duration(text: str | float, allow_zero: bool = False) -> float:
    """``"24h"``, ``"90m"``, ``"2d"``, ``"3600s"`` or a bare number of hours -> hours; zero
    only with ``allow_zero`` (an offset, not a length)."""
    if isinstance(text, int | float):
        return float(text)
    m = _DURATION.match(str(text))
    if not m or float(m.group(1)) < 0 or (float(m.group(1)) == 0 and not allow_zero):
        kind = "duration >= 0" if allow_zero else "positive duration"
        raise ConfigError(f"not a {kind}: {text!r} (e.g. 24h, 90m, 2d)")
    return float(m.group(1)) * _SECONDS[m.group(2)] / 3600.0


def unit_seed(batch_seed: int, key: str) -> int:
    """A seed in [0, 2**31) from the batch seed and the unit key only (SHA-256, no hash salt)."""
    digest = hashlib.sha256(key.encode("utf-8")).digest()
    words = [int(batch_seed)] + [int.from_bytes(digest[i:i + 4], "little") for i in range(0, 16, 4)]
    return int(np.random.SeedSequence(words).generate_state(1)[0] & 0x7FFFFFFF)


def window_units(case: str | Path, window: str | float | None = None, step: str | float | None = None,
                 windows: list[tuple[float, float]] | None = None,
                 overrides: dict | None = None) -> list[Unit]:
    """Cut one case's record into windows: every ``step`` hours a window ``window`` hours long
    (the last one must fit in the record), or the explicit ``windows`` [(start, end) hours]."""
    case = Path(case).resolve()
    cfg = load_case(case)
    times = record_times(case)
    t = seconds_between(times) / 3600.0
    span = float(t[-1])
    if windows is None:
        if window is None:
            raise ConfigError("give a window length (e.g. --window 24h) or a list of windows")
        w = parse_duration(window)
        s = parse_duration(step) if step is not None else w
        starts = np.arange(0.0, span - w + 1e-9, s)
        if starts.size == 0:
            raise ConfigError(f"{case}: a {w:g} h window does not fit in the {span:g} h record")
        windows = [(float(a), float(a + w)) for a in starts]
    t0 = parse_time(times[0])
    out = []
    for a, b in windows:
        a, b = float(a), float(b)
        if not 0 <= a < b:
            raise ConfigError(f"bad window [{a:g}, {b:g}] h: needs 0 <= start < end")
        start = format_time(t0.timestamp() + a * 3600.0)
        out.append(Unit(f"{cfg.name}@{a:g}-{b:g}h", str(case), cfg.name, (a, b), start,
                        dict(overrides or {})))
    return out


def case_units(cases: str | Path | list, overrides: dict | None = None) -> list[Unit]:
    """One unit per case TOML: a folder (every ``*.toml`` in it, sorted) or a list of files."""
    if isinstance(cases, str | Path):
        p = Path(cases)
        cases = sorted(p.glob("*.toml")) if p.is_dir() else [p]
    out = []
    for c in cases:
        c = Path(c).resolve()
        if not c.is_file():
            raise FileNotFoundError(f"no case file {c}")
        out.append(Unit(c.stem, str(c), c.stem, None, "", dict(overrides or {})))
    return out


def check_unique(units: list[Unit]) -> list[Unit]:
    """Refuse two units with one key (they would share a run folder)."""
    seen: dict[str, int] = {}
    for u in units:
        seen[u.key] = seen.get(u.key, 0) + 1
    dup = sorted(k for k, n in seen.items() if n > 1)
    if dup:
        raise ConfigError(f"units with the same key (same case name and window): {dup}")
    return units
