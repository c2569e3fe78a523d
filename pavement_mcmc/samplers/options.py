"""Typed options: every sampler and move declares its options as a frozen dataclass.

:func:`options_from` builds one from a mapping (a case's ``[sampler.options]`` table, ``--set
sampler.options.X=...`` or a dict in Python), refusing an unknown key with the valid ones listed
and a value of the wrong type with the expected one; an instance passes through unchanged. A
field's ``metadata`` may hold ``choices`` (the valid strings).
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import typing
from collections.abc import Mapping
from typing import Any, TypeVar

T = TypeVar("T")


def options_from(cls: type[T], values: Mapping[str, Any] | T | None, where: str) -> T:
    """An instance of the options dataclass ``cls`` from ``values``.

    Parameters
    ----------
    cls : a dataclass whose fields all have defaults.
    values : None (the defaults), an instance of ``cls`` (returned as is) or a mapping of field
        names to values.
    where : names the table in error messages, e.g. ``"[sampler.options] of sampler 'hmc'"``.

    Raises
    ------
    ValueError
        For an unknown key (with a close-match hint and the valid keys) or a value of the wrong
        type or outside its choices.
    """
    if values is None:
        return cls()
    if isinstance(values, cls):
        return values
    if not isinstance(values, Mapping):
        raise ValueError(f"{where} must be a table of options, got {values!r}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    hints = typing.get_type_hints(cls)
    for key in values:
        if key not in fields:
            close = difflib.get_close_matches(str(key), list(fields), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            valid = ", ".join(fields) or "none"
            raise ValueError(f"{where}: unknown option {key!r}{hint}; valid options: {valid}")
    kwargs = {k: _coerce(v, hints[k], fields[k], f"{where}: option {k!r}") for k, v in values.items()}
    return cls(**kwargs)


def describe(cls) -> str:
    """One line per option: ``name = default``, for ``--help`` texts and error messages."""
    out = []
    for f in dataclasses.fields(cls):
        default = f.default if f.default is not dataclasses.MISSING else "..."
        out.append(f"{f.name} = {default!r}")
    return "; ".join(out)


def _coerce(value: Any, hint: Any, field: dataclasses.Field, where: str) -> Any:
    choices = field.metadata.get("choices")
    args = typing.get_args(hint)
    optional = type(None) in args
    base = [a for a in args if a is not type(None)] if args else [hint]
    if value is None:
        if optional:
            return None
        raise ValueError(f"{where} may not be empty")
    if choices is not None and isinstance(value, str):
        if value not in choices:
            raise ValueError(f"{where} = {value!r}; valid: {', '.join(choices)}")
        return value
    for kind in base:
        if kind is bool and isinstance(value, bool):
            return value
        if kind is int and isinstance(value, int) and not isinstance(value, bool):
            return value
        if kind is float and isinstance(value, int | float) and not isinstance(value, bool):
            if not math.isfinite(value):
                raise ValueError(f"{where} must be finite, got {value!r}")
            return float(value)
        if kind is str and isinstance(value, str):
            return value
        if kind is Any or kind is object:
            return value
    names = " or ".join(getattr(k, "__name__", str(k)) for k in base)
    raise ValueError(f"{where} must be {names}, got {value!r}")
