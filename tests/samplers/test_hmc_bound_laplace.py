"""hmc's Laplace metric when the marginal MAP has h on its upper bound.

``find_marginal_map`` fits ``z = theta / scale`` within ``[lo / scale, hi / scale]``; for some
scales ``(hi / scale) * scale`` rounds above ``hi`` (500 for 15 % of them). The one-sided
Jacobian step onto the bound was then scored as outside (residuals 1e6): on the SoilVUE desert
window with ``two_layer`` (``runs/desert.toml``) one h at 500 got a Jacobian column of 3e10,
every Laplace sd came out ~1e-7 of its value, and hmc's metric never recovered (R-hat 2.4 after
700 steps, min ESS < 200 after 50k steps).
"""

from __future__ import annotations

import numpy as np
from test_samplers import ToyGMRF

from pavement_mcmc.parameters import Rayleigh
from pavement_mcmc.posterior.map import ScaledResiduals
from pavement_mcmc.posterior.marginal import MarginalGMRF, find_marginal_map
from pavement_mcmc.samplers import get_sampler

HI = 500.0  # ToyGMRF's upper bound of h


def _rounding_scales(n: int) -> np.ndarray:
    """Scales s of h for which (HI / s) * s rounds above HI."""
    s = np.linspace(400.0, 499.0, 5000)
    return s[(HI / s) * s > HI][:n]


def _toy_at_bound() -> ToyGMRF:
    """The GMRF toy with data around 501: most h sit on their upper bound 500 at the mode."""
    post = ToyGMRF(N=12, seed=5)
    post.y = post.y + 501.0 - post.y.mean()
    post.obs = post.y[:, None]
    return post


def test_a_z_on_its_bound_maps_onto_the_bound():
    post = _toy_at_bound()
    scales = _rounding_scales(20)
    assert scales.size == 20  # the rounding this guards against does happen
    idx = np.arange(1, post.ndim)
    for s in scales:
        scale = np.full(idx.size, s)
        res = ScaledResiduals(post, np.r_[1.0, np.full(idx.size, 10.0)], idx, scale,
                              np.zeros(idx.size, bool))
        th = res.theta((HI / scale)[None, :])[0, idx]
        assert np.all(th == HI), (s, th.max() - HI)
        out = res(((HI / scale) * (1 + 1e-6))[None, :], 1.0)[0, :res.n_res]
        assert np.all(out == 1e6)  # a point outside still is


def test_laplace_sd_of_h_on_its_upper_bound_is_the_gaussians():
    """With residuals linear in h the Gauss-Newton covariance is exact:
    (I / sigma^2 + gamma D^T D)^-1 at the returned gamma, bound or not."""
    post = _toy_at_bound()
    tab = MarginalGMRF(post.N, Rayleigh(post.g0), 0.0, 1e4)
    theta0 = np.r_[1.0, np.full(post.N, _rounding_scales(1)[0])]  # h's scale: its start value
    mm = find_marginal_map(post, tab, theta0=theta0)
    h, g = mm.theta[1:], mm.theta[0]
    assert np.all(h <= HI) and np.any(h > HI - 1e-3)  # some h on the bound
    D = np.diff(np.eye(post.N), axis=0)
    exact = np.linalg.inv(np.eye(post.N) / post.sigma**2 + g * D.T @ D)
    np.testing.assert_allclose(np.sqrt(np.diag(mm.cov)), np.sqrt(np.diag(exact)), rtol=1e-3)
    # and hmc's metric starts from it: whitened sd of h within a factor of the exact one
    smp = get_sampler("hmc", post, seed=1, options={"log_positive": False, "sqrt_at_zero": False})
    smp.prepare(theta0=theta0)
    ratio = np.sqrt(np.diag(smp.M)) / np.sqrt(np.diag(exact))
    assert np.all((ratio > 0.1) & (ratio < 10.0)), ratio
