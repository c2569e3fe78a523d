"""Issue 21, items 1-2: one StoppingRule (its check on known chains, stored with the run, old
runs judged by the rule they were held to), one RunFolder (finished, unfinished, failed and
old-format runs) and one kept-chain view that every reader goes through."""

from __future__ import annotations

import ast
import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.diagnostics import StoppingRule
from pavement_mcmc.diagnostics.stopping import LEGACY_RULE
from pavement_mcmc.runs import RunFolder, keep, load_kept, load_view, point_estimate
from pavement_mcmc.runs.resume import stored_result

PKG = Path(__file__).resolve().parents[2] / "pavement_mcmc"


def _ar1(rho: float, n: int = 2000, m: int = 16, p: int = 2, seed: int = 1) -> np.ndarray:
    """m independent stationary AR(1) chains of p parameters; IACT (1 + rho) / (1 - rho)."""
    rng = np.random.default_rng(seed)
    x = np.empty((n, m, p))
    x[0] = rng.normal(size=(m, p))
    s = np.sqrt(1 - rho**2)
    for i in range(1, n):
        x[i] = rho * x[i - 1] + s * rng.normal(size=(m, p))
    return x


def _check(x: np.ndarray, rule: StoppingRule, logp: np.ndarray | None = None, **kw):
    lp = -0.5 * (x**2).sum(axis=2) if logp is None else logp
    return rule.check(x, lp, np.ones(lp.shape, bool), 0, burn_in=0, names=["a", "b"], **kw)


# ------------------------------------------------------------------ the rule's check
def test_iid_chain_passes_and_its_estimates_are_the_known_ones():
    x = _ar1(0.0, n=1000)  # <= TAU_ROWS rows: tau estimated unthinned
    c = _check(x, StoppingRule())
    assert c.failures == []
    assert np.all(np.abs(c.tau - 1.0) < 0.2)  # IACT of white noise is 1
    assert np.all(np.abs(c.ess / (1000 * 16) - 1) < 0.2) and np.all(c.rhat < 1.01)


def test_each_criterion_fails_on_a_chain_made_to_fail_it():
    x = _ar1(0.0)
    assert [f[:3] for f in _check(x, StoppingRule(ess_target=1e6)).failures] == ["ESS"]
    slow = _ar1(0.95)  # IACT 39: 2000 rows are ~51 IACT, not 100
    c = _check(slow, StoppingRule(ess_target=10, min_tau_lengths=100, rhat_max=1.5))
    assert np.all(np.abs(c.tau / 39 - 1) < 0.3), c.tau
    assert [f[:11] for f in c.failures] == ["kept chain "]
    assert _check(slow, StoppingRule(ess_target=10, min_tau_lengths=20, rhat_max=1.5)).failures == []
    apart = x + np.arange(16)[None, :, None] * 0.5  # walkers that disagree
    c = _check(apart, StoppingRule(ess_target=10), logp=-0.5 * (x**2).sum(axis=2))
    assert [f[:5] for f in c.failures] == ["R-hat"] and c.rhat.min() > 1.5
    trend = -0.5 * (x**2).sum(axis=2) + np.linspace(0, 30, 2000)[:, None]
    assert _check(x, StoppingRule(), logp=trend).failures == ["log-posterior still drifting"]
    assert _check(x, StoppingRule(drift_z=1e9), logp=trend).failures == []


def test_a_short_check_stops_at_the_first_failure_and_burn_in_is_after_adaptation():
    x = _ar1(0.0, n=400)
    lp = -0.5 * (x**2).sum(axis=2)
    c = StoppingRule(ess_target=1e9).check(x, lp, np.ones(lp.shape, bool), 50, full=False)
    assert c.burn_in >= 50 and np.all(np.isnan(c.rhat))  # R-hat (costly) not evaluated
    c = StoppingRule().check(x[:55], lp[:55], np.ones((55, 16), bool), 50)
    assert c.failures == ["only 5 kept steps"]


