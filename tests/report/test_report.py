"""The HTML report: sections, embedded figures, the section hook, a run still being written."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc import report
from pavement_mcmc.diagnostics.assessment import assess
from pavement_mcmc.runs import load_view
from pavement_mcmc.storage import HDF5Store

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def run_dir(tiny_run):
    return tiny_run


def test_view_and_assessment(run_dir):
    view = load_view(run_dir)
    assert view.burn_in_source.endswith("(result.json)")
    a = view.assessment
    assert set(a.table) == {"kappa", "C", "h_1", "h_2", "h_3"}
    assert a.n_kept == a.n_steps - a.burn_in and a.n_chains == 12
    assert not a.trusted and a.reasons  # 300 steps cannot be enough
    assert "NOT" in a.verdict_text()
    pr = view.predictive(20)
    assert pr.pred.shape == (20, view.problem.meas.n_obs, 5)
    assert pr.h.shape == (20, view.problem.meas.n_obs - 1)
    assert load_view(run_dir, burn_in=100).burn_in == 100


def test_assess_trusts_a_stationary_chain():
    rng = np.random.default_rng(4)
    n, m, p = 4000, 8, 2
    x = np.zeros((n, m, p))
    for i in range(1, n):
        x[i] = 0.5 * x[i - 1] + rng.normal(size=(m, p))

    class Run:
        chain, log_prob = x, -0.5 * (x**2).sum(axis=2)
        accepted = rng.random((n, m)) < 0.4
        param_names = ["a", "b"]

    a = assess(Run, burn_in=0)
    assert a.trusted, a.reasons
    Run.chain = x + np.linspace(0, 3, n)[:, None, None]  # a trend: Geweke and R-hat must fail
    assert not assess(Run, burn_in=0).trusted


def test_report_html_on_a_run_still_being_written(run_dir, tmp_path):
    """One full report (the expensive part), built while a SWMR writer holds the run file and
    before result.json exists, with one plug-in section that works and one that raises."""
    from matplotlib.figure import Figure

    def good(problem, view):
        fig = Figure()
        ax = fig.subplots()
        ax.plot([0, 1], [0, 1], label="x")
        ax.set_xlabel("x")
        return f"<p>hook saw {len(view.names)} parameters</p>", [fig]

    def bad(problem, view):
        raise RuntimeError("boom")

    live = tmp_path / "live"
    shutil.copytree(run_dir, live)
    (live / "result.json").unlink()  # the runner writes it only at the end
    report.register_section("Hooked section", good, order=1)
    report.register_section("Broken section", bad)
    writer = HDF5Store.open_append(live / "chain.h5")  # a live writer holds the file
    try:
        view = load_view(live)
        assert "MSER" in view.burn_in_source
        out = report.build_report(view, dpi=30, n_draws=20)
    finally:
        writer.close()
        report.unregister_section("Hooked section")
        report.unregister_section("Broken section")
    assert out == live / "report.html"
    doc = out.read_text()
    for title in ("Convergence verdict", "Posterior statistics", "Diagnostics",
                  "Measured vs predicted temperatures", "Surface heat transfer coefficient h(t)",
                  "Surface fluxes", "Corner plot", "Markov chains", "Log-posterior trace",
                  "Acceptance", "Autocovariance norm", "Geweke", "Early vs late segments",
                  "Sensitivity coefficients", "Urban-scale comparison", "Provenance",
                  "Case configuration", "Hooked section", "Broken section"):
        assert f">{title}" in doc, title
    assert len(re.findall(r'src="data:image/png;base64,', doc)) >= 13
    assert "hook saw 5 parameters" in doc
    assert "Section “Broken section” failed" in doc and "boom" in doc
    assert "can NOT be trusted" in doc
    assert view.problem.meas.data_hash()[:16] in doc
    body = re.sub(r"<pre>.*?</pre>", "", doc, flags=re.S)
    assert "http://" not in body and "https://" not in body  # self-contained
