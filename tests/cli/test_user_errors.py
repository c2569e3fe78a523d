"""Issue 11, item 5: errors name the right file, runs that are missing or empty get a clear
message, and cli.main shows a bug (not a user error) with its traceback."""

from __future__ import annotations

import pytest
from conftest import REPO

from pavement_mcmc.cli import main


def _err(capsys, argv) -> tuple[int, str]:
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().err


@pytest.mark.parametrize("command", [["report"], ["diagnostics"], ["urban"], ["export"]])
def test_case_file_given_for_a_run_names_that_file(command, tmp_path, capsys):
    extra = [tmp_path / "x.nc"] if command == ["export"] else []
    code, err = _err(capsys, [*command, REPO / "runs" / "caseB.toml", *extra])
    assert code == 2 and "caseB.toml is a case file" in err
    assert "case.toml:" not in err and "Traceback" not in err


def test_resume_of_missing_or_empty_run(tmp_path, capsys):
    code, err = _err(capsys, ["resume", tmp_path / "nonexist"])
    assert code == 2 and "no such run directory" in err and "Errno" not in err
    (tmp_path / "empty").mkdir()
    code, err = _err(capsys, ["resume", tmp_path / "empty"])
    assert code == 2 and "nothing was written" in err and "Errno" not in err


def test_resume_after_a_kill_before_the_first_block(tmp_path, monkeypatch, capsys):
    import importlib

    fitmod = importlib.import_module("pavement_mcmc.runs.fit")

    def killed(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(fitmod, "_run", killed)
    run = tmp_path / "run"
    assert main(["fit", str(REPO / "runs" / "caseA.toml"), "--out", str(run),
                 "--no-progress"]) == 130
    monkeypatch.undo()
    code, err = _err(capsys, ["resume", run])
    assert code == 2 and "no saved block" in err and "Errno" not in err


def test_unknown_prior_names_parameter_and_file(tmp_path, capsys):
    case = tmp_path / "case.toml"
    text = (REPO / "runs" / "caseA.toml").read_text()
    text = text.replace("../data/reference_case/", str(REPO / "data" / "reference_case") + "/")
    case.write_text(text.replace('dist = "truncnormal", mean = 2.27', 'dist = "gaussian", mean = 2.27'))
    code, err = _err(capsys, ["fit", case, "--out", tmp_path / "run", "--no-progress"])
    assert code == 2 and "gaussian" in err and "kappa" in err and str(case) in err
    assert not (tmp_path / "run").exists()


def test_a_bug_shows_its_traceback_and_asks_for_a_report(monkeypatch, capsys):
    import pavement_mcmc.cli.diagnostics as diag

    def broken(args):
        raise KeyError("internal")

    monkeypatch.setattr(diag, "run", broken)
    code, err = _err(capsys, ["diagnostics", "anything"])
    assert code == 1 and "Traceback" in err and "KeyError" in err and "bug" in err


def test_cli_error_types_are_the_projects_own():
    from pavement_mcmc.data import ConfigError, DataError, RunError, RunNotFound, UserError
    from pavement_mcmc.storage import StoreBusy, StoreMismatch

    for cls in (ConfigError, DataError, RunError, RunNotFound, StoreBusy, StoreMismatch):
        assert issubclass(cls, UserError)


@pytest.mark.parametrize("argv", [["diagnose", REPO / "runs" / "caseC.toml+finer_h", "--no-rank"],
                                  ["fit", REPO / "runs" / "caseC.toml", "--add", "finer_h",
                                   "--no-progress"]])
def test_finer_h_on_an_h_per_interval_is_a_user_error(argv, tmp_path, capsys):
    """``diagnose CASE+finer_h`` raised SystemExit past cli.main's UserError path and ``fit --add
    finer_h`` a ValueError reported as a bug; both resolve finer_h in one place now and say so
    in one line."""
    out = ["--out", tmp_path / "run"] if argv[0] == "fit" else []
    code, err = _err(capsys, [*argv, *out])
    assert code == 2 and "already one value per interval" in err and "Traceback" not in err
    assert not (tmp_path / "run").exists()
