"""Shared fixtures: the repository paths and one tiny stored run reused by the review tests."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def tiny_run(tmp_path_factory) -> Path:
    """A 300-step, 12-walker emcee run of Case A, made once per session (~2 s)."""
    from pavement_mcmc.runs import fit

    root = tmp_path_factory.getbasetemp() / "tiny_caseA"
    fit(REPO / "runs" / "caseA.toml", root, overwrite=True, seed=3,
        overrides={"sampler": {"kind": "emcee", "max_steps": 300, "n_walkers": 12}})
    return root


#: the shared real record (its licence differs from ours: read it in place, never copy it)
GRASS = REPO.parent / "shared" / "data" / "goettingen_grass" / "measurements.csv"


@pytest.fixture(scope="session")
def grass_csv() -> Path:
    if not GRASS.is_file():
        pytest.skip(f"the shared real record is not here ({GRASS})")
    return GRASS


@pytest.fixture(scope="session")
def finished_run(tmp_path_factory) -> Path:
    """A Case A run of the fast sampler that finished by its rule (ESS target 30, ~260 steps)."""
    from pavement_mcmc.runs import fit

    root = tmp_path_factory.getbasetemp() / "finished_caseA"
    out = fit(REPO / "runs" / "caseA.toml", root, overwrite=True, seed=2,
              overrides={"sampler": {"kind": "fast", "ess_target": 30, "max_steps": 4000}})
    assert out.result.converged, out.result.reason
    return root


@pytest.fixture(scope="session")
def stopped_run(tmp_path_factory) -> Path:
    """A Case A run of the fast sampler stopped by its step budget 50 steps after its 150-step
    adaptation, far from its ESS target of 1000."""
    from pavement_mcmc.runs import fit

    root = tmp_path_factory.getbasetemp() / "stopped_caseA"
    out = fit(REPO / "runs" / "caseA.toml", root, overwrite=True, seed=2,
              overrides={"sampler": {"kind": "fast", "max_steps": 200}})
    assert not out.result.converged
    return root


@pytest.fixture
def extension_forecast(tmp_path):
    """``f(effects, seed, extension)``: a 40 h forecast twin (input noise on) hiding ``effects``,
    the base model's forecast and the model with ``extension`` forecast from the best of its
    start values; returns ``(gain F, the extension's forecast, its problem, the twin)``."""
    def run(effects, seed, extension):
        from pavement_mcmc.criticism.forecast import forecast, forecast_from_starts, forecast_gain
        from pavement_mcmc.data import load_case
        from pavement_mcmc.posterior import build_problem
        from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin

        twin = forecast_twins(effects, (seed,), hours=40.0, input_sigma=True)[0]
        case = write_twin(twin, tmp_path / twin.name)
        base = forecast(build_problem(load_case(case)))
        pb = build_problem(load_case(case, additions={"model": {"extensions": [extension]}}))
        fc = forecast_from_starts(pb, pb.model.extensions[-1].start_values(pb.meas, None))
        return forecast_gain(base, fc), fc, pb, twin
    return run