def test_the_rule_is_frozen_and_round_trips_through_a_record():
    r = StoppingRule(ess_target=400, rhat_max=1.02)
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.ess_target = 5  # type: ignore[misc]
    assert StoppingRule.from_dict(json.loads(json.dumps(r.to_dict()))) == r
    assert StoppingRule.from_dict({"ess_target": 30, "unknown": 1, "geweke": True}) == \
        StoppingRule(ess_target=30)
    # a record from before Geweke joined the rule keeps the rule it was sampled under
    assert StoppingRule.from_dict({"ess_target": 30}) == StoppingRule(ess_target=30, geweke=False)
    assert r.with_overrides(ess_target=None, min_tau_lengths=20) == dataclasses.replace(
        r, min_tau_lengths=20.0)


# ------------------------------------------------------------------ the run folder
def _copy(run: Path, tmp_path: Path, name: str) -> RunFolder:
    dst = tmp_path / name
    shutil.copytree(run, dst)
    return RunFolder(dst)


def test_finished_run_stores_its_rule_and_says_it_finished(finished_run):
    f = RunFolder(finished_run)
    assert f.state == "finished" and f.finished and f.converged and not f.failed
    assert {"chain", "case", "config", "result", "summary_csv", "summary_md"} <= set(f.contents())
    assert f.read_result()["rule"] == StoppingRule(ess_target=30).to_dict()
    assert f.read_config()["rule"] == StoppingRule(ess_target=30).to_dict()
    assert f.rule() == StoppingRule(ess_target=30) and f.unfinished_reason() is None
    assert stored_result(f.path).rule == StoppingRule(ess_target=30)


def test_unfinished_and_empty_runs(finished_run, tmp_path):
    f = _copy(finished_run, tmp_path, "killed")
    f.result.unlink()  # as after kill -9
    assert f.state == "unfinished" and not f.finished and not f.converged
    assert f.rule() == StoppingRule(ess_target=30)  # stored in config.json at the start
    view = load_view(f.path)
    assert view.rule == StoppingRule(ess_target=30)
    assert "still being written" in view.unfinished and "MSER" in view.burn_in_source
    assert RunFolder(tmp_path / "nothing").state == "empty"


def test_failed_run_is_refused_and_not_resumed_as_finished(finished_run, tmp_path):
    from pavement_mcmc.criticism.guards import check_run

    f = _copy(finished_run, tmp_path, "failed")
    f.write_result({"failed": True, "converged": False, "reason": "failed: RuntimeError: boom"})
    assert f.state == "failed" and f.failed and not f.finished
    assert stored_result(f.path) is None
    assert [g.kind for g in check_run(f.path)] == ["failed"]
    assert "boom" in load_view(f.path).unfinished


def test_old_format_runs_keep_the_rule_they_were_held_to(finished_run, tmp_path):
    f = _copy(finished_run, tmp_path, "old")
    res = f.read_result()
    del res["rule"]  # result.json before the rule was stored: its thresholds at top level
    res.update(ess_target=30.0, rhat_max=1.02, min_tau_lengths=40.0)
    f.write_result(res)
    cfg = f.read_config()
    del cfg["rule"]
    f.write_config(cfg)
    held = StoppingRule(ess_target=30, rhat_max=1.02, min_tau_lengths=40, drift_z=3, geweke=False)
    assert f.rule() == held
    assert load_view(f.path).assessment.rule == held
    assert stored_result(f.path).rule == held
    for k in ("ess_target", "rhat_max", "min_tau_lengths"):  # older still: no thresholds
        del res[k]
    f.write_result(res)
    assert f.rule() == LEGACY_RULE.with_overrides(ess_target=30)  # the case's target


