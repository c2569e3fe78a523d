"""radiation_factor: what ``diagnose`` can and cannot say about a radiometer error.

A factor on the recorded net radiation is exactly confounded with a common scale of kappa, C and
h(t): only the priors on kappa and C can reveal it.

- Loose priors (+-5 %, centred 3 % off the truth, as in the detection matrix): the data part of
  its score stays small; the ranking must not claim it. Where its total score passes the
  threshold through the prior part (measured: rad_factor 1.15, seeds 2 and 4: S 14.5 and 15.9, of
  which 10.8 and 11.8 from the priors) the entry is *prior-driven* and the verdict says so.
- Tight, correct priors (1 % at the truth) and h(t) in 1 h pieces: rad_factor 1.15 is ranked
  first (measured S 65-89 on seeds 1-5, fitted factor 1.15-1.18); 0.85 only on 3 of 5 seeds
  (S 15-30; seed 2: S 8, nothing claimed; seed 3: two_layer wins a look-alike tie). Under the
  claim rule (a claim also needs a data part D > 20) 1.15 is claimed on 4 of 5 seeds (seed 5:
  D 15) and 0.85 on 1 of 5 (seeds 1 and 4: D 10 and 14). A coarser
  h(t) does not help: with 7 or 3 pieces ``finer_h`` ranks first, and radiation_factor then
  scores high on clean data too (it soaks up the h(t) misfit).
"""

from __future__ import annotations

import pytest
from test_hidden_effects import CASE

from pavement_mcmc.criticism import diagnose, refit
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.synthetic import SyntheticSpec, write_case

TIGHT = (
    CASE.format(kappa=1.31, C=0.99e6)
    .replace("sd = 0.07", "sd = 0.0131")
    .replace("sd = 0.05e6", "sd = 0.0099e6")
)
LOOSE = CASE.format(kappa=1.35, C=1.02e6)


def ranking(tmp_path, rad_factor: float | None, seed: int, priors: str):
    d = tmp_path / f"rad_{rad_factor}_{seed}"
    if not (d / "measurements.csv").exists():
        effects = {} if rad_factor is None else {"radiation_factor": {"rad_factor": rad_factor}}
        write_case(SyntheticSpec(seed=seed, sigma=0.2, effects=effects), d)
    (d / f"{priors}.toml").write_text(TIGHT if priors == "tight" else LOOSE)
    problem = build_problem(load_case(d / f"{priors}.toml"))
    rk = diagnose(problem, refit(problem).values()).ranking
    rad = next(e for e in rk.entries if e.name == "radiation_factor")
    return rk, rad


def assert_not_claimed(rk, rad):
    assert not rad.detected and (rk.best is None or rk.best.name != "radiation_factor"), rk.verdict
    assert rad.data_score <= rad.threshold, rad  # the data alone do not see it
    if rad.score > rad.threshold:
        assert rad.prior_driven and "Not claimed: radiation_factor" in rk.verdict, rk.verdict


def test_radiation_factor_loose_priors_is_not_claimed_tight_priors_detect_it(tmp_path):
    # loose priors: S passes 10 only through the prior part (the old rule claimed it here)
    rk, rad = ranking(tmp_path, 1.15, seed=2, priors="loose")
    assert rad.score > rad.threshold and rad.delta_prior > 0.5 * rad.score, rad
    assert_not_claimed(rk, rad)
    assert rad.to_dict()["prior_driven"] is True
    # the same data with tight, correct kappa and C priors: detected from the data, ranked first
    rk, rad = ranking(tmp_path, 1.15, seed=2, priors="tight")
    assert rk.best is rad and rk.entries[0] is rad, rk.verdict
    assert rad.data_score > rad.threshold and not rad.prior_driven, rad
    assert rad.values["rad_factor"] == pytest.approx(1.15, abs=0.05)
    assert "Caveat" in rk.verdict and "priors on kappa and C" in rk.verdict


