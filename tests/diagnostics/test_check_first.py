"""A check that starts with the parameter which held the last one (``first``) decides as the
full check does, and, when that parameter still fails, estimates nothing else."""

import numpy as np

from pavement_mcmc.diagnostics.stopping import StoppingRule


def _chains(n=3000, m=8, p=6, phi=0.95, seed=0):
    """Parameter 2 an AR(1) with tau = (1 + phi) / (1 - phi) = 39; the others white noise."""
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((n, m, p))
    for t in range(1, n):
        x[t, :, 2] = phi * x[t - 1, :, 2] + np.sqrt(1 - phi**2) * x[t, :, 2]
    return x, np.zeros((n, m)), np.ones((n, m), bool)


def test_first_parameter_failing_ends_the_check_with_only_its_estimate():
    x, lp, acc = _chains()
    rule = StoppingRule(ess_target=1000.0)
    full = rule.check(x, lp, acc, 0, burn_in=0, full=False)
    quick = rule.check(x, lp, acc, 0, burn_in=0, full=False, first=2)
    assert full.failures and quick.failures and "p2" in quick.failures[0]
    assert np.isnan(quick.ess[[0, 1, 3, 4, 5]]).all()
    # its one estimate is the full check's (tau ~ 39 of the AR(1)), not a cheaper one
    assert 25 < quick.tau[2] < 60
    np.testing.assert_allclose(quick.tau[2], full.tau[2], rtol=1e-12)


def test_first_parameter_passing_gives_the_full_check():
    x, lp, acc = _chains(phi=0.8)
    rule = StoppingRule(ess_target=200.0, min_tau_lengths=20.0)
    full = rule.check(x, lp, acc, 0, burn_in=0, full=False)
    quick = rule.check(x, lp, acc, 0, burn_in=0, full=False, first=2)
    assert full.failures == [] and quick.failures == [] and quick.held_by is None
    np.testing.assert_array_equal(quick.ess, full.ess)
    np.testing.assert_array_equal(quick.rhat, full.rhat)


def test_first_parameter_failing_r_hat_ends_the_check_with_only_its_r_hat():
    x, lp, acc = _chains(n=3000, phi=0.0)
    x[:, :4, 4] += 0.5  # parameter 4: half the chains elsewhere (R-hat well above 1.01)
    rule = StoppingRule(ess_target=100.0, min_tau_lengths=5.0)
    full = rule.check(x, lp, acc, 0, burn_in=0, full=False)
    assert full.held_by == 4 and full.failures[-1].startswith("R-hat")
    quick = rule.check(x, lp, acc, 0, burn_in=0, full=False, first=4)
    assert quick.held_by == 4 and quick.failures == full.failures
    assert np.isnan(quick.rhat[[0, 1, 2, 3, 5]]).all()
    np.testing.assert_allclose(quick.rhat[4], full.rhat[4], rtol=1e-12)


def test_progress_and_skip_hint_after_a_quick_check():
    """After a quick check the progress line shows no parameter's ESS as the minimum unless it
    failed on it, and the skip hint keeps the last known tau_max (not one parameter's)."""
    from pavement_mcmc.runs.loop import _hint, _min_ess

    x, lp, acc = _chains(n=3000, phi=0.0)
    x[:, :4, 4] += 0.5  # parameter 4 fails R-hat only
    rule = StoppingRule(ess_target=100.0, min_tau_lengths=5.0)
    quick = rule.check(x, lp, acc, 0, burn_in=0, full=False, first=4)
    assert quick.failures[0].startswith("R-hat")
    assert _min_ess(quick, 76.0) == 76.0
    assert _hint(quick, [0, 209.6])[1] == 209.6
    x2, lp2, acc2 = _chains()
    q2 = StoppingRule(ess_target=1000.0).check(x2, lp2, acc2, 0, burn_in=0, full=False, first=2)
    assert _min_ess(q2, None) == q2.ess[2] < 1000
