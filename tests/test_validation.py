"""Slow validation runs (``make validate``): SBC, coverage on the reference case, fast vs MH.

Numbers are printed (run with ``-s``) for the record. The many-fit campaigns (SBC's 100 twins,
the 8 Case C twins) run through the batch engine, :func:`pavement_mcmc.batch.map_units`, on a
local Dask cluster (one worker per core); each fit's seed is fixed by its index, so the numbers do
not depend on the number of workers.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import cloudpickle
import numpy as np
import pytest
from scipy import stats

from pavement_mcmc import diagnostics as dg
from pavement_mcmc.batch import Failure, map_units
from pavement_mcmc.data import load_case
from pavement_mcmc.parameters import ParameterSpace, TruncatedNormal
from pavement_mcmc.physics import HBasis, Model
from pavement_mcmc.posterior import LogPosterior, build_problem
from pavement_mcmc.runs import run_sampler, truth_values
from pavement_mcmc.samplers import get_sampler
from pavement_mcmc.solver import Grid
from pavement_mcmc.storage import MemoryStore

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.slow
# the campaign units below are functions of this test module, which the Dask workers cannot import
cloudpickle.register_pickle_by_value(sys.modules[__name__])


def _campaign(fn, units, **kw) -> list:
    """``fn`` over ``units`` on the batch engine; a unit that failed fails the test, naming it."""
    out = map_units(fn, units, key=lambda u: u[0], **kw)
    bad = [r for r in out if isinstance(r, Failure)]
    assert not bad, bad
    return out

#: the SBC's generative prior = its inference prior (wider than the paper's, see test_sbc)
SBC_PRIOR = {"kappa": TruncatedNormal(1.5, 0.3), "C": TruncatedNormal(1.5e6, 0.3e6),
             "h_1": TruncatedNormal(10.0, 3.0)}


def _run(post, kind="fast", n_chains=None, seed=0, move=None, **kw):
    opts = {"move": move} if move else {}
    s = get_sampler(kind, post, n_chains=n_chains, seed=seed, options=opts)
    s.prepare()
    st = MemoryStore.create(post.space.free, post.blob_names, s.n_chains, {"sampler": kind})
    res = run_sampler(s, st, **kw)
    return res, st.read()


def _sbc_posterior(meas):
    from dataclasses import replace

    grid = Grid.build(meas)
    model = Model(meas, grid, HBasis.pieces(meas.t, [0, meas.t[-1] / 3600]))
    space = model.parameter_space()
    space = ParameterSpace([replace(space[n], prior=SBC_PRIOR[n]) for n in space.names])
    return LogPosterior(model, space)


@pytest.mark.parametrize("inputs", ["clean", "noisy", "noisy_integrated"])
def test_sbc_case_a_twins(inputs):
    """Simulation-based calibration (Talts et al. 2018) on 100 small twin datasets.

    Generative model = inference model: kappa, C, h drawn from SBC_PRIOR (wider than the paper's
    2.27 +- 0.11 / 2.10 +- 0.021 MJ, which leave the data little to say), data from the
    independent fine-grid simulator (pavement_mcmc.synthetic, 12 h, linear forcing, no emission
    and no forcing noise so the inversion model is well specified) with sigma = 0.25 degC noise.
    h is ONE constant piece: the simulator's h(t) is a smooth spline, so a step function (Case
    A's three pieces) cannot be the truth of a well-specified twin. Ranks of the truth among
    99 thinned posterior draws must be uniform (chi-square, 10 bins, p > 0.001 per parameter).

    ``inputs``: ``"clean"`` replaces the 5 cm (Dirichlet) column and the t = 0 row (initial
    profile) by the simulator's noise-free values; ``"noisy"`` keeps their noise and treats them
    as exact, as the paper does: the model is then misspecified (errors in variables) and the
    posterior too narrow — xfail, it measures the paper's method, not the sampler;
    ``"noisy_integrated"`` keeps the noise and integrates it out of the likelihood
    (``input_sigma``, :mod:`pavement_mcmc.posterior.input_noise`): kappa and h become uniform, C's ranks
    still lean low — the fit prefers parameters that damp the noisy boundary's wiggles (a
    larger C), an errors-in-variables bias the Berkson-type marginalisation does not remove
    (MAP C / true C on 16 twins: 1.03 with the noisy 5 cm series, 1.00 with the clean one).
    That case xfails when C alone fails.
    """
    if inputs == "noisy":
        pytest.xfail("measured 2026-11-21 (578c060, 100 twins): kappa's ranks U-shaped, chi-square "
                     "p = 4e-15: noisy boundary/initial data used as exact make the paper's method "
                     "over-confident (not re-run: it measures the paper, not the sampler)")

    rng = np.random.default_rng(2024)
    n_sets = 100
    truths = [{n: float(p.sample(rng, 1)[0]) for n, p in SBC_PRIOR.items()} for _ in range(n_sets)]
    results = _campaign(_sbc_unit, [(i, truths[i]) for i in range(n_sets)], inputs=inputs)
    ranks = {n: [r[n] for r in results] for n in SBC_PRIOR}
    L = 99
    bad = {}
    for n, r in ranks.items():
        counts = np.bincount(np.asarray(r) * 10 // (L + 1), minlength=10)
        p = stats.chisquare(counts).pvalue
        print(f"SBC {inputs} {n}: rank counts {counts.tolist()}, chi-square p = {p:.3g}")
        if not p > 1e-3:
            bad[n] = (p, counts.tolist())
    if inputs == "noisy_integrated" and set(bad) == {"C"}:
        # measured 2026-11-21: C's ranks lean low, p 6e-6 to 1e-4 with time-based stopping,
        # 0.0013 with the deterministic check schedule (so this passes by a hair); kappa, h fine
        pytest.xfail(f"C biased high by the boundary noise's attenuation (errors in variables), "
                     f"not removed by integrating the noise out: {bad['C']}")
    assert not bad, bad


def _sbc_unit(unit, inputs: str, L: int = 99) -> dict:
    """One SBC twin: the rank of the truth among ``L`` thinned posterior draws, per parameter."""
    from pavement_mcmc.posterior import attach_input_noise
    from pavement_mcmc.synthetic import SyntheticSpec, simulate, to_measurements

    warnings.simplefilter("ignore")
    i, true = unit
    spec = SyntheticSpec(kappa=true["kappa"], C=true["C"], sigma=0.25, hours=12,
                         h_knots=(true["h_1"], true["h_1"]), seed=1000 + i, emission=False,
                         forcing="linear", forcing_noise=False, spinup_hours=24)
    cols, truth = simulate(spec)
    if inputs == "clean":  # noise-free bottom boundary and initial profile (see the test)
        labels = [k for k in cols if k.startswith("T_") and k.endswith("cm")]
        for j, lab in enumerate(labels):
            cols[lab] = np.array(cols[lab], float)
            cols[lab][0] = truth.T_clean[0, j]
        cols[labels[-1]] = np.array(truth.T_clean[:, len(labels) - 1], float)
    post = _sbc_posterior(to_measurements(cols, sigma=0.25))
    if inputs == "noisy_integrated":
        attach_input_noise(post, 0.25)
    res, data = _run(post, n_chains=32, seed=i, ess_target=1000, max_steps=6000)
    kept = data.chain[res.burn_in:].reshape(-1, post.ndim)
    draws = kept[np.linspace(0, kept.shape[0] - 1, L).astype(int)]
    return {n: int(np.sum(draws[:, j] < true[n])) for j, n in enumerate(post.space.free)}


def _case(name, overrides=None):
    return build_problem(load_case(ROOT / "runs" / f"{name}.toml", overrides))


WIDE = {"parameters": {
    "kappa": {"prior": {"dist": "truncnormal", "mean": 1.5, "sd": 0.5}},
    "C": {"prior": {"dist": "truncnormal", "mean": 1.5e6, "sd": 0.5e6}}}}


#: the reference case's documented instrument noise (data/reference_case/README.md)
NOISY_INPUTS = {"input_sigma": 0.25, "T_air_sigma": 0.05, "q_net_sigma": 2.0,
                "q_net_rel_sigma": 0.01}


def _case_c_intervals(data_overrides: dict):
    pr = _case("caseC", {**WIDE, "data": data_overrides})
    res, data = _run(pr.posterior, "hmc", seed=1, ess_target=1000, max_steps=200_000,
                     max_seconds=1200)
    kept = data.chain[res.burn_in:].reshape(-1, pr.posterior.ndim)
    lo, hi = np.percentile(kept, [2.5, 97.5], axis=0)
    truth = truth_values(pr)
    names = pr.space.free
    inside = {n: bool(lo[j] <= truth[n] <= hi[j]) for j, n in enumerate(names) if n in truth}
    h_cov = float(np.mean([v for n, v in inside.items() if n.startswith("h_")]))
    for n in ("kappa", "C"):
        j = names.index(n)
        print(f"Case C wide priors, {data_overrides}: {n} 95% [{lo[j]:.4g}, {hi[j]:.4g}]"
              f" truth {truth[n]:.4g}")
    missed = [n for n, v in inside.items() if n.startswith("h_") and not v]
    print(f"Case C wide priors: h coverage {h_cov:.2%}, missed {missed}; converged={res.converged}:"
          f" {res.reason}")
    assert res.converged
    return inside, h_cov


@pytest.mark.parametrize("noisy_inputs", [False, True])
def test_reference_case_c_covers_kappa_and_c(noisy_inputs):
    """Case C (one h per interval, the correctly specified model of the reference data) with
    kappa and C priors widened to 1.5 +- 0.5 and 1.5e6 +- 0.5e6: the 95 % intervals contain the
    true kappa and C when the documented noise of the inputs (5 cm boundary, initial profile,
    air temperature, net radiation) is integrated out. Used as exact inputs (the paper's
    likelihood) the intervals are too narrow: xfail with the measured numbers."""
    if not noisy_inputs:
        pytest.xfail("measured 2026-11-21 (converged in ~11 s): kappa 95 % [1.294, 1.378] contains "
                     "1.31, but C [1.002, 1.224] MJ misses 0.99 and h coverage is 76 %: the "
                     "likelihood treats the noisy 5 cm boundary and initial profile as exact")
    inside, _ = _case_c_intervals(NOISY_INPUTS)
    assert inside["kappa"] and inside["C"]


@pytest.mark.xfail(strict=False, reason=(
    "measured 2026-11-21 with the inputs' noise integrated out: h coverage 84 % < 90 %; the 17 "
    "missed pieces are the first 4 h (truth 16.6 -> 10.2, 95 % intervals ~[2, 11.6]) plus h_64 "
    "(11.57 vs [11.64, 12.97]); kappa and C are covered. The night-time data barely inform h "
    "(on a twin, putting the true early h into the posterior mean costs 0.7 in log-likelihood), "
    "so the first-order smoothness prior sets it and prefers a flat start; the true early trend "
    "costs ~8 nats under the estimated gamma ~5"))
def test_reference_case_c_covers_90_percent_of_h():
    _, h_cov = _case_c_intervals(NOISY_INPUTS)
    assert h_cov >= 0.9


@pytest.fixture(scope="module")
def case_c_twins(tmp_path_factory):
    """Case C on 8 twins of the reference case from the independent simulator (same truth,
    smooth h(t) through the paper's values, emission, instrument noise on every input; seeds
    1-8), kappa/C priors widened, the inputs' noise integrated out. The reference case is one
    noise draw: a miss there may be luck, so coverage is also measured over these."""

    root = tmp_path_factory.mktemp("case_c_twins")
    out = _campaign(_case_c_twin, [(seed, str(root)) for seed in range(1, 9)])
    for seed, t in zip(range(1, 9), out):
        print(f"twin {seed}: kappa {t['kappa']} C {t['C']} h {t['h']:.2f} converged={t['ok']} "
              f"({t['elapsed']:.0f} s)")
    return out


def _case_c_twin(unit) -> dict:
    from pavement_mcmc.synthetic import SyntheticSpec, write_case

    seed, root = unit
    csv = write_case(SyntheticSpec(seed=seed, sigma=0.25), Path(root) / f"twin{seed}")
    data = {"csv": str(csv), "truth": str(csv.parent / "truth.json"), **NOISY_INPUTS}
    pr = _case("caseC", {**WIDE, "data": data})
    res, chain = _run(pr.posterior, "hmc", seed=seed, ess_target=400, max_steps=100_000,
                      max_seconds=300, min_tau_lengths=20, rhat_max=1.02)
    kept = chain.chain[res.burn_in:].reshape(-1, pr.posterior.ndim)
    lo, hi = np.percentile(kept, [2.5, 97.5], axis=0)
    truth = truth_values(pr)
    inside = {n: bool(lo[j] <= truth[n] <= hi[j]) for j, n in enumerate(pr.space.free) if n in truth}
    h_cov = float(np.mean([v for n, v in inside.items() if n.startswith("h_")]))
    return {"kappa": inside["kappa"], "C": inside["C"], "h": h_cov, "ok": res.converged,
            "elapsed": res.elapsed}


def test_case_c_twins_cover_kappa_and_c(case_c_twins):
    """95 % intervals: kappa and C each covered in >= 6 of 8 twins (P(<= 5 of 8) = 0.6 %)."""
    k = sum(t["kappa"] for t in case_c_twins)
    c = sum(t["C"] for t in case_c_twins)
    print(f"Case C twins: kappa covered {k}/8, C {c}/8")
    assert all(t["ok"] for t in case_c_twins)
    assert k >= 6 and c >= 6


@pytest.mark.xfail(strict=False, reason=(
    "measured 2026-11-21 (hmc): mean h coverage 89.8 % over the 8 twins (0.85-0.96 each), just "
    "under the 90 % asked (nominal 95 %); kappa 6/8, C 7/8. Every twin misses the first 3-4 h of h: "
    "prior-dominated (see test_reference_case_c_covers_90_percent_of_h); with the true initial "
    "profile instead of the interpolated one the same pieces are missed"))
def test_case_c_twins_cover_90_percent_of_h(case_c_twins):
    h = float(np.mean([t["h"] for t in case_c_twins]))
    print(f"Case C twins: mean h coverage {h:.2%}")
    assert h >= 0.9


def test_paper_priors_pull_case_a_away_from_truth():
    """Measured, not hidden: with the paper's tight priors (kappa 2.27 +- 0.11, C 2.10 +- 0.021
    MJ) and three h pieces, Case A's posterior excludes the true kappa = 1.31 and C = 0.99 MJ."""
    pr = _case("caseA")
    res, data = _run(pr.posterior, seed=1, ess_target=1000, max_steps=20_000)
    assert res.converged, res.reason
    kept = data.chain[res.burn_in:].reshape(-1, pr.posterior.ndim)
    truth = truth_values(pr)
    for j, n in enumerate(["kappa", "C"]):
        m, s = kept[:, j].mean(), kept[:, j].std()
        print(f"Case A paper priors: {n} = {m:.4g} +- {s:.3g} (truth {truth[n]:.4g}, "
              f"{(m - truth[n]) / s:+.1f} sd)")
    lo, hi = np.percentile(kept[:, :2], [2.5, 97.5], axis=0)
    assert not (lo[0] <= truth["kappa"] <= hi[0])  # documents the bias (misspecified h + prior)


