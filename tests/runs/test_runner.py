"""fit / resume / load_run on the shipped reference data (Case A, short budgets)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.runs import fit, load_run, resume, to_toml
from pavement_mcmc.storage import StoreMismatch, read_run

ROOT = Path(__file__).resolve().parents[2]


def _case(tmp_path: Path, sampler: str = "fast", max_steps: int = 60) -> Path:
    """A copy of Case A (and its data) in tmp_path, with a small step budget."""
    data = tmp_path / "data"
    data.mkdir()
    src = ROOT / "data" / "reference_case"
    shutil.copy(src / "measurements.csv", data / "measurements.csv")
    shutil.copy(src / "truth.json", data / "truth.json")
    text = (ROOT / "runs" / "caseA.toml").read_text()
    text = text.replace("../data/reference_case/", "data/")
    text = text.split("[sampler]")[0] + (
        f'[sampler]\nkind = "{sampler}"\nseed = 3\ness_target = 1000000\nmax_steps = {max_steps}\n'
        "burn_in = 20\n")
    p = tmp_path / "case.toml"
    p.write_text(text)
    return p


def test_fit_writes_run_and_load_run_reads_it(tmp_path):
    case = _case(tmp_path)
    out = fit(case, tmp_path / "run", set_values={"kappa": 1.5})
    res = out.result
    assert not res.converged and "step budget" in res.reason and "not converged" in res.reason
    for f in ("chain.h5", "case.toml", "config.json", "result.json", "summary.csv", "summary.md"):
        assert (tmp_path / "run" / f).exists(), f
    rows = {r["parameter"]: r for r in out.table}
    assert set(rows) == {"kappa", "C", "h_1", "h_2", "h_3"}
    assert rows["kappa"]["truth"] == 1.31 and rows["C"]["truth"] == 0.99e6
    assert rows["h_1"]["literature"] == 10.0 and rows["kappa"]["prior_sd"] == pytest.approx(0.1135)
    assert 5 < rows["h_1"]["truth"] < 20
    assert rows["kappa"]["q2.5"] < rows["kappa"]["mean"] < rows["kappa"]["q97.5"]
    problem, data = load_run(tmp_path / "run")
    assert data.param_names == problem.space.free and data.n_saved == 60
    assert data.meta["burn_in"] == 20 and data.meta["result"]["n_steps"] == 60
    assert problem.space["kappa"].value == 1.5  # the --set value went into the stored config
    with pytest.raises(FileExistsError, match="resume"):
        fit(case, tmp_path / "run")


@pytest.mark.parametrize("sampler", ["fast", "hmc"])
def test_resume_equals_straight_run_hdf5(tmp_path, sampler):
    case = _case(tmp_path, sampler=sampler, max_steps=80)
    fit(case, tmp_path / "straight")
    half = fit(case, tmp_path / "half", overrides={"sampler": {"max_steps": 40}})
    assert half.result.n_steps == 40
    # the step budget is not part of the identity: raise it in the run's stored overrides
    rec = json.loads((tmp_path / "half" / "config.json").read_text())
    rec["overrides"]["sampler"]["max_steps"] = 80
    (tmp_path / "half" / "config.json").write_text(json.dumps(rec))
    resume(tmp_path / "half")
    a, b = read_run(tmp_path / "straight" / "chain.h5"), read_run(tmp_path / "half" / "chain.h5")
    assert a.chain.shape == b.chain.shape
    for f in ("chain", "log_prob", "blobs", "accepted"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f))


def test_resume_refuses_changed_config_and_data(tmp_path):
    case = _case(tmp_path, max_steps=20)
    fit(case, tmp_path / "run")
    case.write_text(case.read_text().replace("sigma = 0.25", "sigma = 0.3"))
    with pytest.raises(StoreMismatch, match="data.sigma") as err:
        resume(tmp_path / "run")
    assert "changed since" not in str(err.value)  # sigma is config, not a data change (issue 11)
    case.write_text(case.read_text().replace("sigma = 0.3", "sigma = 0.25"))
    csv = tmp_path / "data" / "measurements.csv"
    lines = csv.read_text().splitlines()
    cells = lines[5].split(",")
    cells[1] = str(float(cells[1]) + 0.5)
    lines[5] = ",".join(cells)
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(StoreMismatch, match="data: .*measurements.csv changed"):
        resume(tmp_path / "run")  # names the file that changed, not two hashes (issue 11)


def test_to_toml_round_trips():
    import tomllib

    raw = {"name": "x", "data": {"csv": "/a b/c.csv", "sigma": 0.25, "window_hours": [0, 28]},
           "parameters": {"kappa": {"prior": {"dist": "truncnormal", "mean": 2.27, "sd": 0.1}},
                          "T_2.5cm": {"value": 1e-7, "upper": float("inf")}},
           "sampler": {"kind": "fast", "seed": 1, "thin": 1}}
    assert tomllib.loads(to_toml(raw)) == raw


def test_cli_fit_json(tmp_path, capsys):
    from pavement_mcmc.cli import main

    case = _case(tmp_path, sampler="mh", max_steps=30)
    code = main(["fit", str(case), "--out", str(tmp_path / "r"), "--json", "--seed", "4"])
    payload = json.loads(capsys.readouterr().out)
    assert code == 1 and payload["converged"] is False and payload["n_steps"] == 30
    code = main(["fit", str(case), "--out", str(tmp_path / "r"), "--sampler", "nuts"])
    assert code == 2


def test_the_papers_literature_values_only_for_a_pavement(tmp_path):
    """The paper's kappa 2.27, C 2.10 MJ, h 10 are an asphalt's: a case declaring a loam gets
    no literature values in its table (it showed them for every ground; Case A, which declares
    no material, keeps them: the first test)."""
    out = fit(_case(tmp_path), tmp_path / "run", overrides={"model": {"material": "loam"}})
    assert all(np.isnan(r["literature"]) for r in out.table)
    (tmp_path / "b").mkdir()
    out = fit(_case(tmp_path / "b", max_steps=20), tmp_path / "b" / "run",
              overrides={"model": {"material": "asphalt"}})
    rows = {r["parameter"]: r for r in out.table}
    assert rows["kappa"]["literature"] == 2.27 and rows["h_2"]["literature"] == 10.0
