"""Reduced sensitivity coefficients: against a finer difference, against the analytical
steady-state derivative, one batched model call; identifiability on known structures."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.analysis.sensitivity import (
    Sensitivity,
    default_names,
    identifiability,
    reduced_sensitivity,
)
from pavement_mcmc.data import Measurements, load_case
from pavement_mcmc.parameters import parameter_values
from pavement_mcmc.physics import HBasis, Model
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.solver import Grid

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def case_a():
    return build_problem(load_case(REPO / "runs" / "caseA.toml"))


class CountingModel:
    """Proxy that counts ``predict`` calls and the parameter sets they carry."""

    def __init__(self, model):
        self.model, self.meas, self.calls = model, model.meas, []

    def predict(self, p):
        self.calls.append(len(next(iter(p.values()))))
        return self.model.predict(p)


def test_central_difference_agrees_with_finer_step_in_one_batched_call(case_a):
    vals = parameter_values(case_a.space, {"kappa": 1.3, "C": 1.0e6, "h": 10})
    names = default_names(case_a.space)
    counting = CountingModel(case_a.model)
    coarse = reduced_sensitivity(counting, vals, names)  # paper: dp = 1e-2 p
    assert counting.calls == [2 * len(names) + 1]
    fine = reduced_sensitivity(case_a.model, vals, names, rel_step=1e-4)
    X, Xf = coarse.coefficients, fine.coefficients
    assert X.shape == (case_a.meas.n_obs, case_a.meas.n_sensors, len(names))
    for j, n in enumerate(names):
        scale = np.max(np.abs(Xf[..., j]))
        assert np.max(np.abs(X[..., j] - Xf[..., j])) < 1e-3 * scale, n
    assert np.all(X[0] == 0)  # the initial condition does not depend on the parameters


def _steady_case(kappa, h, T_air=20.0, q=200.0, T_b=30.0, L=0.05, hours=48):
    """Constant forcing and an initial profile at the analytical steady state."""
    t = np.arange(0, hours + 1) * 3600.0
    Ts = (kappa * T_b / L + h * T_air + q) / (kappa / L + h)
    depths = np.array([0.0, 0.01, 0.02, 0.03, 0.04])
    T0 = Ts + (T_b - Ts) * depths / L
    n = t.size
    meas = Measurements(
        t=t, time0="2004-06-06T00:00:00Z", T_air=np.full(n, T_air), q_net=np.full(n, q),
        wind=None, rain=None, depths=depths, T_obs=np.tile(T0, (n, 1)), bottom_depth=L,
        T_bottom=np.full(n, T_b), sigma=0.25,
    )
    return meas, Ts


def test_matches_analytical_steady_state_derivatives():
    """At steady state T(x) = Ts + (Tb - Ts) x / L with
    Ts = (kappa Tb / L + h Tair + q) / (kappa / L + h), so
    dTs/dkappa = (Tb - Ts) / (L (kappa/L + h)), dTs/dh = (Tair - Ts) / (kappa/L + h), dT/dC = 0."""
    kappa, h, C, L, T_air, T_b = 1.3, 10.0, 1.0e6, 0.05, 20.0, 30.0
    meas, Ts = _steady_case(kappa, h, T_air=T_air, T_b=T_b, L=L)
    model = Model(meas, Grid.build(meas, dx=0.0025, dt=300.0), HBasis.pieces(meas.t, [0, 48]))
    vals = {"kappa": kappa, "C": C, "h_1": h}
    sens = reduced_sensitivity(model, vals, ["kappa", "C", "h_1"])
    # the base run stays at the steady state (the discrete steady state is exactly linear)
    np.testing.assert_allclose(sens.base, meas.T_obs, atol=1e-9)
    D = kappa / L + h
    w = 1 - meas.depths / L
    expect_k = kappa * (T_b - Ts) / (L * D) * w
    expect_h = h * (T_air - Ts) / D * w
    last = sens.coefficients[-1]  # 48 h later: the perturbed runs have relaxed (L^2 C/kappa ~ 1 h)
    np.testing.assert_allclose(last[:, 0], expect_k, rtol=1e-4, atol=1e-9)
    np.testing.assert_allclose(last[:, 2], expect_h, rtol=1e-4, atol=1e-9)
    np.testing.assert_allclose(last[:, 1], 0.0, atol=1e-7)


def test_parameter_values_groups_and_errors(case_a):
    v = parameter_values(case_a.space, {"h": 7.0, "h_2": 3.0, "kappa": 1.1})
    assert v["h_1"] == 7.0 and v["h_3"] == 7.0 and v["h_2"] == 3.0 and v["kappa"] == 1.1
    assert v["C"] == case_a.space["C"].value
    with pytest.raises(ValueError, match="unknown parameter 'kapa'.*valid"):
        parameter_values(case_a.space, {"kapa": 1.0})
    with pytest.raises(ValueError, match="not a finite"):
        parameter_values(case_a.space, {"kappa": float("nan")})


def _fake(columns: np.ndarray, names: list[str]) -> Sensitivity:
    n_rows = columns.shape[0]
    coef = np.zeros((n_rows + 1, 1, len(names)))
    coef[1:, 0, :] = columns
    return Sensitivity(names, np.ones(len(names)), np.ones(len(names)), np.arange(n_rows + 1.0),
                       ["0cm"], np.zeros((n_rows + 1, 1)), coef, 1e-2)


def test_identifiability_flags_confounded_pairs():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=200), rng.normal(size=200)
    cols = np.column_stack([a, -2.0 * a + 1e-6 * b, b, np.zeros(200)])
    ident = identifiability(_fake(cols, ["p", "q", "r", "s"]), sigma=0.5)
    assert ident.pairs[0][:2] == ("p", "q") and ident.pairs[0][2] == pytest.approx(-1, abs=1e-6)
    assert len(ident.pairs) == 1
    assert ident.condition_number > 1e5
    text = " ".join(ident.verdict)
    assert "p and q" in text and "no information on s" in text
    ok = identifiability(_fake(np.column_stack([a, b]), ["p", "r"]), sigma=0.5)
    assert ok.pairs == [] and ok.condition_number < 2
    np.testing.assert_allclose(ok.rel_sd_alone, [0.5 / np.linalg.norm(a), 0.5 / np.linalg.norm(b)])


def test_case_a_identifiability_runs(case_a):
    vals = parameter_values(case_a.space, {"kappa": 1.3, "C": 1.0e6})
    sens = reduced_sensitivity(case_a.model, vals, default_names(case_a.space))
    ident = identifiability(sens, case_a.meas.sigma)
    assert ident.correlation.shape == (5, 5)
    np.testing.assert_allclose(np.diag(ident.correlation), 1.0)
    assert np.isfinite(ident.condition_number)
    assert ident.to_dict()["names"] == ["kappa", "C", "h_1", "h_2", "h_3"]
