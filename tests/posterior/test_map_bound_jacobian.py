"""find_map's Jacobian within one finite-difference step of a bound.

A central step across the bound was scored as outside (residuals 1e6) and made that column
~1e10: a parameter started on its bound stayed there (``fit --add two_layer`` on the desert
window: C2 started at its lower bound 1e5 and the MAP stopped at C2 100008, kappa 0.037 against
0.29), and a mode within a step of a bound got a Laplace sd ~1e-10 of the true one. The steps
are now one-sided there.
"""

from __future__ import annotations

import numpy as np

from pavement_mcmc.parameters import Flat, Parameter, ParameterSpace
from pavement_mcmc.posterior import find_map

T = np.linspace(0.0, 1.0, 21)
SIGMA = 0.1


class ToyLine:
    """y = a + b t + noise-free data, flat priors, a in [1, 10], b in [-10, 10]; the residuals
    are linear, so the least-squares mode and its covariance are known exactly."""

    def __init__(self, a: float, b: float, a0: float):
        self.y = a + b * T
        self.obs = self.y[:, None]
        self.space = ParameterSpace([Parameter("a", a0, 1.0, 10.0, prior=Flat()),
                                     Parameter("b", 1.0, -10.0, 10.0, prior=Flat())])
        self.blob_names = ["rmse"]

    def whitened(self, theta):
        th = np.atleast_2d(theta)
        return (th[:, :1] + th[:, 1:2] * T - self.y) / SIGMA

    def __call__(self, theta):
        th = np.atleast_2d(theta)
        r = self.whitened(th)
        lp = self.space.log_prior(th) - 0.5 * np.sum(r**2, axis=1)
        return lp, np.sqrt(np.mean((r * SIGMA) ** 2, axis=1))[:, None]


def _exact_sd() -> np.ndarray:
    X = np.c_[np.ones_like(T), T] / SIGMA
    return np.sqrt(np.diag(np.linalg.inv(X.T @ X)))


def test_a_start_on_the_bound_reaches_the_mode():
    post = ToyLine(a=1.5, b=2.0, a0=1.0)  # a starts on its lower bound, its mode 0.5 above it
    lap = find_map(post, log_positive=False)
    np.testing.assert_allclose(lap.theta, [1.5, 2.0], atol=1e-6)
    lp_mode = post(np.array([[1.5, 2.0]]))[0][0]
    assert post(lap.theta[None, :])[0][0] >= lp_mode - 1e-8


def test_a_mode_within_a_step_of_the_bound_has_the_gaussians_sd():
    post = ToyLine(a=1.0 + 2e-6, b=2.0, a0=3.0)  # step of a's z: 1e-5 * max(|z|, 1) > 2e-6
    lap = find_map(post, log_positive=False)
    np.testing.assert_allclose(lap.theta, [1.0 + 2e-6, 2.0], atol=1e-5)
    np.testing.assert_allclose(lap.sd, _exact_sd(), rtol=1e-3)
