"""Diagnostics against answers that do not come from the code under test (AR(1) theory, iid)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from pavement_mcmc import diagnostics as dg


def ar1(rng: np.random.Generator, phi: float, n: int, shape: tuple[int, ...] = ()) -> np.ndarray:
    """AR(1) chains x_t = phi x_{t-1} + eps_t started in the stationary law; shape (n, *shape)."""
    eps = rng.standard_normal((n, *shape))
    x = np.empty_like(eps)
    x[0] = eps[0] / np.sqrt(1 - phi**2)
    for t in range(1, n):
        x[t] = phi * x[t - 1] + eps[t]
    return x


@pytest.mark.parametrize("phi", [0.5, 0.9])
def test_integrated_time_ar1(phi: float) -> None:
    rng = np.random.default_rng(1)
    x = ar1(rng, phi, 20_000, (8, 2))
    tau = dg.integrated_time(x)
    expected = (1 + phi) / (1 - phi)
    assert tau.shape == (2,)
    np.testing.assert_allclose(tau, expected, rtol=0.1)


def test_integrated_time_1d_and_2d_shapes() -> None:
    rng = np.random.default_rng(2)
    x = ar1(rng, 0.5, 50_000)
    assert dg.integrated_time(x).shape == (1,)
    np.testing.assert_allclose(dg.integrated_time(x), 3.0, rtol=0.1)
    assert dg.integrated_time(x.reshape(-1, 5)).shape == (1,)


def test_autocorr_error_on_short_chain_carries_estimate() -> None:
    rng = np.random.default_rng(3)
    x = ar1(rng, 0.9, 300, (4, 1))  # tau ~ 19, so 300 < 50 tau
    with pytest.raises(dg.AutocorrError) as info:
        dg.integrated_time(x)
    assert info.value.tau.shape == (1,)
    assert 5 < info.value.tau[0] < 40
    with pytest.warns(dg.AutocorrWarning):
        tau = dg.integrated_time(x, quiet=True)
    np.testing.assert_array_equal(tau, info.value.tau)


def test_constant_chain_has_infinite_tau() -> None:
    x = np.ones((200, 3, 1))
    assert np.isinf(dg.integrated_time(x, quiet=True, tol=0))[0]
    assert dg.ess(x)[0] == 0


def test_ess_iid_close_to_n() -> None:
    rng = np.random.default_rng(4)
    x = rng.standard_normal((5000, 4, 3))
    np.testing.assert_allclose(dg.ess(x), 20_000, rtol=0.15)
    np.testing.assert_allclose(dg.mcse(x), 1 / np.sqrt(20_000), rtol=0.1)


def test_mcse_ar1() -> None:
    rng = np.random.default_rng(5)
    phi = 0.9
    x = ar1(rng, phi, 40_000)
    sd = 1 / np.sqrt(1 - phi**2)
    expected = sd * np.sqrt((1 + phi) / (1 - phi) / 40_000)
    np.testing.assert_allclose(dg.mcse(x), expected, rtol=0.15)


def test_mcse_sd_iid_normal_and_heavy_tailed() -> None:
    """The sd's standard error is sd / sqrt(2 n) for iid normal draws, and twice that,
    sqrt(2 / n), for iid exponential ones (excess kurtosis 6), where the Gaussian formula
    sd / sqrt(2 ess) would still say sqrt(1 / (2 n))."""
    rng = np.random.default_rng(6)
    n = 20_000
    normal, expo = rng.standard_normal((5000, 4, 3)), rng.exponential(1.0, (5000, 4, 3))
    np.testing.assert_allclose(dg.mcse_sd(normal), 1 / np.sqrt(2 * n), rtol=0.1)
    np.testing.assert_allclose(dg.mcse_sd(expo), np.sqrt(2 / n), rtol=0.15)


def test_mcse_sd_matches_the_spread_of_the_sd_over_replicates() -> None:
    """300 independent AR(1) chains (phi = 0.9, 4000 steps, one per parameter column): the sample
    sd's scatter over them matches the mean of their ``mcse_sd`` within 15 %, and the
    theoretical value sqrt(tau_z / (2 n)) with tau_z = (1 + phi^2) / (1 - phi^2) of x^2
    (about half of x's tau: ``mcse_sd`` must use the squares' own autocorrelation)."""
    rng = np.random.default_rng(7)
    phi, n, reps = 0.9, 4000, 300
    x = np.empty((n, 1, reps))
    x[0] = rng.standard_normal((1, reps)) / np.sqrt(1 - phi**2)
    e = rng.standard_normal((n, 1, reps))
    for t in range(1, n):
        x[t] = phi * x[t - 1] + e[t]
    sds = x.reshape(n, reps).std(axis=0, ddof=1)
    sd = 1 / np.sqrt(1 - phi**2)
    theory = sd * np.sqrt((1 + phi**2) / (1 - phi**2) / (2 * n))
    m = dg.mcse_sd(x)
    np.testing.assert_allclose(np.mean(m), sds.std(ddof=1), rtol=0.15)
    np.testing.assert_allclose(np.mean(m), theory, rtol=0.1)


def test_geweke_iid_is_standard_normal() -> None:
    rng = np.random.default_rng(6)
    # 400 independent replications, one per "parameter", of a 2000-step iid chain.
    z = dg.geweke(rng.standard_normal((2000, 1, 400))).z
    assert abs(z.mean()) < 0.15
    assert 0.88 < z.std() < 1.12
    assert 0.02 < np.mean(np.abs(z) > 1.96) < 0.09


def test_geweke_ar1_is_standard_normal() -> None:
    rng = np.random.default_rng(7)
    z = dg.geweke(ar1(rng, 0.5, 4000, (1, 400))).z
    assert abs(z.mean()) < 0.15
    assert 0.85 < z.std() < 1.15


def test_geweke_detects_drift_and_relative_difference() -> None:
    rng = np.random.default_rng(8)
    n = 2000
    x = 10 + rng.standard_normal(n) + np.linspace(0, 3, n)
    g = dg.geweke(x)
    assert abs(g.z[0]) > 5
    assert not g.passed[0]
    expected_rel = abs(g.mean_first[0] - g.mean_last[0]) / abs(g.mean_last[0])
    np.testing.assert_allclose(g.rel_diff, expected_rel)
    assert 0.15 < g.rel_diff[0] < 0.25  # means ~10.15 vs ~12.25


def test_split_rhat_iid_and_shifted() -> None:
    rng = np.random.default_rng(9)
    x = rng.standard_normal((1000, 4, 2))
    r = dg.split_rhat(x)
    assert np.all(np.abs(r - 1) < 0.01)
    np.testing.assert_allclose(dg.split_rhat(x, rank_normalized=False), 1, atol=0.01)
    x[:, 0, :] += 2.0
    assert np.all(dg.split_rhat(x) > 1.1)
    assert np.all(dg.split_rhat(x, rank_normalized=False) > 1.1)


def test_split_rhat_catches_drift_in_single_chain() -> None:
    rng = np.random.default_rng(10)
    x = rng.standard_normal(2000) + np.linspace(0, 4, 2000)
    assert dg.split_rhat(x)[0] > 1.1


def test_acceptance_over_time() -> None:
    acc = np.zeros((100, 4), dtype=bool)
    acc[50:] = True
    acc[:50, 0] = True  # 25 % before step 50
    a = dg.acceptance_over_time(acc, window=10)
    assert a.shape == (100,)
    np.testing.assert_allclose(a[:50], 0.25)
    np.testing.assert_allclose(a[59:], 1.0)
    np.testing.assert_allclose(a[54], (5 * 0.25 + 5 * 1.0) / 10)


def test_autocovariance_norm_ar1() -> None:
    rng = np.random.default_rng(11)
    phi = 0.8
    x = ar1(rng, phi, 20_000, (4, 3))
    x[..., 2] *= 1e6  # a parameter in very different units does not change the answer
    g = dg.autocovariance_norm(x, max_lag=10)
    assert g.shape == (11,)
    assert g[0] == 1.0
    np.testing.assert_allclose(g, phi ** np.arange(11), atol=0.03)
    g2 = dg.autocovariance_norm(x, max_lag=10, ord=2)
    np.testing.assert_allclose(g2, phi ** np.arange(11), atol=0.05)


def test_autocovariance_norm_matches_direct_sum() -> None:
    rng = np.random.default_rng(12)
    x = rng.standard_normal((50, 2, 3)).cumsum(axis=0)
    lag = 4
    y = x - x.mean(axis=0)
    y = y / x.reshape(-1, 3).std(axis=0)
    gam = [sum(y[: 50 - k, j].T @ y[k:, j] for j in range(2)) for k in (0, lag)]
    expected = np.linalg.norm(gam[1]) / np.linalg.norm(gam[0])
    np.testing.assert_allclose(dg.autocovariance_norm(x, lag)[lag], expected, rtol=1e-10)


def test_segment_summary() -> None:
    x = np.arange(100.0).reshape(100, 1, 1) * np.ones((1, 2, 2))
    s = dg.segment_summary(x, 4)
    np.testing.assert_array_equal(s.edges, [0, 25, 50, 75, 100])
    assert len(s.samples) == 4 and s.samples[0].shape == (50, 2)
    np.testing.assert_allclose(s.mean[:, 0], [12, 37, 62, 87])
    assert s.quantiles.shape == (4, 5, 2)
    np.testing.assert_allclose(s.quantiles[1, 2, 0], 37)


def transient_logp(rng: np.random.Generator, n: int, scale: float, n_chains: int) -> np.ndarray:
    """Stationary AR(1) noise plus an exponential approach -50 exp(-t / scale)."""
    t = np.arange(n)[:, None]
    return -50.0 * np.exp(-t / scale) + ar1(rng, 0.5, n, (n_chains,))


@pytest.mark.parametrize("n_chains", [1, 16])
def test_choose_burn_in_finds_transient(n_chains: int) -> None:
    rng = np.random.default_rng(13)
    scale = 100.0
    lp = transient_logp(rng, 5000, scale, n_chains)
    # The transient is below the noise level (sd ~ 1.15 / sqrt(n_chains)) after a few scales.
    b = dg.choose_burn_in(lp)
    assert 2.5 * scale <= b <= 8 * scale
    b_med = dg.choose_burn_in(lp, method="median")
    assert 2 * scale <= b_med <= 8 * scale
    assert not dg.is_drifting(lp[b:])


def test_choose_burn_in_stationary_is_small() -> None:
    rng = np.random.default_rng(14)
    lp = ar1(rng, 0.5, 5000, (8,))
    assert dg.choose_burn_in(lp) < 500


def test_choose_burn_in_rejects_unknown_method() -> None:
    with pytest.raises(ValueError, match="mser"):
        dg.choose_burn_in(np.zeros(100), method="nope")


def test_is_drifting() -> None:
    rng = np.random.default_rng(15)
    n = 4000
    stationary = ar1(rng, 0.9, n, (4,))
    assert not dg.is_drifting(stationary)
    trend = stationary + np.linspace(0, 3, n)[:, None]
    assert dg.is_drifting(trend)
    # False-alarm rate on stationary AR(1) chains stays small at the default threshold.
    alarms = sum(dg.is_drifting(ar1(rng, 0.9, 2000)) for _ in range(100))
    assert alarms <= 4


def test_summary() -> None:
    rng = np.random.default_rng(16)
    x = rng.normal(loc=[1.0, -2.0], scale=[0.5, 2.0], size=(2000, 4, 2))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = dg.summary(x, ["kappa", "C"])
    assert set(s) == {"kappa", "C"}
    k = s["kappa"]
    assert abs(k["mean"] - 1.0) < 0.02 and abs(k["sd"] - 0.5) < 0.02
    assert abs(k["q50"] - 1.0) < 0.03 and k["q2.5"] < k["q50"] < k["q97.5"]
    assert 6000 < k["ess"] < 10000 and abs(k["rhat"] - 1) < 0.01 and abs(k["geweke_z"]) < 3.5
    with pytest.raises(ValueError, match="names"):
        dg.summary(x, ["a"])


def test_geweke_components_count_one_fluctuation_once():
    """40 parameters sharing one AR(1) factor: an early shift of the factor by ~2.5 of its
    standard errors (an ordinary 1-in-80 event for ONE test) flags most parameters, but only one
    principal component; a shift 4x as large is still flagged by the components."""
    from pavement_mcmc.diagnostics import geweke, geweke_components

    rng = np.random.default_rng(3)
    n, m, p = 1000, 8, 40
    f = np.zeros((n, m))
    e = rng.normal(size=(n, m))
    for t in range(1, n):
        f[t] = 0.8 * f[t - 1] + 0.6 * e[t]  # unit variance, tau = 9
    load = rng.uniform(0.8, 1.2, p)
    noise = 0.3 * rng.normal(size=(n, m, p))

    def chain(shift):
        g = f.copy()
        g[: n // 10] += shift
        return g[:, :, None] * load + noise

    z_factor = geweke(f[:, :, None]).z[0]
    se = float(np.sqrt(9.0 / (n // 10 * m) + 9.0 / (n // 2 * m)))  # sd of the factor's diff
    x = chain((2.5 - z_factor) * se)  # the factor's z becomes ~2.5
    zp = geweke(x).z
    zc = geweke_components(x)
    assert np.mean(np.abs(zp) >= 1.96) > 0.5
    assert np.sum(np.abs(zc) >= 1.96) <= 0.1 * p and np.abs(zc).max() < 3.5
    assert np.abs(geweke_components(chain(10 * se))).max() > 3.5


def test_tau_of_antithetic_chains_sees_a_slow_positive_tail():
    """x = -0.7 * previous noise + a slow AR(1) part: lag-1 correlation about -0.4 (Sokal's window
    closes at lag 1) but a positive tail; the estimate follows the true tau (Geyer), not 0.1."""
    from pavement_mcmc.diagnostics import integrated_time

    rng = np.random.default_rng(0)
    n, m = 20000, 8
    e = rng.normal(size=(n + 1, m))
    fast = e[1:] - 0.9 * e[:-1]  # MA(1): rho1 = -0.9/1.81
    slow = np.zeros((n, m))
    u = rng.normal(size=(n, m))
    for t in range(1, n):
        slow[t] = 0.95 * slow[t - 1] + np.sqrt(1 - 0.95**2) * u[t]
    x = fast + 0.35 * slow
    v_f, v_s = 1.81, 0.35**2
    rho = lambda k: (np.where(k == 1, -0.9, 0.0) + v_s * 0.95**k) / (v_f + v_s)  # noqa: E731
    k = np.arange(1, 400)
    true_tau = 1 + 2 * rho(k).sum()
    assert rho(np.array([1]))[0] < -0.4
    tau = integrated_time(x[:, :, None], quiet=True)[0]
    assert abs(tau - true_tau) < 0.3 * true_tau, (tau, true_tau)


def test_geweke_components_do_not_depend_on_units():
    """A parameter in tiny units (kappa next to C in J m-3 K-1) that shifts early is caught."""
    from pavement_mcmc.diagnostics import geweke_components

    rng = np.random.default_rng(4)
    x = rng.normal(size=(800, 8, 3))
    x[:80, :, 0] += 1.0  # an early shift of ~8 standard errors in parameter 0
    x[:, :, 0] *= 1e-3
    x[:, :, 1] *= 2e4
    x[:, :, 2] = 1e6 + 2e4 * x[:, :, 2]
    assert np.abs(geweke_components(x)).max() > 3.5
    x[:80, :, 0] -= 1e-3
    assert np.abs(geweke_components(x)).max() < 3.5
