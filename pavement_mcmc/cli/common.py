"""Helpers shared by the sub-commands: JSON output, --set parsing, loading runs."""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np


def add_json_flag(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print the computed figures as JSON")


def emit(args, payload: dict, text: str) -> None:
    """Print ``payload`` as JSON if ``--json`` was given, else the human-readable ``text``."""
    if getattr(args, "json", False):
        print(json.dumps(payload, indent=2, default=_jsonable))
    else:
        print(text)


def _jsonable(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def parse_assignments(items: list[str] | None) -> dict[str, float]:
    """``["kappa=1.3", "C=1e6"]`` -> ``{"kappa": 1.3, "C": 1e6}``, with clear errors."""
    out = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise ValueError(f"--set expects NAME=VALUE, got {item!r}")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise ValueError(f"--set {name}: {value!r} is not a number") from None
    return out


def warn(msg: str) -> None:
    print(f"warning: {msg}", file=sys.stderr)
