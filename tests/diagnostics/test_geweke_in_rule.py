"""Geweke's early/late test is part of the stopping rule: a run the loop stops on its rule is
not then called untrustworthy by the assessment (Case C stopped at 949 steps with 12 of 115
principal components failing Geweke, and `diagnostics` said NOT TRUSTED)."""

from types import SimpleNamespace

import numpy as np

from pavement_mcmc.diagnostics import StoppingRule, geweke_verdict
from pavement_mcmc.diagnostics.assessment import assess


def _run(chain: np.ndarray, lp: np.ndarray) -> SimpleNamespace:
    return SimpleNamespace(chain=chain, log_prob=lp, accepted=np.ones(lp.shape, bool),
                           param_names=["a", "b", "c", "d"])


def _chain(rng, shift: float, n: int = 3000, m: int = 16) -> np.ndarray:
    """Independent draws (ESS n m, R-hat 1, no drift); the first 15 % of the steps of the
    first parameter moved by ``shift`` standard deviations (a burn-in not quite over)."""
    x = rng.normal(size=(n, m, 4))
    x[: int(0.15 * n), :, 0] += shift
    return x


def _decisions(chain, rng, rule):
    lp = rng.normal(size=chain.shape[:2])
    check = rule.check(chain, lp, np.ones(chain.shape[:2], bool), 0, burn_in=0)
    a = assess(_run(chain, lp), 0, rule)
    return check, a


def test_a_chain_whose_early_part_differs_does_not_stop_the_run():
    rng = np.random.default_rng(5)
    x = _chain(rng, 0.3)
    old, _ = _decisions(x, rng, StoppingRule(geweke=False))
    assert old.failures == []  # every other criterion passes: the rule before stopped here
    check, a = _decisions(x, rng, StoppingRule())
    assert len(check.failures) == 1 and check.failures[0].startswith("Geweke")
    assert not a.trusted and any("Geweke" in r for r in a.reasons)
    assert abs(geweke_verdict(x).z[0]) > 3.5


def test_the_rule_and_the_assessment_agree_on_stationary_chains():
    """Twenty stationary chains: the rule stops on those the assessment trusts and on no
    other, and false alarms stay near the test's level (about 3 % for four components)."""
    rng = np.random.default_rng(11)
    stops, trusted = [], []
    for _ in range(20):
        x = _chain(rng, 0.0, n=600)
        check, a = _decisions(x, rng, StoppingRule(ess_target=1000))
        stops.append(not check.failures)
        trusted.append(a.trusted)
    assert stops == trusted
    assert sum(stops) >= 17


def test_too_short_a_chain_cannot_pass_geweke():
    rng = np.random.default_rng(2)
    v = geweke_verdict(rng.normal(size=(12, 8, 3)))
    assert v.failed and "too few" in v.text()
    check = StoppingRule(ess_target=10, min_tau_lengths=1).check(
        rng.normal(size=(12, 8, 3)), rng.normal(size=(12, 8)), np.ones((12, 8), bool), 0,
        burn_in=0)
    assert any("Geweke" in f for f in check.failures)
