"""The review commands end to end on a tiny run: simulate, sensitivity, diagnostics, report,
urban, export; errors go to stderr with exit code 2."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from pavement_mcmc.cli import main

REPO = Path(__file__).resolve().parents[2]
CASE = str(REPO / "runs" / "caseA.toml")


@pytest.fixture(scope="module")
def run_dir(tiny_run):
    return str(tiny_run)


def test_simulate(tmp_path, capsys):
    rc = main(["simulate", CASE, "--set", "kappa=1.3", "C=1.0e6", "h=10", "--out",
               str(tmp_path), "--json"])
    assert rc == 0
    res = json.loads(capsys.readouterr().out)
    assert res["values"]["h_2"] == 10 and res["values"]["kappa"] == 1.3
    assert set(res["rmse"]) == {"0cm", "1cm", "2cm", "3cm", "4cm", "all"}
    with open(tmp_path / "predicted.csv") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["time", "T_0cm", "T_1cm", "T_2cm", "T_3cm", "T_4cm"]
    assert rows[1][0] == "2004-06-06T00:00:00Z" and len(rows) == 1 + 113
    assert (tmp_path / "simulate.png").stat().st_size > 10_000
    assert main(["simulate", CASE, "--set", "h_2=5", "--out", str(tmp_path)]) == 0
    assert "RMSE per sensor" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["--set", "kapa=1.3"], "unknown parameter 'kapa'"),
    (["--set", "kappa=abc"], "not a number"),
    (["--set", "kappa"], "NAME=VALUE"),
])
def test_simulate_errors(argv, message, tmp_path, capsys):
    assert main(["simulate", CASE, *argv, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_simulate_bad_toml(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("name = [unclosed\n")
    assert main(["simulate", str(bad)]) == 2
    assert "invalid TOML" in capsys.readouterr().err


def test_sensitivity(tmp_path, capsys):
    assert main(["sensitivity", CASE, "--set", "kappa=1.3", "C=1e6", "--out", str(tmp_path),
                 "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    ident = res["identifiability"]
    assert ident["names"] == ["kappa", "C", "h_1", "h_2", "h_3"]
    assert ident["condition_number"] > 1 and ident["verdict"]
    assert (tmp_path / "sensitivity.png").exists() and (tmp_path / "identifiability.png").exists()
    assert main(["sensitivity", CASE, "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "condition number" in out and "verdict:" in out


def test_diagnostics(run_dir, capsys):
    assert main(["diagnostics", run_dir]) == 0
    out = capsys.readouterr().out
    for word in ("IACT", "ESS", "R-hat", "Gw rel", "Gw z", "acceptance", "burn-in", "drift",
                 "NOT TRUSTED", "not independent chains"):
        assert word in out, word
    assert main(["diagnostics", run_dir, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["trusted"] is False and res["reasons"] and "kappa" in res["table"]
    assert main(["diagnostics", run_dir + "/nope"]) == 2
    assert "no such run" in capsys.readouterr().err


def test_urban(run_dir, tmp_path, capsys):
    assert main(["urban", run_dir, "--draws", "10", "--out", str(tmp_path / "u.png"),
                 "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["max_abs_dTs"] > 0 and res["max_abs_dq_lw"] > 0
    assert (tmp_path / "u.png").exists()
    wind = tmp_path / "w.csv"
    wind.write_text("time,wind\n0,2\n40,2\n")
    assert main(["urban", run_dir, "--wind", str(wind), "--draws", "0", "--emissivity", "0.9",
                 "--out", str(tmp_path / "u2.png")]) == 0
    assert "max |dT_s|" in capsys.readouterr().out
    assert main(["urban", run_dir, "--wind", str(tmp_path / "missing.csv")]) == 2


def test_report_command(run_dir, tmp_path, capsys, monkeypatch):
    from pavement_mcmc import report

    full = report._figures
    monkeypatch.setattr(report, "_figures", lambda view, n: full(view, n)[:2])  # the full set
    out = tmp_path / "r.html"                                       # is tested in test_report
    assert main(["report", run_dir, "--out", str(out), "--dpi", "30", "--draws", "10"]) == 0
    assert "wrote" in capsys.readouterr().out
    assert "data:image/png;base64," in out.read_text()


def test_export_command(run_dir, tmp_path, capsys):
    pytest.importorskip("arviz")
    assert main(["export", run_dir, str(tmp_path / "x.nc"), "--thin", "20"]) == 0
    assert "log_likelihood" in capsys.readouterr().out
    assert (tmp_path / "x.nc").stat().st_size > 0
