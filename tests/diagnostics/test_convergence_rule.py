"""Issue 11, item 3: diagnostics and the report apply the fit's own stopping rule, never keep
the sampler's adaptation, and call a stopped or unfinished run what it is."""

from __future__ import annotations

import json
import shutil

from pavement_mcmc.cli import main
from pavement_mcmc.runs import load_view


def test_stopped_run_is_not_trusted_and_burn_in_is_after_adaptation(stopped_run, capsys):
    view = load_view(stopped_run)
    a = view.assessment
    assert a.rule.ess_target == 1000 and a.rule.rhat_max == 1.01  # the fit's rule, not 100 / 1.1
    assert a.n_adapt_rows == 150 and a.burn_in >= 150
    assert not a.trusted and a.unfinished
    assert "unfinished" in a.verdict_text()
    assert main(["diagnostics", str(stopped_run)]) == 0
    out = capsys.readouterr().out
    assert "NOT TRUSTED" in out and "unfinished" in out and "TRUSTED: The run can be" not in out
    assert main(["diagnostics", str(stopped_run), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["rule"]["ess_target"] == 1000 and d["trusted"] is False and d["unfinished"]


def test_run_without_result_is_unfinished_and_user_burn_in_is_raised(stopped_run, tmp_path):
    run = tmp_path / "killed"
    shutil.copytree(stopped_run, run)
    (run / "result.json").unlink()  # as after kill -9: chain.h5 holds blocks, no result
    view = load_view(run, burn_in=10)
    assert view.burn_in == 150 and "adaptation" in view.burn_in_source
    a = view.assessment
    assert not a.trusted and "still being written or was stopped" in a.unfinished
    assert a.rule.ess_target == 1000  # from the run's config


def test_finished_run_is_trusted_under_its_own_rule(finished_run):
    a = load_view(finished_run).assessment
    assert a.unfinished is None and a.rule.ess_target == 30
    assert a.trusted, a.reasons


def test_report_of_stopped_run_says_unfinished(stopped_run, tmp_path, capsys):
    out = tmp_path / "report.html"
    assert main(["report", str(stopped_run), "--draws", "5", "--out", str(out)]) == 0
    assert "NOT trusted" in capsys.readouterr().out
    assert "unfinished" in out.read_text()


def test_the_summary_judges_split_rhat_on_the_stopping_rules_rows():
    """A run the stopping rule stops must not be judged otherwise by its report: the summary
    (and so the assessment and summary.md) takes split-R-hat on the rule's rows. They once
    disagreed at 1.009 against 1.011 on the Göttingen energy case (converged, NOT trusted)."""
    import numpy as np

    from pavement_mcmc.diagnostics import summary
    from pavement_mcmc.diagnostics.stopping import StoppingRule

    rng = np.random.default_rng(3)
    n, m, p = 3000, 8, 3
    x = np.zeros((n, m, p))
    for t in range(1, n):  # AR(1) chains, each with its own slowly wandering level
        x[t] = 0.97 * x[t - 1] + rng.standard_normal((m, p))
    logp = -0.5 * (x**2).sum(axis=2)
    check = StoppingRule(ess_target=10.0).check(x, logp, np.ones((n, m)), 0, burn_in=0,
                                                 names=["a", "b", "c"])
    s = summary(x, ["a", "b", "c"])
    np.testing.assert_allclose([s[k]["rhat"] for k in "abc"], check.rhat, rtol=1e-12)
