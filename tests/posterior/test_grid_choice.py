"""The solver grid a case without ``[grid] kind`` gets (``"auto"``), and that ``fit`` says what
it chose and why: deep sensors get the stretched grid, a shallow column the uniform one, a kind
set by hand is neither changed nor reported."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.cli import main
from pavement_mcmc.data import load_case
from pavement_mcmc.physics import Model
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.posterior.grid_choice import LADDER, stretched_at
from pavement_mcmc.solver import STRETCH_DX_TOP

DEPTHS_CM = (2, 5, 10, 20, 50)


def _field_case(tmp_path, grid: str = "", bottom_cm: int = 50) -> str:
    """A 24-h record of 30-min data with sensors at 2-50 cm (a damped daily wave) in the plain
    Case C form: no [grid] (unless ``grid``), no [sampler.options]."""
    t = np.arange(49) * 1800.0
    w = 2 * np.pi / 86400.0
    rows = ["time,T_air,q_net,wind," + ",".join(f"T_{d}cm" for d in DEPTHS_CM)]
    for s in t:
        temps = [10 + 5 * np.exp(-d / 11) * np.sin(w * s - d / 11) for d in DEPTHS_CM]
        stamp = np.datetime64("2020-04-05T00:00:00") + np.timedelta64(int(s), "s")
        rows.append(f"{stamp}Z,{10 + 6 * np.sin(w * s):.3f},{400 * max(np.sin(w * s), -0.2):.1f},"
                    f"1.0," + ",".join(f"{v:.3f}" for v in temps))
    (tmp_path / "m.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    observed = [d for d in DEPTHS_CM if d < bottom_cm]
    text = f"""name = "plain"
[data]
csv = "m.csv"
sigma = 0.1
observed_cm = {observed}
bottom_cm = {bottom_cm}
[model]
h = {{ kind = "per_interval", smooth = true }}
{grid}
[parameters.kappa]
value = 1.0
prior = {{ dist = "truncnormal", mean = 1.0, sd = 0.5 }}
[parameters.C]
value = 2.0e6
prior = {{ dist = "truncnormal", mean = 2.0e6, sd = 0.7e6 }}
[parameters.h]
value = 10.0
prior = {{ dist = "flat" }}
[parameters.gamma]
prior = {{ dist = "rayleigh", scale = 2.22 }}
[sampler]
kind = "hmc"
seed = 1
"""
    path = tmp_path / "plain.toml"
    path.write_text(text, encoding="utf-8")
    return str(path)


def test_deep_sensors_get_the_stretched_grid_and_the_reason(tmp_path):
    """A 50 cm bottom boundary: stretched (a few mm at the top, nodes at the sensors), and the
    problem says so; a shallow (5 cm) column gets the uniform 5 mm grid."""
    pb = build_problem(load_case(_field_case(tmp_path)))
    g = pb.grid_chosen
    assert g["kind"] == "stretched" and "50 cm is deeper than 10 cm" in g["why"]
    assert g["nodes"] == pb.model.grid.n_nodes < 50  # a uniform 5 mm grid would have 101
    assert 1e3 * STRETCH_DX_TOP <= g["top_mm"] <= 4e3 * STRETCH_DX_TOP and g["deep_mm"] > 10
    assert 2 <= g["steps_per_interval"] <= 7  # 30-min data: the defaults' 257 s or coarser
    assert np.all(np.isin(np.array(DEPTHS_CM[:-1]) / 100, np.round(pb.model.grid.x, 9)))
    shallow = build_problem(load_case(_field_case(tmp_path, bottom_cm=5)))
    assert shallow.grid_chosen["kind"] == "uniform" and shallow.grid_chosen["top_mm"] == 5.0


def _predict(pb):
    """The sensor temperatures on a grid at the case's parameter values (the test's own
    model on that grid, not the rule's)."""
    m = pb.model
    p = pb.space.expand(pb.space.initial()[None])

    def on(grid):
        return Model(m.meas, grid, m.h_basis, m.extensions, scheme=m.scheme, gamma0=m.gamma0,
                     plates=m.plates).predict(p)[0]
    return on


@pytest.mark.parametrize("sigma", [0.1, 0.05])
def test_the_chosen_stretched_grid_is_the_coarsest_within_a_tenth_of_sigma(tmp_path, sigma):
    """The deep record's grid: its largest difference at the sensors from the same grid refined
    twice in space and time is at most sigma/10, and the next coarser rung's is not (before the
    rule the defaults were kept: their next coarser rung is within sigma/10 at sigma = 0.1);
    a smaller sigma gets a finer grid."""
    case = _field_case(tmp_path)
    at_01 = build_problem(load_case(case)).model.grid
    text = Path(case).read_text(encoding="utf-8")
    Path(case).write_text(text.replace("sigma = 0.1", f"sigma = {sigma}"), encoding="utf-8")
    pb = build_problem(load_case(case))
    on, grid = _predict(pb), pb.model.grid

    def err(g):
        return np.max(np.abs(on(g) - on(g.refined(2))))
    assert err(grid) <= 0.1 * sigma
    k = next(i for i, f in enumerate(LADDER) if stretched_at(pb.meas, f).n_nodes == grid.n_nodes
             and np.array_equal(stretched_at(pb.meas, f).substeps, grid.substeps))
    assert k > 0 and err(stretched_at(pb.meas, LADDER[k - 1])) > 0.1 * sigma
    assert f"{LADDER[k]:g}x the stretched defaults" in pb.grid_chosen["why"]
    if sigma < 0.1:  # finer than sigma = 0.1's choice
        assert grid.n_nodes > at_01.n_nodes and grid.substeps.max() > at_01.substeps.max()


def test_a_grid_kind_set_by_hand_is_kept_and_not_reported(tmp_path):
    pb = build_problem(load_case(_field_case(tmp_path, grid='[grid]\nkind = "uniform"')))
    assert pb.grid_chosen == {} and pb.model.grid.n_nodes == 101


def test_fit_prints_and_records_the_grid_it_chose(tmp_path, capsys):
    """The command line prints the chosen grid beside the sampler's chosen options; result.json
    keeps it (fails before the grid choice was returned: nothing was printed)."""
    case = _field_case(tmp_path)
    main(["fit", case, "--out", str(tmp_path / "run"), "--no-progress",
          "--set", "sampler.max_steps=3", "--set", "sampler.n_walkers=4"])
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith("grid chosen:"))
    assert "stretched" in line and "deeper than 10 cm" in line
    assert "sampler options chosen:" in out
    rec = json.loads((tmp_path / "run" / "result.json").read_text())
    assert rec["grid_chosen"]["kind"] == "stretched"


def test_a_candidate_of_the_criticism_shares_the_base_grid(tmp_path):
    """The grid is chosen once, for the base model: a candidate scored against it is solved on
    the same grid (the same discretisation, and the choice is not repeated per candidate)."""
    from pavement_mcmc.criticism.candidates import variant

    base = build_problem(load_case(_field_case(tmp_path)))
    assert base.grid_chosen.get("kind") == "stretched"
    cand = variant(base, ["two_layer"], None)
    assert cand.model.grid is base.model.grid and cand.grid_chosen == {}
    assert [e.name for e in cand.model.extensions] == ["two_layer"]
