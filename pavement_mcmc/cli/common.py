"""Helpers shared by the sub-commands: JSON output, --set parsing, loading runs."""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from ..data.errors import UserError


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
            raise UserError(f"--set expects NAME=VALUE, got {item!r}")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise UserError(f"--set {name}: {value!r} is not a number") from None
    return out


def warn(msg: str) -> None:
    print(f"warning: {msg}", file=sys.stderr)


def add_set_option(p: argparse.ArgumentParser) -> None:
    """``--set NAME=VALUE ...``: parameter values (``h`` sets every h piece); a dotted key
    (``grid.dx=0.0025``) overrides the case config instead."""
    p.add_argument(
        "--set", dest="assign", nargs="+", action="extend", default=[], metavar="NAME=VALUE",
        help="parameter values, e.g. kappa=1.3 C=1.0e6 h=10 (h sets every h piece; for a fit "
             "these are start values, the priors still apply: fix one with "
             "parameters.kappa.vary=false parameters.kappa.value=1.3); dotted keys such as "
             "grid.dx=0.0025 override the case config",
    )


def split_assignments(items: list[str]) -> tuple[dict, dict[str, float]]:
    """Split ``--set`` items into config overrides (dotted keys) and parameter values."""
    from ..data import merge_overrides, parse_set

    overrides: dict = {}
    params = []
    for item in items:
        key = item.partition("=")[0]
        if "." in key:
            overrides = merge_overrides(overrides, parse_set(item))
        else:
            params.append(item)
    return overrides, parse_assignments(params)
