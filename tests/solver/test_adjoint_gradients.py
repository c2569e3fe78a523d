"""The compiled conversion of the reverse sweep's sums into gradients
(:func:`pavement_mcmc.solver.kernels.adjoint.gradient_terms`) gives the NumPy expressions'
floats bit for bit, on a uniform and a stretched grid (so chains do not change)."""

from __future__ import annotations

import numpy as np
import pytest

from pavement_mcmc.solver import Grid
from pavement_mcmc.solver.adjoint import _gradients


def _numpy_gradients(grid, kappa, C, h, q, acc_a, acc_b, acc_h, acc_q):
    """The NumPy expressions the compiled conversion replaced (as they were)."""
    S, N = kappa.shape
    geom = grid._rate_geometry()
    Cn = C[:, :N]
    f = np.ones(N)
    f[0] = 2.0
    gk = -f * acc_a / Cn
    gk[:, :-1] += geom.vol_ratio * acc_b[:, :-1] / Cn[:, 1:]
    gk /= geom.den
    sg = f * kappa * acc_a
    sg[:, 1:] -= kappa[:, :-1] * acc_b[:, :-1] * geom.inv_rho[1:]
    sg /= Cn * geom.Vd * geom.d
    hs = 2.0 / (Cn[:, 0] * geom.dx0)
    sg[:, 0] += hs * (np.sum(h * acc_h, axis=1) - np.sum(q * acc_q, axis=1))
    gC = np.zeros((S, N + 1))
    gC[:, :N] = sg / Cn
    return {"kappa": gk, "C": gC, "h": -hs[:, None] * acc_h, "q": hs[:, None] * acc_q}


@pytest.mark.parametrize("stretched", [False, True])
def test_compiled_gradient_terms_equal_numpy_bitwise(stretched):
    t = np.arange(0.0, 12 * 900.0 + 1, 900.0)
    grid = (Grid.stretched(0.5, t, dx_top=0.004, growth=1.1, dx_max=0.03) if stretched
            else Grid.from_times(0.05, t))
    assert grid.uniform is not stretched
    rng = np.random.default_rng(7)
    S, N, n_obs = 16, grid.n_nodes - 1, t.size
    kappa = rng.uniform(0.5, 2.0, (S, N))
    C = rng.uniform(1e6, 3e6, (S, N + 1))
    h, q = rng.uniform(0, 30, (S, n_obs - 1)), rng.normal(0, 100, (S, n_obs))
    # the reverse sweep's sums as the adjoint hands them over: transposed (n, S) buffers
    acc = [rng.normal(0, 10.0 ** rng.uniform(-3, 3), (n, S)).T for n in (N, N, n_obs - 1, n_obs)]
    ref = _numpy_gradients(grid, kappa, C, h, q, *acc)
    got = _gradients(grid, kappa, C, h, q, *acc)
    for k in ref:
        assert np.array_equal(ref[k], got[k]), k