def test_radiation_factor_no_false_claim_with_tight_correct_priors(tmp_path):
    rk, rad = ranking(tmp_path, None, seed=2, priors="tight")
    assert rk.best is None, rk.verdict
    assert not rad.detected


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_radiation_factor_matrix(tmp_path, seed):
    """Loose priors never claim a radiometer error; tight, correct ones never claim one on
    clean data."""
    for factor in (0.85, 1.15):  # loose priors: never claimed
        assert_not_claimed(*ranking(tmp_path, factor, seed, "loose"))
    rk, rad = ranking(tmp_path, None, seed, "tight")  # no false claim on clean data
    assert rk.best is None, rk.verdict


def _miss(reason: str, strict: bool = False):
    return pytest.mark.xfail(reason=reason, strict=strict)


_RULE = "under the claim rule (data part D > 20) "
_TIGHT_CELLS = [
    *[(1.15, seed) for seed in (1, 2, 3, 4)],
    pytest.param(1.15, 5, marks=_miss(_RULE + "+15 % is claimed on 4 of 5 seeds (seed 5: S 65 but "
                                      "D 15)")),
    pytest.param(0.85, 1, marks=_miss(_RULE + "not claimed (S 15, D 10): -15 % is claimed on 1 of "
                                      "5 seeds")),
    *[pytest.param(0.85, seed, marks=_miss("rad_factor 0.85 with tight priors: not ranked first on "
                                           "seeds 2 and 3 (seed 2: S 8; seed 3: two_layer wins a "
                                           "look-alike tie)", strict=True)) for seed in (2, 3)],
    pytest.param(0.85, 4, marks=_miss(_RULE + "not claimed (S 20, D 14, below surface_layer's S "
                                      "24): -15 % is claimed on 1 of 5 seeds")),
    (0.85, 5),
]


@pytest.mark.slow
@pytest.mark.parametrize("factor, seed", _TIGHT_CELLS)
def test_radiation_factor_tight_priors(tmp_path, factor, seed):
    """Tight, correct priors: a +-15 % radiometer error is ranked first and claimed."""
    rk, rad = ranking(tmp_path, factor, seed, "tight")
    assert rk.best is rad, rk.verdict


def test_the_radiation_factor_is_a_scale_of_kappa_C_and_h_to_rounding(tmp_path):
    """Why no rule, in sample or by forecast, can claim radiation_factor from the temperatures
    of a free-h(t) fit (issue 22's calibration: 1 of 20): the model with a factor f and
    (kappa, C, h) predicts exactly what the base model predicts with (kappa/f, C/f, h/f), at
    every sensor and time, so held-out data see no difference either. A forecast twin (Case C
    form, per-interval h), f = 0.8 and 1.3."""
    import numpy as np

    from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin

    twin = forecast_twins(("radiation_factor",), seeds=(701,), hours=16.0)[0]
    path = write_twin(twin, tmp_path / twin.name)
    base = build_problem(load_case(path))
    cand = build_problem(load_case(path, additions={"model": {"extensions": ["radiation_factor"]}}))
    assert cand.space.free == [*base.space.free, "rad_factor"]
    rng = np.random.default_rng(3)
    hs = [n for n in base.space.free if n.startswith("h_")]
    for f in (0.8, 1.3):
        p = {"kappa": 1.1, "C": 1.9e6, "gamma": 2.0, **{n: 8 + 6 * rng.random() for n in hs}}
        scaled = {**{n: v / f for n, v in p.items()}, "gamma": p["gamma"]}
        t_cand = cand.posterior.predict(np.array([[p[n] if n != "rad_factor" else f
                                                   for n in cand.space.free]]))
        t_base = base.posterior.predict(np.array([[scaled[n] for n in base.space.free]]))
        np.testing.assert_allclose(t_cand, t_base, rtol=0, atol=1e-9)
        nudged = np.array([[scaled[n] * (1.02 if n == "kappa" else 1.0) for n in base.space.free]])
        assert np.max(np.abs(base.posterior.predict(nudged) - t_cand)) > 1e-3  # not vacuous
