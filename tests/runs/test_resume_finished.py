"""Issue 11, item 4: resume leaves a finished run alone unless asked for more, and whatever
changes the chain refreshes the run's report."""

from __future__ import annotations

import json
import shutil

from pavement_mcmc.cli import main
from pavement_mcmc.storage import read_run


def _copy(run, tmp_path):
    out = tmp_path / "run"
    shutil.copytree(run, out)
    return out


def test_resume_of_finished_run_does_nothing(finished_run, tmp_path, capsys):
    run = _copy(finished_run, tmp_path)
    before = read_run(run / "chain.h5").n_saved
    result = (run / "result.json").read_text()
    assert main(["resume", str(run), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "is finished" in out and "--more-steps" in out
    assert read_run(run / "chain.h5").n_saved == before
    assert (run / "result.json").read_text() == result


def test_more_steps_extends_and_refreshes_the_report(finished_run, tmp_path, capsys):
    run = _copy(finished_run, tmp_path)
    before = read_run(run / "chain.h5").n_saved
    (run / "report.html").write_text("stale")
    assert main(["resume", str(run), "--more-steps", "40", "--no-progress"]) == 0
    assert read_run(run / "chain.h5").n_saved == before + 40
    assert json.loads((run / "result.json").read_text())["n_steps"] == before + 40
    html = (run / "report.html").read_text()
    assert html != "stale" and str(before + 40) in html
    assert "wrote" in capsys.readouterr().err


def test_ess_target_continues_until_the_new_target(finished_run, tmp_path):
    run = _copy(finished_run, tmp_path)
    before = read_run(run / "chain.h5").n_saved
    assert main(["resume", str(run), "--ess-target", "3000", "--no-progress"]) == 0
    res = json.loads((run / "result.json").read_text())
    assert res["converged"] and res["rule"]["ess_target"] == 3000 and min(res["ess"]) >= 3000
    assert res["n_steps"] > before
    rec = json.loads((run / "config.json").read_text())
    assert rec["overrides"]["sampler"]["ess_target"] == 3000
    assert rec["rule"]["ess_target"] == 3000  # the rule stored with the run is the new one
    assert main(["resume", str(run), "--no-progress"]) == 0  # finished under the new target
    assert json.loads((run / "result.json").read_text())["n_steps"] == res["n_steps"]


def test_library_resume_removes_a_stale_report(finished_run, tmp_path):
    from pavement_mcmc.runs import resume

    run = _copy(finished_run, tmp_path)
    (run / "report.html").write_text("old")
    out = resume(run, more_steps=20)
    assert out.ran and out.report_removed and not (run / "report.html").exists()


def test_refit_with_overwrite_removes_the_old_report(finished_run, tmp_path):
    from conftest import REPO

    from pavement_mcmc.runs import fit

    run = _copy(finished_run, tmp_path)
    (run / "report.html").write_text("old")
    fit(REPO / "runs" / "caseA.toml", run, overwrite=True, seed=1,
        overrides={"sampler": {"kind": "fast", "max_steps": 160}})
    assert not (run / "report.html").exists()


def test_a_resume_is_held_to_the_rule_stored_with_the_run(finished_run, tmp_path):
    """The rule is stored with the run so that a later change of StoppingRule's defaults does
    not re-judge it: a resume must continue under the stored rule, not today's defaults."""
    from pavement_mcmc.diagnostics.stopping import StoppingRule
    from pavement_mcmc.runs import resume
    from pavement_mcmc.runs.folder import RunFolder

    f = RunFolder(_copy(finished_run, tmp_path))
    stored = StoppingRule(ess_target=30, rhat_max=1.5, min_tau_lengths=7, drift_z=9)
    assert stored != StoppingRule(ess_target=30)
    f.result.unlink()  # killed before it finished: the rule is config.json's
    rec = f.read_config()
    rec["rule"] = stored.to_dict()
    f.write_config(rec)
    out = resume(f.path)
    assert out.result.rule == stored
    assert f.read_result()["rule"] == stored.to_dict() == f.read_config()["rule"]


def test_a_resume_killed_midway_leaves_an_unfinished_run(finished_run, tmp_path):
    """While a resume adds rows, the old result.json describes another chain: a run killed
    then must read as unfinished (not as the finished old one, whose n_saved it contradicts)."""
    import pytest

    from pavement_mcmc.runs import resume
    from pavement_mcmc.runs.folder import RunFolder

    f = RunFolder(_copy(finished_run, tmp_path))
    before = read_run(f.chain).n_saved

    def kill(info):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        resume(f.path, more_steps=200, callback=kill)
    assert read_run(f.chain).n_saved > before
    assert f.state == "unfinished" and f.unfinished_reason() is not None
    assert not f.summary_csv.exists()
    out = resume(f.path, more_steps=20)  # and it continues
    assert out.ran and f.state == "finished"


def test_a_new_ess_target_is_the_rule_even_if_the_resume_is_killed(finished_run, tmp_path):
    """resume --ess-target N killed midway: the folder is unfinished, and the next resume must
    continue towards N (config.json's rule), not stop at once under the old target."""
    import pytest

    from pavement_mcmc.runs import resume
    from pavement_mcmc.runs.folder import RunFolder

    f = RunFolder(_copy(finished_run, tmp_path))

    def kill(info):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        resume(f.path, ess_target=3000, callback=kill)
    assert f.rule().ess_target == 3000 == f.read_config()["rule"]["ess_target"]
