"""The plain model's gradient (:mod:`pavement_mcmc.posterior.plain_gradient`) gives the generic
path's numbers bit for bit (so chains do not change), is used exactly when the model is plain,
and leaves every refusal to the generic path."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem

REPO = Path(__file__).resolve().parents[2]


def _problem(case, overrides=None):
    return build_problem(load_case(REPO / "runs" / f"{case}.toml", overrides))


def _sets(space, n, seed, order="C"):
    rng = np.random.default_rng(seed)
    x0 = space.initial()
    lo, hi = space.bounds()
    th = x0 * rng.lognormal(0.0, 0.2, (n, x0.size))
    return np.asarray(np.clip(th, lo, np.where(np.isfinite(hi), hi, np.inf)), order=order)


def _both(post, theta):
    post._plain = None  # decided again: the plain path when it applies
    a = post.loglik_and_grad(theta)
    used = post._plain
    post._plain = False  # the generic path
    b = post.loglik_and_grad(theta)
    post._plain = None
    return a, b, used


@pytest.mark.parametrize("n, order", [(16, "C"), (16, "F"), (32, "C"), (13, "C")])
def test_plain_path_equals_the_generic_path_bit_for_bit(n, order):
    pr = _problem("caseC")
    theta = _sets(pr.space, n, seed=n, order=order)
    (ll, g, rmse), (ll0, g0, rmse0), used = _both(pr.posterior, theta)
    assert used  # Case C is plain
    for a, b in ((ll, ll0), (g, g0), (rmse, rmse0)):
        assert np.array_equal(a, b)
    assert np.all(np.isfinite(g)) and np.any(g != 0.0)


def test_models_that_are_not_plain_take_the_generic_path():
    pr = _problem("caseA", {"model": {"extensions": ["sensor_bias"]}})
    theta = _sets(pr.space, 16, seed=1)
    (ll, g, _), (ll0, g0, _), used = _both(pr.posterior, theta)
    assert used is False
    assert np.array_equal(ll, ll0) and np.array_equal(g, g0)


def test_a_set_the_solver_refuses_still_raises_its_error():
    pr = _problem("caseC")
    theta = _sets(pr.space, 16, seed=3)
    theta[2, pr.space.free.index("kappa")] = -1.0
    with pytest.raises(ValueError, match="positive"):
        pr.posterior.loglik_and_grad(theta)
    assert pr.posterior._plain  # it was tried, and handed the set over


def test_a_replaced_temperature_stream_is_read():
    """The plain path reads the stream the posterior holds now, not the one it was built with."""
    from pavement_mcmc.posterior.observations import Temperatures

    pr = _problem("caseC")
    post = pr.posterior
    theta = _sets(pr.space, 16, seed=4)
    post.loglik_and_grad(theta)  # the plain path built for the first stream
    new = Temperatures(post.model.meas)
    new.sigma = 0.5
    post.streams[0] = new
    ll, g, _ = post.loglik_and_grad(theta)  # the path kept from the first call, if any
    assert post._plain and post._plain.temps is new
    post._plain = False
    ll0, g0, _ = post.loglik_and_grad(theta)
    assert np.array_equal(ll, ll0) and np.array_equal(g, g0)
