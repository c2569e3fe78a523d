"""Checked overrides of a twin family's :class:`~.simulate.SyntheticSpec` settings.

A family of twins (e.g. :func:`~.corpus.forecast_twins`) sets some settings itself and lets a
caller change others by name; a value given as text (a command line's ``NAME=VALUE``) is read
as the setting's type, so that ``"False"`` is not a true flag and ``"0.5"`` not a string.
"""

from __future__ import annotations

import ast
from collections.abc import Mapping
from dataclasses import MISSING, fields

from .simulate import SyntheticSpec

_DEFAULTS = {f.name: f.default_factory() if f.default is MISSING else f.default
             for f in fields(SyntheticSpec)}
_WORDS = {"true": True, "false": False, "none": None}


def _typed(name: str, value, default):
    """``value`` as the type of ``default`` (text is parsed), or a ValueError."""
    if isinstance(value, str) and not isinstance(default, str):
        text = value.strip()
        try:
            value = _WORDS[text.lower()] if text.lower() in _WORDS else ast.literal_eval(text)
        except (ValueError, SyntaxError):
            raise ValueError(f"spec setting {name}={value!r}: not a "
                             f"{type(default).__name__}") from None
    if default is None or isinstance(value, type(default)):
        return value
    if isinstance(default, float) and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if isinstance(default, tuple) and isinstance(value, list):
        return tuple(value)
    raise ValueError(f"spec setting {name}={value!r}: expected a {type(default).__name__} "
                     f"(default {default!r})")


def spec_overrides(settings: Mapping | None, fixed: tuple[str, ...] = ()) -> dict:
    """``settings`` (name -> value) checked against :class:`SyntheticSpec`: known names, none
    of ``fixed`` (the settings the family sets itself), values of each setting's type. Raises
    ValueError naming the setting and the valid names."""
    out = {}
    for name, value in (settings or {}).items():
        if name not in _DEFAULTS:
            valid = ", ".join(n for n in _DEFAULTS if n not in fixed)
            raise ValueError(f"unknown spec setting {name!r}; valid: {valid}")
        if name in fixed:
            raise ValueError(f"spec setting {name!r} is set by the twin family itself "
                             f"({', '.join(fixed)})")
        out[name] = _typed(name, value, _DEFAULTS[name])
    return out
