"""The package's one TOML writer (case files of twins, the run folder's ``case.toml``).

Nested dicts of strings, numbers (``nan`` and ``±inf`` included: TOML 1.0 has them), booleans
and lists. Top-level dicts become ``[tables]``; inside a table a dict that holds further dicts
becomes a sub-table (``[parameters.kappa]``) and one that does not an inline table
(``prior = { dist = "truncnormal", mean = 1.5, sd = 0.5 }``), the style of the shipped cases.
:func:`tomllib.loads` of the text gives the document back.
"""

from __future__ import annotations

import json
import math
import re

__all__ = ["to_toml"]

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(key: str) -> str:
    return key if _BARE_KEY.match(key) else json.dumps(key)


def _value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"cannot write {type(value).__name__} {value!r} to TOML")


def _has_tables(d: dict) -> bool:
    return any(isinstance(v, dict) for v in d.values())


def _table(lines: list[str], path: str, table: dict) -> None:
    subtables = {k: v for k, v in table.items() if isinstance(v, dict) and _has_tables(v)}
    if len(subtables) < len(table) or not table:  # no bare header over sub-tables only
        lines.append(f"\n[{path}]")
    lines.extend(f"{_key(k)} = {_value(v)}" for k, v in table.items() if k not in subtables)
    for k, v in subtables.items():
        _table(lines, f"{path}.{_key(k)}", v)


def to_toml(document: dict) -> str:
    """TOML text of ``document`` (see the module docstring for the layout)."""
    lines = [f"{_key(k)} = {_value(v)}" for k, v in document.items() if not isinstance(v, dict)]
    for k, v in document.items():
        if isinstance(v, dict):
            _table(lines, _key(k), v)
    return "\n".join(lines).lstrip("\n") + "\n"
