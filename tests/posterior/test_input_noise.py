"""Noisy boundary and initial temperatures integrated out of the likelihood (input_noise)."""

from __future__ import annotations

import numpy as np
import pytest

from pavement_mcmc.physics import HBasis, Model
from pavement_mcmc.posterior import LogPosterior, attach_input_noise
from pavement_mcmc.posterior.input_noise import InputNoise, input_jacobian
from pavement_mcmc.solver import Forcing, Grid, solve
from pavement_mcmc.synthetic import SyntheticSpec, simulate, to_measurements

TRUE = {"kappa": 1.31, "C": 0.99e6, "h": 10.0}


def _twin(seed: int, clean_inputs: bool = False):
    spec = SyntheticSpec(kappa=TRUE["kappa"], C=TRUE["C"], sigma=0.25, hours=12,
                         h_knots=(TRUE["h"], TRUE["h"]), seed=seed, emission=False,
                         forcing="linear", forcing_noise=False, spinup_hours=24)
    cols, truth = simulate(spec)
    if clean_inputs:
        labels = [k for k in cols if k.startswith("T_") and k.endswith("cm")]
        for j, lab in enumerate(labels):
            cols[lab] = np.array(cols[lab], float)
            cols[lab][0] = truth.T_clean[0, j]
        cols[labels[-1]] = np.array(truth.T_clean[:, len(labels) - 1], float)
    meas = to_measurements(cols, sigma=0.25)
    model = Model(meas, Grid.build(meas), HBasis.pieces(meas.t, [0, meas.t[-1] / 3600]))
    return LogPosterior(model, model.parameter_space())


def _true_theta(post):
    return np.array([[TRUE["kappa"], TRUE["C"], TRUE["h"]]])


def test_jacobian_predicts_the_response_to_perturbed_inputs():
    """The conduction model is linear in its boundary, initial and surface data: U eps must
    reproduce an actual solve with every input perturbed at random (bottom series incl. t = 0,
    initial readings, air temperature, net radiation) to round-off, and fail if a column were
    misplaced."""
    from dataclasses import replace

    post = _twin(1)
    model, meas = post.model, post.meas
    p = post.space.expand(_true_theta(post))
    U = input_jacobian(model, p)
    n_obs, n_s = meas.n_obs, meas.n_sensors
    assert {k: v.shape[1] for k, v in U.items()} == {"bottom": n_obs, "initial": n_s,
                                                     "T_air": n_obs, "q_net": n_obs}
    rng = np.random.default_rng(0)
    eps = {k: (5.0 if k == "q_net" else 0.3) * rng.standard_normal(v.shape[1]) for k, v in U.items()}
    base = model.forcing
    depths = np.append(meas.depths, meas.bottom_depth)
    Tb = base.T_bottom + eps["bottom"]
    T0 = np.interp(model.grid.x, depths, np.append(meas.T_obs[0] + eps["initial"], Tb[0]))
    c = model.coefficients(p)
    c = replace(c, q=c.q + eps["q_net"][None, :])
    T = solve(model.grid, Forcing(base.T_air + eps["T_air"], Tb, T0), c, scheme=model.scheme)
    moved = model.observe(T, p)[0, 1:].ravel() - post.predict(_true_theta(post))[0, 1:].ravel()
    np.testing.assert_allclose(sum(U[k] @ eps[k] for k in U), moved, atol=1e-9)
    assert np.abs(moved).max() > 0.1  # the inputs matter
    # the deeper the sensor, the more it follows the 5 cm boundary and the less the air
    share = {k: np.sum(U[k] ** 2, axis=1).reshape(n_obs - 1, n_s).mean(axis=0) for k in U}
    assert np.all(np.diff(share["bottom"]) > 0) and share["bottom"][-1] > 2 * share["bottom"][0]
    assert np.all(np.diff(share["T_air"]) < 0)
    with pytest.raises(ValueError, match="valid"):
        input_jacobian(model, p, kinds=("wind",))


def test_whitening_matches_the_dense_covariance():
    rng = np.random.default_rng(1)
    n, k, sigma, sigma_in = 60, 9, 0.25, 0.3
    U = rng.standard_normal((n, k)) * 0.5
    V = rng.standard_normal((n, 3)) * 0.5
    noise = InputNoise.from_jacobian({"bottom": U, "q_net": V}, sigma, {"bottom": sigma_in, "q_net": 2.0})
    Sigma = sigma**2 * np.eye(n) + sigma_in**2 * U @ U.T + 4.0 * V @ V.T
    r = rng.standard_normal((4, n))
    z = noise.whiten(r)
    np.testing.assert_allclose(np.sum(z * z, axis=1),
                               np.einsum("ij,ij->i", r, np.linalg.solve(Sigma, r.T).T), rtol=1e-10)
    np.testing.assert_allclose(noise.logdet, np.linalg.slogdet(Sigma)[1], rtol=1e-12)
    np.testing.assert_allclose(noise.marginal_sd, np.sqrt(np.diag(Sigma)), rtol=1e-12)
    with pytest.raises(ValueError):
        InputNoise.from_jacobian({"bottom": U}, 0.0, {"bottom": 0.3})


def test_likelihood_with_zero_input_noise_is_the_independent_one():
    post = _twin(2)
    th = _true_theta(post) * np.array([[1.1, 0.9, 1.2]])
    before = post.log_prob(th)
    attach_input_noise(post, 0.0, theta_ref=_true_theta(post)[0])
    np.testing.assert_allclose(post.log_prob(th), before, rtol=1e-12)


