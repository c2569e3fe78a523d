"""The compiled temperature path (:mod:`pavement_mcmc.posterior.compiled`) gives the generic
NumPy path's numbers bit for bit (so chains do not change), with a masked (non-finite) row, and
is used exactly when it applies."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.posterior.compiled import _pairwise_sum
from pavement_mcmc.posterior.observations import log_likelihood

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("n", [1, 7, 8, 13, 128, 129, 560, 4321])
def test_pairwise_sum_is_numpys(n):
    rng = np.random.default_rng(n)
    for _ in range(20):
        a = rng.standard_normal(n) ** 2 * 10.0 ** rng.uniform(-4, 4)
        assert _pairwise_sum(a, 0, n) == np.sum(a)


def _generic(post, T):
    """The generic path of ``LogPosterior.loglik_and_grad``'s cotangent for the temperatures."""
    st, model = post.streams[0], post.model
    pred = model.observe(T, {})
    r = pred[:, 1:, :] - st.data
    z = st.whiten(r)
    ll = log_likelihood(post.streams, z)
    ok = np.isfinite(ll)
    gT, _ = st.vjp(model, pred, r, z, ok, T, None, {}, None)
    return np.where(ok, ll, -np.inf), np.sqrt(np.mean(r * r, axis=1)), gT


@pytest.mark.parametrize("case", ["caseA", "caseC"])
def test_compiled_terms_equal_generic_bitwise(case):
    post = build_problem(load_case(REPO / "runs" / f"{case}.toml")).posterior
    st, model = post.streams[0], post.model
    assert st.compiled_applies(model)
    rng = np.random.default_rng(3)
    n_obs, n_nodes = model.grid.n_obs, model.grid.n_nodes
    # the solver's layout (a transposed view of a sets-innermost buffer) and C order: NumPy
    # sums the squares in sequence for the one, pairwise for the other
    T = (20.0 + 5.0 * rng.standard_normal((n_obs, n_nodes, 6))).transpose(2, 0, 1)
    T[2, 5, 3] = np.nan  # a failed set: -inf, no gradient
    for layout in (T, np.ascontiguousarray(T)):
        ref = _generic(post, layout)
        got = st.compiled_terms(model, layout)
        for a, b in zip(ref, got, strict=True):
            assert a.shape == b.shape
            assert np.array_equal(a, b, equal_nan=True)
        assert got[0][2] == -np.inf and not got[2][2].any()
    assert st.compiled_terms(model, T[:, :, ::-1]) is None  # another layout: the generic path
    # one set: the solver's buffer and C order at once; NumPy sums its residual row pairwise
    one = (20.0 + 5.0 * rng.standard_normal((n_obs, n_nodes, 1))).transpose(2, 0, 1)
    for a, b in zip(_generic(post, one), st.compiled_terms(model, one), strict=True):
        assert np.array_equal(a, b)


def test_compiled_path_used_only_when_it_applies():
    pb = build_problem(load_case(REPO / "runs" / "caseA.toml"), extensions=["sensor_depth"])
    st, model = pb.posterior.streams[0], pb.posterior.model
    assert not model.observes_nominal and not st.compiled_applies(model)
    plain = build_problem(load_case(REPO / "runs" / "caseA.toml")).posterior
    plain.streams[0].input_noise = object()  # whitened by an input-noise covariance
    assert not plain.streams[0].compiled_applies(plain.model)


def test_compiled_temperatures_beside_a_plate_equal_generic_bitwise(tmp_path, monkeypatch):
    """With a heat-flux plate as a second stream, the temperatures' part still takes the
    compiled path; the log-likelihood (summed over both streams' whitened residuals), its
    gradient and the blobs are the generic path's to the bit. The compiled residuals must come
    in the layout NumPy's whitening gives, which decides the order of the sum of squares."""
    from pavement_mcmc.posterior.observations import Temperatures
    from pavement_mcmc.synthetic.corpus import field_twins, write_twin

    twin = field_twins()[1]
    toml = write_twin(twin, tmp_path / twin.name)
    cfg = load_case(toml, {"data": {"window_hours": [0, 24]},
                           "model": {"h": {"kind": "uniform", "n": 12}},
                           "grid": {"dx": 0.01, "dt": 600.0}})
    post = build_problem(cfg).posterior
    assert len(post.streams) == 2 and post.streams[0].compiled_applies(post.model)
    rng = np.random.default_rng(5)
    th = np.repeat(post.space.initial()[None], 5, 0) * (1 + 0.05 * rng.standard_normal((5, 1)))
    used = []
    original = Temperatures.compiled_cotangent

    def spy(self, *a):
        used.append(True)
        return original(self, *a)

    monkeypatch.setattr(Temperatures, "compiled_cotangent", spy)
    got = post.loglik_and_grad(th, "adjoint")
    assert used  # the compiled path was taken
    monkeypatch.setattr(Temperatures, "compiled_applies", lambda self, model: False)
    ref = post.loglik_and_grad(th, "adjoint")
    for a, b in zip(ref, got, strict=True):
        assert np.array_equal(a, b)


@pytest.mark.parametrize("case", ["caseA", "caseC"])
def test_loglik_blobs_compiled_equals_numpy_path(case, monkeypatch):
    """``LogPosterior.loglik_blobs`` (every sampler's log-posterior) by the compiled path gives
    the NumPy path's log-likelihood and RMSE to the bit."""
    pr = build_problem(load_case(REPO / "runs" / f"{case}.toml"))
    post = pr.posterior
    rng = np.random.default_rng(5)
    x0 = pr.space.initial()
    theta = x0 * rng.lognormal(0.0, 0.1, (9, x0.size))
    got = [post.loglik_blobs(theta), post.loglik_blobs(theta[:1])]  # one set: both layouts
    from pavement_mcmc.posterior.observations import Temperatures

    monkeypatch.setattr(Temperatures, "compiled_loglik", lambda *a: None)
    want = [post.loglik_blobs(theta), post.loglik_blobs(theta[:1])]
    for (ll, rmse), (ll0, rmse0) in zip(got, want, strict=True):
        assert np.array_equal(ll, ll0) and np.array_equal(rmse, rmse0)
        assert np.all(np.isfinite(ll))
