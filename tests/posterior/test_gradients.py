"""The likelihood's adjoint gradient with extensions and heat-flux plates, against central
differences of whole solves (the coefficient derivatives the model takes by finite differences
of the coefficients, the surface layer's and the sensor hooks' exact products, and the plates'
direct dependence on the conductivity)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem

REPO = Path(__file__).resolve().parents[2]


def _central(post, theta, eps=1e-6):
    d = theta.shape[1]
    g = np.zeros_like(theta)
    for j in range(d):
        e = np.zeros(d)
        e[j] = eps * max(abs(theta[0, j]), 1e-3)
        g[:, j] = (post.loglik_blobs(theta + e)[0] - post.loglik_blobs(theta - e)[0]) / (2 * e[j])
    return g


def _point(pb, seed=1):
    """Two parameter sets near the initial values, effects switched on, sensor offsets off the
    grid's nodes (piecewise-linear interpolation has no derivative on a node)."""
    rng = np.random.default_rng(seed)
    free = pb.space.free
    th = np.repeat(pb.space.initial()[None], 2, 0) * (1 + 0.02 * rng.standard_normal((2, len(free))))
    on = {"R_surface": 0.1, "et_alpha": 0.4, "d_layer": 0.02, "rad_factor": 0.9, "evap_A": 5.0,
          "eb_alpha_1": 0.4, "eb_alpha_2": 0.4}
    for j, n in enumerate(free):
        if n in on:
            th[:, j] = on[n] * (1 + 0.1 * rng.standard_normal(2))
        elif n.startswith("dz_"):
            th[:, j] = 0.0013 + 0.0004 * j
    return th


@pytest.mark.parametrize("case, exts", [
    ("caseA", ["surface_layer", "evapotranspiration"]),
    ("caseA", ["evapotranspiration", "surface_layer"]),
    ("caseA", ["two_layer", "sensor_bias", "sensor_depth"]),
    ("caseA", ["sensor_depth", "radiation_factor"]),
    ("hidden", ["wind_convection", "evaporation"]),
    ("hidden", ["energy_balance"]),
    ("caseA", ["energy_balance", "surface_layer"]),
    ("caseA", ["surface_layer", "energy_balance"]),  # the balance's hook runs first all the same
    ("caseC", ["surface_layer"]),
])
def test_adjoint_gradient_with_extensions(case, exts):
    pb = build_problem(load_case(REPO / "runs" / f"{case}.toml"), extensions=exts)
    post = pb.posterior
    assert post.has_gradient
    th = _point(pb)
    ll, g, blobs = post.loglik_and_grad(th, "adjoint")
    ref = _central(post, th)
    if "gamma" in pb.space.free:  # the likelihood does not see gamma
        ref[:, pb.space.free.index("gamma")] = 0.0
    np.testing.assert_allclose(ll, post.loglik_blobs(th)[0], rtol=1e-12)
    np.testing.assert_allclose(g, ref, rtol=0, atol=1e-6 * np.abs(ref).max())


def test_adjoint_gradient_with_a_flux_plate(tmp_path):
    """A field twin with a 5 cm plate: the plate's readings enter the likelihood with their own
    sd, its calibration factor is a parameter, and the gradient includes the flux's direct
    dependence on kappa."""
    from pavement_mcmc.synthetic.corpus import field_twins, write_twin

    twin = field_twins()[1]
    toml = write_twin(twin, tmp_path / twin.name)
    cfg = load_case(toml, {"data": {"window_hours": [0, 24]},
                           "model": {"h": {"kind": "uniform", "n": 12}},
                           "grid": {"dx": 0.01, "dt": 600.0}})
    pb = build_problem(cfg, extensions=["evapotranspiration"])
    post = pb.posterior
    assert "plate_G5cm" in pb.space.free and post.flux_obs is not None
    assert post.blob_names[-1] == "rmse_G5cm"
    th = _point(pb)
    ll, g, blobs = post.loglik_and_grad(th, "adjoint")
    ref = _central(post, th)
    np.testing.assert_allclose(g, ref, rtol=0, atol=1e-6 * np.abs(ref).max())
    np.testing.assert_allclose(blobs, post(th)[1], rtol=1e-12)
    # the plates' part of the likelihood: with plates ignored the log-likelihood changes by it
    no_plates = build_problem(load_case(toml, {"data": {"window_hours": [0, 24], "plates": False},
                                               "model": {"h": {"kind": "uniform", "n": 12}},
                                               "grid": {"dx": 0.01, "dt": 600.0}}),
                              extensions=["evapotranspiration"]).posterior
    keep = [pb.space.free.index(n) for n in no_plates.space.free]
    rT, rG = post.data_residuals(th)
    zG = rG / post.flux_sd
    part = -0.5 * (np.sum(zG**2, axis=(1, 2)) + 2 * np.sum(np.log(post.flux_sd))
                   + zG[0].size * np.log(2 * np.pi))
    np.testing.assert_allclose(post.loglik_blobs(th)[0] - no_plates.loglik_blobs(th[:, keep])[0], part,
                               rtol=1e-10)