def _sd_ratio_tol(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """``k`` standard errors of the ratio of two chains' sds (:func:`.diagnostics.mcse_sd`: it
    sees heavy tails, where the Gaussian ``sd / sqrt(2 ESS)`` does not; Case C's gamma has an
    excess kurtosis of 1-12 over seeds, from rare visits to smooth h(t) and large gamma).

    What it can catch: for Gaussian draws it equals the old bound, about 12 % at ESS 2000 and
    1000 with k = 4.5, so a 10 % sd error passes most of the time (a reviewer's simulation:
    caught in 27 %); the test guards against gross disagreement. A heavy-tailed chain widens its
    own bound (gamma in hmc's seed-5 run: 14.6 %), so a bias that comes with heavy tails would
    pass too: across 28 seeds gamma's sd was 0.239-0.256 but for that run (0.270)."""
    def rel(x):
        return dg.mcse_sd(x) / x.reshape(-1, x.shape[2]).std(0)

    return k * np.sqrt(rel(a) ** 2 + rel(b) ** 2)


def test_fast_agrees_with_long_mh_case_a():
    """fast and a long plain MH run agree on Case A's means and sds within Monte Carlo error."""
    pr = _case("caseA")
    rf, df = _run(pr.posterior, "fast", seed=3, ess_target=2000, max_steps=50_000)
    rm, dm = _run(pr.posterior, "mh", n_chains=32, seed=4, ess_target=2000, max_steps=60_000,
                  max_seconds=600)
    print(f"fast: {rf.reason}\nmh: {rm.reason}")
    kf, km = df.chain[rf.burn_in:], dm.chain[rm.burn_in:]
    mf, mm = kf.reshape(-1, 5).mean(0), km.reshape(-1, 5).mean(0)
    sf, sm = kf.reshape(-1, 5).std(0), km.reshape(-1, 5).std(0)
    se = np.sqrt(dg.mcse(kf) ** 2 + dg.mcse(km) ** 2)
    for j, n in enumerate(pr.space.free):
        print(f"{n}: fast {mf[j]:.5g} +- {sf[j]:.3g}  mh {mm[j]:.5g} +- {sm[j]:.3g}  "
              f"z = {(mf[j] - mm[j]) / se[j]:+.2f}")
    assert np.all(np.abs(mf - mm) < 4 * se)
    assert np.all(np.abs(sf / sm - 1) < _sd_ratio_tol(kf, km, 4.0))


def test_hmc_agrees_with_the_random_walk_block_sampler_case_c():
    """Case C with the paper's priors (115 unknowns): the HMC sampler (runs/caseC.toml) and the
    random-walk block sampler (77k steps) agree on every parameter's mean and sd within their
    Monte Carlo errors."""
    pr = _case("caseC")
    rh, dh = _run(pr.posterior, "hmc", seed=5, ess_target=2000, max_steps=100_000,
                  max_seconds=600)
    rb, db = _run(pr.posterior, "fast", n_chains=32, seed=6, move="block", ess_target=1000,
                  max_steps=1_000_000, max_seconds=1200)
    print(f"hmc: {rh.reason} ({rh.elapsed:.0f} s)\nblock: {rb.reason} ({rb.elapsed:.0f} s)")
    assert rh.converged and rb.converged
    kh, kb = dh.chain[rh.burn_in:], db.chain[rb.burn_in:]
    p = kh.shape[2]
    mh, mb = kh.reshape(-1, p).mean(0), kb.reshape(-1, p).mean(0)
    sh, sb = kh.reshape(-1, p).std(0), kb.reshape(-1, p).std(0)
    se = np.sqrt(dg.mcse(kh) ** 2 + dg.mcse(kb) ** 2)
    z = (mh - mb) / se
    for j in [0, 1, 2, 3, 60, 114]:
        print(f"{pr.space.free[j]}: hmc {mh[j]:.5g} +- {sh[j]:.3g}  block {mb[j]:.5g} +- {sb[j]:.3g}"
              f"  z = {z[j]:+.2f}")
    print(f"max |z| over {p} parameters: {np.abs(z).max():.2f}")
    # 115 parameters: a 4.5-sigma bound keeps the family-wise false alarm below 0.1 %
    assert np.all(np.abs(z) < 4.5)
    tol = _sd_ratio_tol(kh, kb, 4.5)
    print(f"sd ratio hmc / block: max |ratio - 1| / tol {np.max(np.abs(sh / sb - 1) / tol):.2f}, "
          f"gamma's tol {tol[pr.space.free.index('gamma')]:.3f}")
    assert np.all(np.abs(sh / sb - 1) < tol)


def test_criticism_campaign(tmp_path):
    """Issue 14's numbers on our own twins (independent simulator, inversion settings it does not
    share), with ``diagnose``'s default rule (the forecast gain, issue 22): the false-alarm rate
    on 24 clean twins (4 h shapes x Case A / hourly / Case C forms x loose / tight priors, input
    noise on and off, each its own seed) must stay <= 1/20; the true-effect-first rate and refit
    RMSE ratio per catalogue effect are printed; on the 12 off-catalogue twins (sensor lag,
    shading, a buried source, a sun-warmed surface sensor) "none of these" must be the answer in
    >= 2/3 with no confident claim. (With the in-sample rule, ``--no-forecast``, the three
    sun-warmed sensors are claimed as two_layer or sensor_depth: why the forecast rule is the
    default, docs/VALIDATION.md section 4.)"""
    from pavement_mcmc.criticism.campaign import diagnose_twins, rates
    from pavement_mcmc.synthetic.corpus import catalogue_twins, clean_twins, off_catalogue_twins

    warnings.simplefilter("ignore")
    records = diagnose_twins(clean_twins() + catalogue_twins() + off_catalogue_twins(), tmp_path,
                             forecast=True)
    r = rates(records)
    fa, n = r["false_alarm"]
    print(f"CRITICISM false-alarm rate on clean twins: {fa}/{n} {r['false_alarm_twins']}")
    for eff, v in r["true_first"].items():
        print(f"CRITICISM {eff}: ranked first and claimed {v['first']}/{v['n']}, refit RMSE / "
              f"true-model RMSE {v['rmse_ratio']}")
    k, m = r["none_of_these"]
    print(f"CRITICISM none-of-these on off-catalogue twins: {k}/{m}; confident catalogue claims "
          f"there: {r['off_confident_claims']}")
    for rec in records:
        print("CRITICISM", rec["twin"], "->", rec["claimed"], "none" if rec["none_of_these"] else "",
              f"{rec['seconds']:.0f} s")
    assert fa * 20 <= n
    assert 3 * k >= 2 * m and not r["off_confident_claims"]
