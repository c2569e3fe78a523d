"""Tests for pavement_mcmc.data: case TOML loading, validation and overrides."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from pavement_mcmc.data import (
    DATA_KEYS,
    GRID_DEFAULTS,
    SAMPLER_DEFAULTS,
    SECTIONS,
    ConfigError,
    DataError,
    dump_config,
    load_case,
    merge_overrides,
    parse_set,
)

ROOT = Path(__file__).resolve().parents[2]
RUNS = ROOT / "runs"
REFERENCE = ROOT / "data" / "reference_case"


def write_case(tmp_path: Path, body: str, csv: str | None = None) -> Path:
    """A case TOML in tmp_path/cfg/ pointing at a copy of the reference CSV in tmp_path/data/."""
    (tmp_path / "data").mkdir(exist_ok=True)
    (tmp_path / "cfg").mkdir(exist_ok=True)
    shutil.copy(REFERENCE / "measurements.csv", tmp_path / "data" / "m.csv")
    csv = csv if csv is not None else "../data/m.csv"
    path = tmp_path / "cfg" / "case.toml"
    path.write_text(f'[data]\ncsv = "{csv}"\nsigma = 0.25\n' + body)
    return path


def error_for(path: Path, *parts: str, **kwargs) -> str:
    with pytest.raises(ConfigError) as info:
        load_case(path, **kwargs)
    msg = str(info.value)
    assert str(path) in msg, msg
    for part in parts:
        assert part in msg, f"{part!r} not in {msg!r}"
    return msg


# --------------------------------------------------------------------------- shipped cases


@pytest.mark.parametrize(
    ("case", "h"),
    [
        ("caseA", {"kind": "pieces", "edges_hours": [0, 6, 18, 28]}),
        ("caseB", {"kind": "pieces", "edges_hours": [0, 6, 24, 28]}),
        ("caseC", {"kind": "per_interval", "smooth": True}),
    ],
)
def test_shipped_cases_load(case, h):
    cfg = load_case(RUNS / f"{case}.toml")
    assert cfg.name == case
    assert cfg.path == (RUNS / f"{case}.toml").resolve()
    assert cfg.model["h"] == h and cfg.model["extensions"] == []
    m = cfg.measurements
    assert m.n_obs == 113 and m.n_sensors == 5 and m.sigma == 0.25
    assert m.bottom_depth == pytest.approx(0.05)
    assert cfg.truth is not None and cfg.truth["kappa"] == 1.31
    p = cfg.parameters
    assert p["kappa"]["prior"] == {"dist": "truncnormal", "mean": 2.27, "sd": 0.1135}
    assert p["C"]["prior"] == {"dist": "truncnormal", "mean": 2.10e6, "sd": 0.021e6}
    if case == "caseC":
        assert p["gamma"]["prior"] == {"dist": "rayleigh", "scale": 2.22}
    else:
        assert p["h"]["prior"] == {"dist": "truncnormal", "mean": 10.0, "sd": 5.0}
    assert cfg.grid == {"kind": "auto", "dx": None, "dt": None, "dx_top": None, "growth": None,
                        "dx_max": None, "scheme": "cn"}
    assert cfg.sampler["seed"] == 1
    json.dumps(cfg.raw)  # JSON-serialisable


def test_defaults_filled(tmp_path):
    cfg = load_case(write_case(tmp_path, ""))
    assert cfg.name == "case"  # the file's stem
    assert cfg.description == ""
    assert cfg.grid == GRID_DEFAULTS
    assert cfg.sampler == SAMPLER_DEFAULTS
    assert cfg.model == {"extensions": [], "h": {"kind": "pieces", "edges_hours": [0.0, 28.0]}}
    assert cfg.parameters == {}
    assert cfg.truth is None and cfg.truth_path is None


def test_accessors_return_copies():
    cfg = load_case(RUNS / "caseA.toml")
    cfg.grid["dx"] = 1.0
    cfg.parameters["kappa"]["prior"]["mean"] = 0.0
    assert cfg.grid["dx"] is None
    assert cfg.parameters["kappa"]["prior"]["mean"] == 2.27


def test_unknown_parameter_and_extension_names_kept(tmp_path):
    body = '[model]\nextensions = ["no_such_thing"]\n[parameters.zeta]\nvalue = 3.0\nvary = false\n'
    cfg = load_case(write_case(tmp_path, body))
    assert cfg.model["extensions"] == ["no_such_thing"]
    assert cfg.parameters["zeta"] == {"value": 3.0, "vary": False}


# --------------------------------------------------------------------------- paths


def test_relative_paths_resolve_against_toml(tmp_path, monkeypatch):
    path = write_case(tmp_path, "")
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    cfg = load_case(Path("..") / "cfg" / "case.toml")
    assert cfg.csv_path == (tmp_path / "data" / "m.csv").resolve()
    assert cfg.measurements.source == str(cfg.csv_path)
    assert cfg.path == path.resolve()


def test_missing_csv_names_tried_path(tmp_path):
    path = write_case(tmp_path, "", csv="../data/missing.csv")
    error_for(path, "data.csv", "file not found", str((tmp_path / "data" / "missing.csv").resolve()))


def test_missing_truth(tmp_path):
    path = write_case(tmp_path, 'truth = "nope.json"\n')
    error_for(path, "data.truth", str((tmp_path / "cfg" / "nope.json").resolve()))


def test_bad_csv_raises_data_error_with_note(tmp_path):
    path = write_case(tmp_path, "observed_cm = [0, 7]\n")
    with pytest.raises(DataError, match="T_7cm") as info:
        load_case(path)
    assert any(str(path) in note for note in info.value.__notes__)


# --------------------------------------------------------------------------- validation


def test_missing_toml(tmp_path):
    error_for(tmp_path / "absent.toml", "not found")


def test_invalid_toml(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("[data\ncsv = 1\n")
    error_for(path, "invalid TOML")


def test_unknown_top_level_key_lists_valid(tmp_path):
    msg = error_for(write_case(tmp_path, "[sampeler]\nseed = 1\n"), "'sampeler'", "'sampler'")
    assert "Valid keys: " + ", ".join(SECTIONS) in msg


def test_unknown_data_key_lists_valid(tmp_path):
    msg = error_for(write_case(tmp_path, "sgima = 1.0\n"), "[data]", "'sgima'", "'sigma'")
    assert ", ".join(DATA_KEYS) in msg


@pytest.mark.parametrize(
    ("body", "section", "key"),
    [
        ("[grid]\ndz = 0.001\n", "[grid]", "'dz'"),
        ("[sampler]\nwalkers = 32\n", "[sampler]", "'walkers'"),
        ("[parameters.kappa]\nmin = 0.0\n", "[parameters.kappa]", "'min'"),
    ],
)
def test_unknown_keys_in_sections(tmp_path, body, section, key):
    error_for(write_case(tmp_path, body), section, key, "Valid keys")


def test_missing_sigma(tmp_path):
    path = tmp_path / "case.toml"
    shutil.copy(REFERENCE / "measurements.csv", tmp_path / "m.csv")
    path.write_text('[data]\ncsv = "m.csv"\n')
    error_for(path, "'sigma'")


@pytest.mark.parametrize(
    ("body", "key"),
    [
        ("[grid]\ndx = -0.001\n", "grid.dx"),
        ('[grid]\ndt = "60"\n', "grid.dt"),
        ("[sampler]\nseed = 1.5\n", "sampler.seed"),
        ("[sampler]\nkind = 3\n", "sampler.kind"),
        ('[model]\nextensions = "two_layer"\n', "model.extensions"),
        ('[model]\nh = { kind = "pieces", edges_hours = [0, 18, 6, 28] }\n', "model.h.edges_hours"),
        ('[model]\nh = "pieces"\n', "model.h"),
        ('[parameters.kappa]\nvalue = "1.3"\n', "parameters.kappa.value"),
        ("[parameters.kappa]\nvary = 1\n", "parameters.kappa.vary"),
        ("[parameters.kappa]\nprior = 2.27\n", "parameters.kappa.prior"),
        ("[parameters.kappa]\nlower = 2.0\nupper = 1.0\n", "lower must be < upper"),
        ("[parameters.kappa]\nprior = { when = 2004-06-06 }\n", "parameters.kappa.prior.dist"),
        ("[parameters.kappa]\nnote = 2004-06-06\n", "'note'"),
        ("[parameters.kappa]\nprior = { dist = 'x', when = 2004-06-06 }\n", "dates and times"),
    ],
)
def test_wrong_types(tmp_path, body, key):
    error_for(write_case(tmp_path, body), key)


@pytest.mark.parametrize(
    "line",
    ['sigma = "0.25"', "window_hours = [0]", "observed_cm = 3", "max_gap_fill = -1", "csv = 3"],
)
def test_wrong_types_in_data(tmp_path, line):
    path = tmp_path / "case.toml"
    lines = {"csv": 'csv = "m.csv"', "sigma": "sigma = 0.25"}
    lines[line.split(" ")[0]] = line
    path.write_text("[data]\n" + "\n".join(lines.values()) + "\n")
    error_for(path, "data." + line.split(" ")[0])


def test_pieces_must_cover_window(tmp_path):
    body = '[model]\nh = { kind = "pieces", edges_hours = [0, 6, 18] }\n'
    error_for(write_case(tmp_path, body), "model.h.edges_hours", "does not cover")


# --------------------------------------------------------------------------- overrides


def test_merge_overrides_is_deep_and_pure():
    base = {"grid": {"dx": 0.005, "dt": 60.0}, "model": {"extensions": ["a"]}}
    out = merge_overrides(base, {"grid": {"dx": 0.001}, "model": {"extensions": ["b"]}})
    assert out == {"grid": {"dx": 0.001, "dt": 60.0}, "model": {"extensions": ["b"]}}
    assert base["grid"]["dx"] == 0.005
    added = merge_overrides(base, {"model": {"extensions": ["a", "b"]}}, append=True)
    assert added["model"]["extensions"] == ["a", "b"]


def test_load_with_overrides():
    over = {"data": {"sigma": 0.3, "window_hours": [0, 20]}, "grid": {"dx": 0.0025}}
    cfg = load_case(RUNS / "caseA.toml", over, additions={"model": {"extensions": ["two_layer"]}})
    assert cfg.measurements.sigma == 0.3
    assert cfg.measurements.t[-1] == 20 * 3600.0
    assert cfg.grid == {"kind": "auto", "dx": 0.0025, "dt": None, "dx_top": None, "growth": None,
                        "dx_max": None, "scheme": "cn"}
    assert cfg.raw["grid"]["dx"] == 0.0025
    assert cfg.model["extensions"] == ["two_layer"]
    assert cfg.model["h"]["edges_hours"] == [0, 6, 18, 28]


def test_bad_override_names_overrides():
    with pytest.raises(ConfigError, match=r"after overrides.*'dz'"):
        load_case(RUNS / "caseA.toml", {"grid": {"dz": 0.001}})


def test_parse_set():
    assert parse_set("grid.dx=0.0025") == {"grid": {"dx": 0.0025}}
    assert parse_set("sampler.kind = mh") == {"sampler": {"kind": "mh"}}
    assert parse_set("data.window_hours=[0, 20]") == {"data": {"window_hours": [0, 20]}}
    assert parse_set('data.columns."T_2.5cm"=T_3cm') == {"data": {"columns": {"T_2.5cm": "T_3cm"}}}
    assert parse_set("parameters.kappa.vary=false") == {"parameters": {"kappa": {"vary": False}}}
    with pytest.raises(ConfigError, match="KEY=VALUE"):
        parse_set("grid.dx")


def test_dump_config_round_trip():
    cfg = load_case(RUNS / "caseC.toml")
    record = json.loads(dump_config(cfg))
    assert record["config"] == cfg.raw
    assert record["data_hash"] == cfg.measurements.data_hash()
    assert record["resolved"]["sampler"] == cfg.sampler
    assert Path(record["csv_path"]) == REFERENCE.resolve() / "measurements.csv"
