"""The package's one TOML writer (:mod:`pavement_mcmc.data.toml_writer`): what it writes,
:mod:`tomllib` reads back — nan and ±inf, nested tables at every depth, quoted keys."""

from __future__ import annotations

import math
import tomllib

import pytest

from pavement_mcmc.data.toml_writer import to_toml


def test_nan_inf_and_nested_tables_round_trip():
    doc = {
        "name": "x",
        "top_nan": float("nan"),
        "data": {"csv": "/a b/c.csv", "sigma": 0.25, "window_hours": [0, 28], "empty": {}},
        "parameters": {
            "kappa": {"value": 1.2, "upper": float("inf"), "lower": float("-inf"),
                      "prior": {"dist": "truncnormal", "mean": 2.27, "sd": float("nan")}},
            "T_2.5cm": {"value": 1e-7, "deep": {"deeper": {"x": [1.5, float("inf")]}}},
        },
        "flags": {"on": True, "off": False, "list_of_tables": [{"a": 1}, {"b": "é"}]},
        "no_keys": {},
    }
    back = tomllib.loads(to_toml(doc))
    assert math.isnan(back.pop("top_nan"))
    kappa = back["parameters"]["kappa"]
    assert kappa["upper"] == math.inf and kappa["lower"] == -math.inf
    assert math.isnan(kappa["prior"].pop("sd"))
    assert back["parameters"]["T_2.5cm"]["deep"]["deeper"]["x"] == [1.5, math.inf]
    doc.pop("top_nan")
    doc["parameters"]["kappa"]["prior"].pop("sd")
    assert back == doc


def test_unicode_and_dotted_keys_are_quoted():
    doc = {"héat": 1, "a.b": {"c d": 2}, "": 3}
    assert tomllib.loads(to_toml(doc)) == doc


def test_a_value_toml_cannot_hold_is_refused():
    with pytest.raises(TypeError, match="cannot write NoneType"):
        to_toml({"a": None})
