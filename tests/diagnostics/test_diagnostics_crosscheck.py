"""Our hand-written IACT, ESS, MCSE, split-R-hat and Geweke spectrum against ArviZ and emcee on
chains whose answer is known: AR(1) (tau = (1 + phi) / (1 - phi)), iid, and chains that disagree.

Tolerances, and why they differ:

- ``integrated_time`` is emcee's estimator (the per-chain autocorrelation averaged over chains,
  Sokal's window with c = 5), so for positively correlated chains it equals
  ``emcee.autocorr.integrated_time`` to rounding (rtol 1e-10). Where tau < 1 (antithetic chains)
  ours takes at least Geyer's estimate and emcee's window closes at lag 1 with tau ~ 0: there
  the AR(1) truth decides (ours is right).
- split-R-hat (rank-normalised, or plain) is the same formula as ArviZ's: rtol 1e-12.
- ``ess`` uses Sokal's window, ArviZ Geyer's initial monotone sequence on split chains: different
  truncations of the same sum. On 10 000 x 4 steps of AR(1) the two agree within 12 % for each
  parameter (the scatter of either is about sqrt(2 (2 c tau + 1) / N), 10 % at phi = 0.9) and
  within 3 % on the average over 20 parameters; both are within 6 % of the truth on that average.
- ``mcse_sd`` is ArviZ's formula with our ESS of the squared deviations: within 6 %.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from pavement_mcmc import diagnostics as dg
from pavement_mcmc.diagnostics.stationarity import _spectrum0_ar

az = pytest.importorskip("arviz")
emcee = pytest.importorskip("emcee")


@pytest.fixture(autouse=True)
def _arviz_without_numba():
    """ArviZ 0.23's numba path of ``mcse(method="sd")`` fails on NumPy 2 (float() of a 1-element
    array); its NumPy path computes the same numbers."""
    was = az.Numba.numba_flag
    az.Numba.disable_numba()
    yield
    if was:
        az.Numba.enable_numba()


def ar1(rng: np.random.Generator, phi: float, n: int, shape: tuple[int, ...] = ()) -> np.ndarray:
    """AR(1) chains x_t = phi x_{t-1} + eps_t (unit innovations) started in the stationary law."""
    eps = rng.standard_normal((n, *shape))
    eps[0] /= np.sqrt(1 - phi**2)
    return lfilter([1.0], [1.0, -phi], eps, axis=0)


def tau_ar1(phi: float) -> float:
    return (1 + phi) / (1 - phi)


def sd_of_mean_ar1(phi: float, n: int, m: int) -> float:
    """Exact sd of the mean of m independent stationary AR(1) chains of n steps."""
    k = np.arange(1, n)
    var_one = (1 + 2 * np.sum((1 - k / n) * phi**k)) / (1 - phi**2) / n
    return float(np.sqrt(var_one / m))


def arviz(fn, x: np.ndarray, **kw) -> np.ndarray:
    """An ArviZ diagnostic of our (n_steps, n_chains, n_params) chain, per parameter."""
    return fn(az.convert_to_dataset(np.moveaxis(x, 0, 1)), **kw)["x"].values


@pytest.mark.parametrize("phi", [0.5, 0.9])
def test_integrated_time_equals_emcee_and_the_ar1_truth(phi: float) -> None:
    """Equal to emcee's to rounding; within 3 sd of Sokal's estimator, sqrt(2 (2 c tau + 1) / N)
    (N = all draws, c = 5), of the truth."""
    rng = np.random.default_rng(1)
    x = ar1(rng, phi, int(2000 * tau_ar1(phi)), (4, 3))
    ours = dg.integrated_time(x)
    np.testing.assert_allclose(ours, emcee.autocorr.integrated_time(x), rtol=1e-10)
    sd = np.sqrt(2 * (10 * tau_ar1(phi) + 1) / (x.shape[0] * x.shape[1]))
    np.testing.assert_allclose(ours, tau_ar1(phi), rtol=3 * sd)


def test_integrated_time_of_antithetic_chains_follows_the_truth_not_emcee() -> None:
    """phi = -0.5, tau = 1/3: Sokal's window closes at lag 1 where 1 + 2 rho(1) = 0, so emcee
    says tau ~ 0.006 (an ESS 50 times too large); our Geyer floor gives 1/3 within 10 %."""
    rng = np.random.default_rng(2)
    x = ar1(rng, -0.5, 20_000, (4, 2))
    np.testing.assert_allclose(dg.integrated_time(x), 1 / 3, rtol=0.1)
    assert np.all(emcee.autocorr.integrated_time(x, quiet=True) < 0.1)


@pytest.mark.parametrize("phi", [0.0, 0.5, 0.9, -0.5])
def test_ess_and_mcse_agree_with_arviz_and_the_truth(phi: float) -> None:
    rng = np.random.default_rng(11)
    n, m = 10_000, 4
    x = ar1(rng, phi, n, (m, 20))
    ours, theirs = dg.ess(x), arviz(az.ess, x, method="mean")
    np.testing.assert_allclose(ours / theirs, 1, rtol=0.12)
    assert abs(np.mean(ours / theirs) - 1) < 0.03
    assert abs(np.mean(ours) / (n * m / tau_ar1(phi)) - 1) < 0.06
    assert abs(np.mean(theirs) / (n * m / tau_ar1(phi)) - 1) < 0.06
    np.testing.assert_allclose(dg.mcse(x), arviz(az.mcse, x, method="mean"), rtol=0.06)
    np.testing.assert_allclose(dg.mcse_sd(x), arviz(az.mcse, x, method="sd"), rtol=0.06)


@pytest.mark.parametrize("n_taus", [20, 50])
def test_mcse_of_short_chains_matches_the_scatter_of_their_mean(n_taus: int) -> None:
    """120 replications of 32 AR(1) chains (phi = 0.9) 20 or 50 tau long, the length at which
    the run loop stops. The sd of the grand mean is known exactly; ``mcse`` must match it.

    Measured (mean MCSE / exact): ours 1.04 (20 tau) and 1.00 (50 tau), ArviZ 1.06 and 1.00,
    and the per-chain estimate sd / sqrt(N / integrated_time), which ``mcse`` used before, 0.82
    and 0.91: each chain centred on its own mean loses the slow part of its autocorrelation, so
    that ESS was 1.5 and 1.2 times too large."""
    phi, m, reps = 0.9, 32, 120
    n = int(n_taus * tau_ar1(phi))
    x = ar1(np.random.default_rng(3), phi, n, (m, reps))
    exact = sd_of_mean_ar1(phi, n, m)
    np.testing.assert_allclose(x.mean(axis=(0, 1)).std(), exact, rtol=0.15)  # the truth is right
    assert 0.95 < np.mean(dg.mcse(x)) / exact < 1.08
    assert 0.95 < np.mean(arviz(az.mcse, x, method="mean")) / exact < 1.12
    sd = x.reshape(n * m, reps).std(axis=0, ddof=1)
    per_chain = sd / np.sqrt(n * m / dg.integrated_time(x, tol=0))
    assert np.mean(per_chain) / exact < 0.95


def test_ess_of_chains_that_disagree_is_small_like_arviz() -> None:
    """Four AR(1) chains (phi = 0.5, 2000 steps), one shifted by one sd: the pooled ESS counts
    the disagreement (ours 12 of 8000, ArviZ 33; the per-chain average said 2550)."""
    x = ar1(np.random.default_rng(4), 0.5, 2000, (4, 1))
    x[:, 0] += 1.0
    ours, theirs = dg.ess(x)[0], arviz(az.ess, x, method="mean")[0]
    assert ours < 0.02 * x.shape[0] * x.shape[1]
    assert theirs < 0.02 * x.shape[0] * x.shape[1]


def _rhat_cases() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(5)
    iid = rng.standard_normal((1000, 4, 3))
    shifted = ar1(rng, 0.5, 1000, (4, 3))
    shifted[:, 0] += 0.5
    drifting = rng.standard_normal((1001, 4, 3)) + np.linspace(0, 2, 1001)[:, None, None]
    wider = rng.standard_normal((1000, 4, 3)) * np.array([1.0, 1.0, 1.0, 3.0])[:, None]
    ties = np.round(ar1(rng, 0.9, 1000, (4, 3)), 1)  # MH chains repeat values
    return {"iid": iid, "shifted": shifted, "drifting": drifting, "wider": wider, "ties": ties}


@pytest.mark.parametrize("case", ["iid", "shifted", "drifting", "wider", "ties"])
def test_split_rhat_equals_arviz(case: str) -> None:
    """Same estimator (Vehtari et al. 2021): equal to rounding, plain and rank-normalised; the
    disagreeing chains are flagged (R-hat > 1.01), the iid ones not; a chain with a wider
    spread only by the tail R-hat."""
    x = _rhat_cases()[case]
    rank, plain = dg.split_rhat(x), dg.split_rhat(x, rank_normalized=False)
    np.testing.assert_allclose(rank, arviz(az.rhat, x), rtol=1e-12)
    np.testing.assert_allclose(plain, arviz(az.rhat, x, method="split"), rtol=1e-12)
    if case == "iid":
        assert np.all(rank < 1.01)
    elif case != "ties":
        assert np.all(rank > 1.01)
    if case == "wider":
        assert np.all(arviz(az.rhat, x, method="z_scale") < 1.01)


@pytest.mark.parametrize("phi", [0.0, 0.5, 0.9])
def test_geweke_spectrum_at_zero_matches_ar1_and_emcee(phi: float) -> None:
    """Geweke's S(0) (AR fit, as R coda) against the AR(1) truth 1 / (1 - phi)^2 and emcee's
    var * tau, over 50 chains of 5000 steps: within 10 % on the average (each chain's S(0)
    scatters by about sqrt(2 (2 c tau + 1) / n), 20 % at phi = 0.9)."""
    x = ar1(np.random.default_rng(6), phi, 5000, (50, 1))
    s0 = _spectrum0_ar(x)[:, 0]
    truth = 1 / (1 - phi) ** 2
    assert abs(np.mean(s0) / truth - 1) < 0.1
    via_emcee = [x[:, j, 0].var() * emcee.autocorr.integrated_time(x[:, j, 0])[0] for j in range(50)]
    assert abs(np.mean(s0) / np.mean(via_emcee) - 1) < 0.1