# ------------------------------------------------------------------ one kept-chain view
@pytest.mark.parametrize("how", ["stored", "unfinished"])
def test_every_reader_keeps_the_same_rows(finished_run, tmp_path, how):
    """A run whose burn-in is not half the chain: stored in result.json (and not the loop's
    own choice), or, with no result.json, MSER's after the adaptation. The view, the point
    estimate, the guards, the batch row and the statistics table all keep exactly its rows
    (before, four of them kept half the chain of an unfinished run)."""
    from pavement_mcmc.batch.unit import unit_row
    from pavement_mcmc.criticism.guards import sampled_sd
    from pavement_mcmc.runs import statistics_table

    f = _copy(finished_run, tmp_path, how)
    res = f.read_result()
    _, kept0 = load_kept(f.path)
    n = kept0.n_saved
    if how == "stored":
        res["burn_in"] = n - 37
        f.write_result(res)
    else:
        f.result.unlink()
    burn = load_view(f.path).burn_in
    assert burn != n // 2 and (how == "unfinished" or burn == n - 37)
    assert burn != kept0.burn_in or how == "unfinished"
    chain = kept0.run.chain
    names = kept0.param_names
    mean = chain[burn:].reshape(-1, chain.shape[2]).mean(axis=0)
    sd = chain[burn:].reshape(-1, chain.shape[2]).std(axis=0)

    view = load_view(f.path)
    assert view.flat.shape[0] == (n - burn) * chain.shape[1]
    assert view.assessment.n_kept == n - burn
    np.testing.assert_array_equal(view.get_chain(thin=2), chain[burn::2])
    problem, values = point_estimate(f.path)
    np.testing.assert_allclose([values[k] for k in names], mean, rtol=1e-12)
    sds = sampled_sd(f.path)
    np.testing.assert_allclose([sds[k] for k in sds], [sd[names.index(k)] for k in sds], rtol=1e-12)
    row = unit_row(f.path)
    assert row["kappa"] == pytest.approx(mean[names.index("kappa")], rel=1e-12)
    problem, kept = load_kept(f.path)
    table = statistics_table(problem, kept)
    assert [r["mean"] for r in table] == pytest.approx(list(mean), rel=1e-12)


def test_keep_never_keeps_the_adaptation_and_keeps_a_row():
    from pavement_mcmc.storage import RunData

    x = _ar1(0.0, n=100, m=4)
    run = RunData(x, -0.5 * (x**2).sum(axis=2), np.zeros((100, 4, 0)), np.ones((100, 4), bool),
                  ["a", "b"], [], {}, None)
    k = keep(run, {"burn_in": 10, "n_adapt_rows": 30})
    assert k.burn_in == 30 and "adaptation" in k.source and k.get_chain().shape == (70, 4, 2)
    assert keep(run, {"burn_in": 500}).n_kept == 1
    assert keep(run, {}, {"burn_in": 41, "thin": 2}).burn_in == 21  # steps -> stored rows
    assert keep(run, {}, {}, burn_in=5).get_chain(flat=True).shape == (95 * 4, 2)


def test_run_file_names_are_written_in_one_module():
    """``chain.h5`` / ``result.json`` ... as string literals only in runs/folder.py."""
    names = {"chain.h5", "result.json", "config.json", "summary.csv", "summary.md",
             "report.html", "unit.json"}
    found = {}
    for py in PKG.rglob("*.py"):
        for node in ast.walk(ast.parse(py.read_text())):
            if isinstance(node, ast.Constant) and node.value in names:
                found.setdefault(str(py.relative_to(PKG)), set()).add(node.value)
    assert set(found) == {"runs/folder.py"}, found


def test_report_caption_states_the_stored_rule(finished_run, tmp_path, monkeypatch):
    from pavement_mcmc import report

    monkeypatch.setattr(report, "_figures", lambda view, n: [])  # the text only: fast
    monkeypatch.setattr(report, "_urban_section", lambda view, dpi, n: "")
    f = _copy(finished_run, tmp_path, "caption")
    res = f.read_result()
    res["rule"] = StoppingRule(ess_target=30, rhat_max=1.03, min_tau_lengths=45).to_dict()
    f.write_result(res)
    view = load_view(f.path)
    html = report.render(view, [], n_draws=5)
    cap = html.split("<h2", 4)[3]  # the diagnostics section
    assert "ESS ≥ 30 " in cap and "split-R̂ &lt; 1.03" in cap and "≥ 45 IACT" in cap, cap[-800:]
    assert "1.1" not in cap.split("<p class=cap>")[1].split("</p>")[0]
