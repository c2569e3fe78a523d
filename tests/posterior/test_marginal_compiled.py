"""The compiled marginal-GMRF terms give NumPy's and SciPy's numbers to the bit (hmc's chains
depend on it), for rows of h in either memory layout and beyond the table's ends."""

import numpy as np
import pytest

from pavement_mcmc.parameters.priors import Rayleigh
from pavement_mcmc.posterior.marginal import MarginalGMRF


def _numpy_terms(tab, H):
    dh = np.diff(H, axis=1)
    S = np.sum(dh * dh, axis=1)
    Z = np.zeros_like(H)
    Z[:, :-1] -= dh
    Z[:, 1:] += dh
    return tab.log_f(S), tab.mean_gamma(S), Z


@pytest.mark.parametrize("order", ["C", "F"])
def test_terms_equal_the_numpy_path_bit_for_bit(order):
    tab = MarginalGMRF(112, Rayleigh(2.22))
    rng = np.random.default_rng(3)
    for scale in (1e-7, 1e-3, 1.0, 30.0, 1e6):  # S below, inside and beyond the table
        H = np.asarray(np.abs(rng.normal(10.0, 5.0, (16, 112))) * scale, order=order)
        H[0] = 4.0  # a flat h: S = 0
        want = _numpy_terms(tab, H)
        got = tab.terms(H)
        for w, g in zip(want, got, strict=True):
            assert np.array_equal(w, g), np.max(np.abs(w - g))


def test_terms_gradient_is_the_derivative_of_log_f():
    tab = MarginalGMRF(20, Rayleigh(2.22))
    h = np.random.default_rng(4).normal(5.0, 2.0, 20)
    f, mg, Z = tab.terms(h[None])
    eps = 1e-6
    for j in (0, 7, 19):
        e = np.zeros(20)
        e[j] = eps
        num = (tab.terms((h + e)[None])[0] - tab.terms((h - e)[None])[0]) / (2 * eps)
        assert num[0] == pytest.approx(-mg[0] * Z[0, j], rel=1e-6, abs=1e-9)


def test_terms_of_a_strided_view_follow_numpy():
    """A view that is neither C- nor F-contiguous (NumPy's summation order unknown to the
    compiled path) takes NumPy's own steps."""
    tab = MarginalGMRF(40, Rayleigh(2.22))
    big = np.asfortranarray(np.abs(np.random.default_rng(6).normal(10.0, 5.0, (16, 80))))
    H = big[:, ::2]
    assert not (H.flags.c_contiguous or H.flags.f_contiguous)
    for w, g in zip(_numpy_terms(tab, H), tab.terms(H), strict=True):
        assert np.array_equal(w, g)
