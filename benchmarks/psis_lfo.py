"""Leave-future-out by importance sampling (PSIS-LFO) against exact refits (issue 22, item 1).

Bürkner, Gabry & Vehtari (2020) approximate the posterior of the data before an origin by
reweighting the draws of the whole-window posterior with 1 / p(y_after | theta), Pareto-smoothed
(ArviZ's ``psislw``); k-hat > 0.7 says the weights cannot be trusted. Here, on forecast twins of
the campaign (Case C form: one h per 30 min, smoothness prior, input noise integrated out), for
each twin:

1. the whole 40 h window is sampled (``hmc``, to the stopping rule) and the held-out 10 h's log
   density of every draw gives the PSIS-LFO estimate of the held-out elpd, with its k-hat;
2. the first 30 h alone are sampled (the exact leave-future-out posterior) and each draw
   predicts the held-out 10 h with the future rule (``persist``: the smoothness prior's mean,
   the Bayesian prediction of a random walk; ``diurnal``: the criticism's rule); the mixture
   over draws is the exact elpd (future h's spread about its mean left out, as in the MAP rule);
3. the criticism's MAP refit of the first 30 h (``criticism.forecast.forecast``) gives the
   plug-in elpd and RMSE, and its seconds.

Densities are per datum with the likelihood's marginal sd (as ``criticism.forecast``).

    PYTHONPATH=. NUMBA_NUM_THREADS=1 python benchmarks/psis_lfo.py [--seeds 600 601] \\
        [--effects wind_convection]
"""

from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.special import logsumexp

from pavement_mcmc.criticism.forecast import (
    default_origins,
    forecast,
    future_values,
    held_out,
    split_rows,
    training_problem,
)
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem, find_map
from pavement_mcmc.runs import keep, run_sampler
from pavement_mcmc.samplers import get_sampler
from pavement_mcmc.storage.memory import MemoryStore
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin

N_DRAWS = 400


def sample(problem, seed: int = 1):
    """Draws (n, n_free) of ``problem``'s posterior by ``hmc`` to the stopping rule, and seconds."""
    t0 = time.perf_counter()
    smp = get_sampler("hmc", problem.posterior, seed=seed)
    smp.prepare(laplace=find_map(problem.posterior) if smp.needs_laplace() else None)
    store = MemoryStore.create(problem.space.free, problem.posterior.blob_names, smp.n_chains, {})
    res = run_sampler(smp, store, max_seconds=600)
    kept = keep(store.read(), {"n_adapt_rows": res.n_adapt_rows}, burn_in=res.burn_in)
    flat = kept.get_chain(flat=True)
    idx = np.linspace(0, len(flat) - 1, min(N_DRAWS, len(flat))).astype(int)
    return flat[idx], time.perf_counter() - t0, res


def held_out_lp(problem, values: dict, n_train: int, n_end: int) -> tuple[float, np.ndarray]:
    r, lp, _ = held_out(problem, values, n_train, n_end)
    return float(lp.sum()), r


def one_twin(twin, root: Path) -> dict:
    cfg = load_case(write_twin(twin, root / twin.name))
    problem = build_problem(cfg)
    t = problem.meas.t
    origins, horizon = default_origins(t)
    origin = origins[0]
    n_train = split_rows(t, origin)
    n_end = len(t) - 1
    out = {"twin": twin.name, "origin_h": origin}

    # 1. PSIS-LFO from the whole-window posterior
    draws, secs, res = sample(problem)
    sets = problem.space.expand(draws)
    ll = np.array([held_out_lp(problem, {k: float(v[i]) for k, v in sets.items()}, n_train, n_end)[0]
                   for i in range(len(draws))])
    import arviz as az

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lw, k = az.psislw(-ll - np.max(-ll))
    out.update(full_seconds=secs, full_converged=res.converged, psis_khat=float(k),
               psis_elpd=float(logsumexp(lw + ll)), ll_sd=float(ll.std()),
               full_mean_elpd=float(np.mean(ll)))
    # 1b. the same draws with the criticism's future rule in place of their own held-out h
    # (fitted to the held-out data): each draw's training-part values, the diurnal rule after
    train = training_problem(problem, n_train)
    llr = np.array([held_out_lp(problem, future_values(
        problem, train, {k: float(v[i]) for k, v in sets.items() if k in train.space}, "diurnal"),
        n_train, n_end)[0] for i in range(len(draws))])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lw, k = az.psislw(-llr - np.max(-llr))
    out.update(psis_rule_khat=float(k), psis_rule_elpd=float(logsumexp(lw + llr)))

    # 2. exact leave-future-out: the training posterior, each draw forecasting the future
    tdraws, tsecs, tres = sample(train)
    tsets = train.space.expand(tdraws)
    for rule in ("persist", "diurnal"):
        lls, rmses = [], []
        for i in range(len(tdraws)):
            vals = future_values(problem, train, {k: float(v[i]) for k, v in tsets.items()}, rule)
            lp, r = held_out_lp(problem, vals, n_train, n_end)
            lls.append(lp)
            rmses.append(np.sqrt(np.mean(r**2)))
        lls = np.array(lls)
        out[f"exact_elpd_{rule}"] = float(logsumexp(lls) - np.log(len(lls)))
        out[f"exact_rmse_{rule}"] = float(np.median(rmses))
    out.update(train_seconds=tsecs, train_converged=tres.converged)

    # 3. the criticism's MAP refit
    t0 = time.perf_counter()
    for rule in ("persist", "diurnal"):
        fc = forecast(problem, origins=[origin], rule=rule)
        out[f"map_elpd_{rule}"] = fc.elpd
        out[f"map_rmse_{rule}"] = fc.rmse
    out["map_seconds"] = (time.perf_counter() - t0) / 2
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, nargs="+", default=[600, 601])
    ap.add_argument("--effects", nargs="*", default=[], help="hidden effects (none: clean twins)")
    a = ap.parse_args(argv)
    twins = forecast_twins(tuple(a.effects), seeds=tuple(a.seeds), input_sigma=True)
    with tempfile.TemporaryDirectory() as tmp:
        for twin in twins:
            r = one_twin(twin, Path(tmp))
            print(f"{r['twin']}: origin {r['origin_h']:.0f} h")
            print(f"  PSIS-LFO (whole window, {r['full_seconds']:.0f} s, converged {r['full_converged']}): "
                  f"elpd {r['psis_elpd']:.1f}, k-hat {r['psis_khat']:.2f} (sd of the draws' held-out "
                  f"log density {r['ll_sd']:.1f}; their mean {r['full_mean_elpd']:.1f}); with the diurnal "
                  f"rule for their held-out h: elpd {r['psis_rule_elpd']:.1f}, "
                  f"k-hat {r['psis_rule_khat']:.2f}")
            print(f"  exact LFO (training posterior, {r['train_seconds']:.0f} s, converged "
                  f"{r['train_converged']}): elpd persist {r['exact_elpd_persist']:.1f} / diurnal "
                  f"{r['exact_elpd_diurnal']:.1f}; RMSE {r['exact_rmse_persist']:.3f} / "
                  f"{r['exact_rmse_diurnal']:.3f} degC")
            print(f"  MAP refit ({r['map_seconds']:.1f} s): elpd persist {r['map_elpd_persist']:.1f} / "
                  f"diurnal {r['map_elpd_diurnal']:.1f}; RMSE {r['map_rmse_persist']:.3f} / "
                  f"{r['map_rmse_diurnal']:.3f} degC", flush=True)


if __name__ == "__main__":
    main()
