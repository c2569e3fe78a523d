"""What a new user tripped over (a review of 29 Nov 2026), each refused with one line and exit
code 2, nothing written: values outside a parameter's bounds (a traceback in ``simulate`` and
``sensitivity``, minutes of sampling at the bounds in ``fit``), ``vary = false`` without a value
(fixed silently at the paper's pavement value), an h piece with no data, ``--out`` into a
folder of other files, a report into a folder that does not exist, ``diagnose`` of a folder
that is not a run, and a run read against data edited since it was fitted. Also: ``--set``
before the case file no longer swallows it, and ``compare`` warns when runs were fitted to
different sensor data."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from pavement_mcmc.cli import main
from pavement_mcmc.data import load_case
from pavement_mcmc.parameters import parameter_values
from pavement_mcmc.posterior import build_problem

REPO = Path(__file__).resolve().parents[2]
CASE = str(REPO / "runs" / "caseA.toml")


def _err(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    return err


@pytest.mark.parametrize("argv, message", [
    (["simulate", CASE, "--set", "C=-5"], "-5 is outside C's bounds"),
    (["sensitivity", CASE, "--set", "kappa=-1"], "-1 is outside kappa's bounds"),
    (["simulate", CASE, "--set", "parameters.h.value=-10"], "-10 is outside h_1's bounds"),
    (["simulate", CASE, "--set", "parameters.kappa.vary=false"], "vary = false needs a value"),
    (["simulate", CASE, "--set", "model.h.edges_hours=[0,6,28,40]"], "h_3 (28-40 h) holds no"),
])
def test_impossible_values_are_refused_in_one_line(argv, message, tmp_path, capsys):
    assert main([*argv, "--out", str(tmp_path / "o")]) == 2
    assert message in _err(capsys)
    assert not (tmp_path / "o").exists()


def test_fit_refuses_a_start_outside_the_bounds_before_writing(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["fit", CASE, "--set", "kappa=-1", "--out", str(out)]) == 2
    assert "outside kappa's bounds" in _err(capsys) and not out.exists()


def test_parameter_values_refuse_out_of_bounds_overrides():
    space = build_problem(load_case(CASE)).space
    assert parameter_values(space, {"kappa": 1.3})["kappa"] == 1.3
    with pytest.raises(ValueError, match="outside h_1's bounds"):
        parameter_values(space, {"h": -1.0})


def test_set_before_the_case_file_leaves_the_case_file_alone(tmp_path, capsys):
    """argparse's nargs='+' took the case file as one more NAME=VALUE ('case is required')."""
    assert main(["simulate", "--set", "kappa=1.3", "C=1.0e6", CASE, "--out", str(tmp_path), "--json"]) == 0
    assert '"kappa": 1.3' in capsys.readouterr().out


def test_out_into_a_folder_of_other_files_is_refused(tmp_path, capsys):
    keep = tmp_path / "keep.txt"
    keep.write_text("mine")
    assert main(["fit", CASE, "--out", str(tmp_path)]) == 2
    assert "not a run" in _err(capsys)
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]
    own = tmp_path / "case.toml"  # the user's own case file there: not a run either
    text = Path(CASE).read_text().replace("../data/", f"{REPO}/data/")
    own.write_text(text)
    assert main(["fit", str(own), "--out", str(tmp_path), "--overwrite"]) == 2
    assert "not a run" in _err(capsys) and own.read_text() == text


def test_report_into_a_missing_folder_and_diagnose_of_a_non_run(tiny_run, tmp_path, capsys):
    assert main(["report", str(tiny_run), "--out", str(tmp_path / "nowhere" / "r.html")]) == 2
    assert "no folder" in _err(capsys)
    (tmp_path / "plain").mkdir()
    assert main(["diagnose", str(tmp_path / "plain")]) == 2
    assert _err(capsys).startswith("pavement-mcmc diagnose: error:")


def test_a_run_is_not_read_against_edited_data(tmp_path, capsys):
    data = tmp_path / "measurements.csv"
    shutil.copy(REPO / "data" / "reference_case" / "measurements.csv", data)
    case = tmp_path / "case.toml"
    case.write_text(Path(CASE).read_text().replace("../data/reference_case/measurements.csv",
                                                   "measurements.csv").replace(
        'truth = "../data/reference_case/truth.json"', ""))
    run = tmp_path / "run"
    assert main(["fit", str(case), "--out", str(run), "--set", "sampler.kind=emcee",
                 "sampler.max_steps=20", "sampler.n_walkers=12"]) in (0, 1)
    capsys.readouterr()
    assert main(["diagnostics", str(run)]) == 0
    lines = data.read_text().splitlines()
    cells = lines[10].split(",")
    cells[-2] = f"{float(cells[-2]) + 0.5:.3f}"
    lines[10] = ",".join(cells)
    data.write_text("\n".join(lines) + "\n")
    for cmd in ("diagnostics", "report", "diagnose"):
        assert main([cmd, str(run)]) == 2
        assert "the data changed since this run was fitted" in _err(capsys)


def test_compare_warns_when_the_sensor_data_differ(capsys):
    from pavement_mcmc.criticism.guards import same_data

    full = build_problem(load_case(CASE))
    short = build_problem(load_case(CASE, {"data": {"window_hours": [0, 20]}}))
    assert same_data([("a", full), ("b", full)]) is None
    g = same_data([("a", full), ("b", short)])
    assert g is not None and "b (#2)" in g.text