def test_whitened_residuals_are_unit_variance_on_independent_twins():
    """At the true parameters, on data from the independent simulator with noisy 5 cm and
    initial readings: residuals / sigma have a mean square clearly above 1 at the deep sensors
    (the inputs' noise), the whitened ones have mean square 1 within sampling error; with
    clean inputs the plain ones are already ~1 (so the test can tell the two apart)."""
    plain, white, clean = [], [], []
    for seed in (11, 12, 13, 14):
        post = _twin(seed)
        th = _true_theta(post)
        r = post.residuals(th)
        plain.append(np.mean((r[0, :, -1] / post.sigma) ** 2))  # deepest observed sensor
        attach_input_noise(post, 0.25, theta_ref=th[0])
        white.append(np.mean(post.standardized_residuals(r)[0] ** 2))
        pc = _twin(seed, clean_inputs=True)
        clean.append(np.mean((pc.residuals(th)[0, :, -1] / pc.sigma) ** 2))
    n = r[0].size * 4
    assert np.mean(plain) > 1.25
    assert abs(np.mean(white) - 1.0) < 4 * np.sqrt(2.0 / n) + 0.05
    assert abs(np.mean(clean) - 1.0) < 0.2


def test_reading_a_run_back_never_reoptimises(tmp_path, monkeypatch):
    """The point the inputs' noise was linearised at is stored with the run; reading the run
    back (load_run, the report's view, the criticism's point estimate) rebuilds the same
    likelihood without a single least-squares fit, and a resume continues on it."""
    from pathlib import Path

    from scipy import optimize

    from pavement_mcmc.runs import fit, load_run, load_view, point_estimate

    case = Path(__file__).resolve().parents[2] / "runs" / "caseA.toml"
    out = fit(case, tmp_path / "run", seed=5, overrides={
        "data": {"input_sigma": 0.25},
        "sampler": {"kind": "emcee", "max_steps": 40, "n_walkers": 12}})
    stored = out.problem.input_ref
    assert stored is not None and set(stored) == set(out.problem.space.free)
    calls = []
    real = optimize.least_squares
    monkeypatch.setattr(optimize, "least_squares", lambda *a, **k: calls.append(1) or real(*a, **k))
    problem, run = load_run(tmp_path / "run")
    view = load_view(tmp_path / "run")
    point_estimate(tmp_path / "run")
    assert calls == [], f"{len(calls)} least-squares fits while reading a run"
    assert run.meta["input_ref"] == stored
    theta = run.chain[-1]
    # the same likelihood to rounding: outside `fit` (which holds BLAS to one thread) the
    # whitening's BLAS may run on two threads and round the last bit differently (1.7e-16
    # relative, seen on a loaded 2-core machine)
    ref = out.problem.posterior(theta)[0]
    np.testing.assert_allclose(problem.posterior(theta)[0], ref, rtol=1e-13, atol=0)
    np.testing.assert_allclose(view.problem.posterior(theta)[0], ref, rtol=1e-13, atol=0)


def test_criticism_scores_through_the_posteriors_whitening():
    """With the inputs' noise integrated out, the criticism's residual report, its MAP refits and
    its hold-out density use the posterior's whitened residuals and marginal sds, not
    ``residuals / meas.sigma`` (which the whitening makes visibly different here)."""
    from pathlib import Path

    from pavement_mcmc.criticism.fitting import refit
    from pavement_mcmc.criticism.residuals import analyse_point
    from pavement_mcmc.data import load_case
    from pavement_mcmc.posterior import build_problem

    toml = Path(__file__).resolve().parents[2] / "runs" / "caseA.toml"
    cfg = load_case(toml, {"data": {"input_sigma": 0.25}})
    pb = build_problem(cfg, input_noise={})  # linearised at the parameters' values: no MAP
    post = pb.posterior
    assert post.input_noise is not None
    values = pb.space.value_dict()
    theta = np.array([[values[n] for n in pb.space.free]])
    z = post.standardized_residuals(post.residuals(theta))[0]
    rep = analyse_point(pb, values)
    np.testing.assert_allclose(rep.whitened.ravel(), z, rtol=1e-10, atol=1e-12)
    assert rep.rmse_sigma == pytest.approx(np.sqrt(np.mean(z**2)), rel=1e-12)
    naive = rep.rmse / float(cfg.measurements.sigma)
    assert abs(rep.rmse_sigma - naive) > 0.05 * naive  # the whitening matters on this case
    for s, lab in enumerate(rep.labels):
        assert rep.sensors[s].rmse_sigma == pytest.approx(
            np.sqrt(np.mean(z.reshape(rep.residuals.shape)[:, s] ** 2)), rel=1e-12), lab
    fit = refit(pb, values, max_nfev=3)
    zf = post.standardized_residuals(fit.residuals[None])[0]
    assert fit.rmse_sigma == pytest.approx(np.sqrt(np.mean(zf**2)), rel=1e-10)
    assert fit.chi2 == pytest.approx(float(np.sum(post.whitened(fit.theta[None]) ** 2)), rel=1e-10)
    np.testing.assert_allclose(post.marginal_sd().ravel(), post.input_noise.marginal_sd)
