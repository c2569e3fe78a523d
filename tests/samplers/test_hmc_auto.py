"""hmc's ``"auto"`` options: the working coordinates and the metric windows chosen from the
problem (:mod:`pavement_mcmc.samplers.hmc_options`), hand options as overrides, the choice
recorded and kept on resume; and the tutorial's ``runs/hidden.toml`` on ``hmc``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_samplers import LinearGaussian

from pavement_mcmc.posterior import find_map
from pavement_mcmc.runs import fit
from pavement_mcmc.samplers import get_sampler
from pavement_mcmc.samplers.coords import LOG, SQRT
from pavement_mcmc.samplers.hmc_options import HMCOptions, resolve

ROOT = Path(__file__).resolve().parents[2]
HIDDEN = ROOT / "runs" / "hidden.toml"


def _bounded(k_sd, seed=5):
    """A linear-Gaussian posterior, every parameter bounded below by 0, parameter i's mode
    ``k_sd[i]`` of its sd above 0 (negative: the untruncated mode lies below 0)."""
    d = len(k_sd)
    post = LinearGaussian(seed=seed, d=d, n=10 * d, lower=[0.0] * d)
    shift = post.mean - np.asarray(k_sd) * np.sqrt(np.diag(post.cov))
    post.y = post.y - post.X @ shift
    post.obs = post.y[:, None]
    post.mean = np.linalg.solve(post.X.T @ post.X, post.X.T @ post.y)
    return post


def _prepared(post, n_chains=8, **opts):
    s = get_sampler("hmc", post, n_chains=n_chains, seed=1, options=opts)
    s.prepare(laplace=find_map(post))
    return s


def test_many_parameters_at_a_bound_get_sqrt_and_those_far_from_it_log():
    """4 of 8 parameters with their mode on the bound 0 (the night h of a field record):
    those get the shifted sqrt, the 4 well above 0 get log; the choice says why."""
    s = _prepared(_bounded([-1.0] * 4 + [4.0] * 4))
    assert list(s.tlog) == [SQRT] * 4 + [LOG] * 4
    assert s.chosen["sqrt_at_zero"] is True and s.chosen["log_positive"] is True
    assert s.chosen["why"].startswith("4 of 8 parameters bounded at 0")


def test_skewed_positive_parameters_get_log_coordinates_even_when_none_is_at_the_bound():
    """Twelve parameters with their mode 3 sd above their bound 0 (none near it, so not
    piled): their posteriors are skewed (median mode/sd 3 < 6) and move as logs, as the
    desert window's h (median 4.9) do; 10 sd above it (Case C's median is 9.1), or only a
    few such parameters, they stay linear."""
    s = _prepared(_bounded([3.0] * 12))
    assert list(s.tlog) == [LOG] * 12
    assert s.chosen["log_positive"] is True and "median mode/sd is 3" in s.chosen["why"]
    for k_sd in ([10.0] * 12, [3.0] * 6):
        s = _prepared(_bounded(k_sd))
        assert not any(s.tlog) and s.chosen["log_positive"] is False


@pytest.mark.parametrize("n_near, n_at0, z_median, on", [(5, 72, 4.9, True), (9, 112, 9.1, False),
                                                          (65, 144, 1.3, True), (0, 0, 0.0, False)])
def test_coordinates_from_the_field_windows_numbers(n_near, n_at0, z_median, on):
    """The numbers measured at the MAP: the desert window (5 of 72 near 0, median 4.9) and the
    Göttingen one (65 of 144) get sqrt and log, Case C (9 of 112, median 9.1) linear."""
    opts, _ = resolve(HMCOptions(), n_params=n_at0 + 2, n_chains=16, n_at0=n_at0, n_near=n_near,
                      z_median=z_median)
    assert opts.log_positive is on and opts.sqrt_at_zero is on


def test_a_small_problem_keeps_the_defaults():
    """One parameter of three at its bound (hmc's own truncated-normal tests), few parameters:
    linear coordinates and two metric windows, as before the rule."""
    post = _bounded([-0.5, 3.0, 3.0])
    s = _prepared(post, n_chains=16)
    assert list(s.tlog) == [0, 0, 0]
    assert (s.options.log_positive, s.options.sqrt_at_zero, s.options.metric_windows) == \
        (False, False, 2)
    assert s.adapt_length() == 150


def test_options_set_by_hand_override_the_rule():
    """``sqrt_at_zero = false`` set by hand: the piled parameters stay linear while log (still
    auto) goes on; ``metric_windows`` set by hand is kept and not reported as chosen."""
    s = _prepared(_bounded([-1.0] * 4 + [4.0] * 4), sqrt_at_zero=False, metric_windows=1)
    assert list(s.tlog) == [0] * 4 + [LOG] * 4
    assert set(s.chosen) == {"log_positive", "why"}
    assert s.options.metric_windows == 1


@pytest.mark.parametrize("n_params, n_chains, windows", [(114, 16, 2), (147, 16, 3), (40, 4, 3),
                                                         (30, 16, 2)])
def test_metric_windows_from_the_pooled_draws_per_parameter(n_params, n_chains, windows):
    """A third window when a window pools fewer than 6 draws per parameter (16 chains x 50
    steps: Case C's 114 parameters keep 2, the Göttingen window's 147 get 3)."""
    opts, chosen = resolve(HMCOptions(), n_params=n_params, n_chains=n_chains, n_at0=0, n_near=0)
    assert opts.metric_windows == chosen["metric_windows"] == windows
    assert opts.log_positive is False and opts.sqrt_at_zero is False


def test_a_resumed_run_keeps_the_choice():
    """The chosen options are stored in the run state: a sampler restored from it continues
    with them (not with the legacy defaults of a run stored before the rule)."""
    post = _bounded([-1.0] * 4 + [4.0] * 4)
    s = _prepared(post, n_chains=4)
    s.step(3, adapt=True)
    r = get_sampler("hmc", post, n_chains=4, seed=1)
    r.set_state(s.get_state())
    assert (r.options.log_positive, r.options.sqrt_at_zero) == (True, True)
    assert list(r.tlog) == list(s.tlog)
    np.testing.assert_array_equal(s.step(2, adapt=True).chain, r.step(2, adapt=True).chain)


def test_hidden_toml_fit_records_the_choice_and_respects_hand_options(tmp_path):
    """The tutorial case samples with hmc; a ``[sampler.options]`` value set by hand (log h)
    is used, the rest is chosen, and result.json records what was chosen and why."""
    ov = {"sampler": {"max_steps": 4, "n_walkers": 4, "options": {"log_positive": True}}}
    out = fit(HIDDEN, tmp_path / "h", overrides=ov, seed=1)
    rec = json.loads((tmp_path / "h" / "result.json").read_text())
    assert out.problem.cfg.sampler["kind"] == "hmc"
    assert set(rec["sampler_chosen"]) == {"sqrt_at_zero", "metric_windows", "why"}
    assert rec["sampler_chosen"]["metric_windows"] == 2
    assert out.chosen == rec["sampler_chosen"]


def test_hidden_toml_models_have_adjoint_gradients():
    """hmc is cheap on the tutorial only because the base model and two_layer have adjoint
    gradients (else each gradient costs 2 d + 1 solves)."""
    from pavement_mcmc.data import load_case
    from pavement_mcmc.posterior import build_problem

    cfg = load_case(HIDDEN)
    for ext in ([], ["two_layer"]):
        assert build_problem(cfg, extensions=ext).model.has_gradient


@pytest.mark.slow
@pytest.mark.parametrize("add", [[], ["two_layer"]])
def test_hidden_toml_converges_within_a_small_budget(tmp_path, add):
    """The README tutorial's fits converge with the shipped case (hmc): 21k / 34k gradients
    measured (seed 1); fast needs 0.27M and 0.48M solves (before its tail fixes 1.2M, and
    with two_layer no convergence in 12M: tests/samplers/test_pcn_tails.py)."""
    out = fit(HIDDEN, tmp_path / "h", add=add, seed=1, max_seconds=1200)
    assert out.result.converged, out.result.reason
    assert out.result.n_evals < 60_000


def _plain_grass(tmp_path, csv) -> Path:
    """runs/grass.toml as a user would write it: no [grid], no [sampler.options]."""
    text = (ROOT / "runs" / "grass.toml").read_text(encoding="utf-8")
    text = text[:text.index("[sampler.options]")]
    a, b = text.index("[grid]"), text.index("[parameters.kappa]")
    text = text[:a] + text[b:]
    text = text.replace('"../../shared/data/goettingen_grass/measurements.csv"', json.dumps(str(csv)))
    path = tmp_path / "grass_plain.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.slow
def test_a_plain_field_toml_gets_the_hand_options_of_grass_toml(tmp_path, grass_csv):
    """On the Göttingen 72-h window the auto grid is a stretched one (coarser than grass.toml's
    hand grid: 1.25x its cells and steps keep the sensors within sigma/10) and hmc's auto
    options are the ones runs/grass.toml sets by hand (65 of 144 h piled at 0, 147
    parameters)."""
    from pavement_mcmc.data import load_case
    from pavement_mcmc.posterior import build_problem

    plain = build_problem(load_case(_plain_grass(tmp_path, grass_csv)))
    hand = build_problem(load_case(ROOT / "runs" / "grass.toml"))
    assert "1.25x the stretched defaults" in plain.grid_chosen["why"]
    assert plain.model.grid.n_nodes < hand.model.grid.n_nodes
    s = get_sampler("hmc", plain.posterior, seed=1)
    s.prepare()
    assert (s.options.metric_windows, s.options.log_positive, s.options.sqrt_at_zero) == \
        (3, True, True)


def test_daily_grass_windows_move_kappa_c_and_the_plate_factor_as_logs(grass_csv):
    """runs/grass_daily.toml: the three parameters on the kappa-C-plate ridge are bounded at 0
    and hmc moves them as logs (in linear coordinates a chain started in the ridge's narrow end
    stayed stuck: window 24-48 h, R-hat 1.15 after 3561 steps)."""
    from pavement_mcmc.data import load_case
    from pavement_mcmc.posterior import build_problem

    cfg = load_case(ROOT / "runs" / "grass_daily.toml", {"data": {"window_hours": [24, 48]}})
    s = get_sampler(cfg.sampler["kind"], build_problem(cfg).posterior, seed=1,
                    options=cfg.sampler["options"])
    s.prepare()
    assert list(s.tlog) == [LOG, LOG, LOG]
