"""The forecast rule's calibration campaign (issue 22) on twins of ``pavement_mcmc.synthetic``.

``python benchmarks/forecast_campaign.py [--out records.jsonl] [--clean N] [--per-effect N]
[--off N] [--hours H] [--input-sigma] [--param EFFECT.NAME=VALUE] [--rules] [--report]
[--oracle]``

Twins: :func:`~pavement_mcmc.synthetic.corpus.forecast_twins` (Case C form, loose priors, a
diurnal h(t) that changes from day to day, 30 min rows, the last quarter of the window held
out). Clean twins, each catalogue effect at 1x, and the off-catalogue effects (``sensor_sun``,
``sensor_lag``, ``shading``, ``buried_source``), interleaved so that a run cut short still
covers every kind. Each twin is diagnosed with the forecast rule
(:func:`~pavement_mcmc.criticism.campaign.diagnose_twin`) and its record appended to ``--out``
(JSON lines; twins already there are skipped, so a killed run resumes); at the end the rates
(:func:`~pavement_mcmc.criticism.campaign.rates`) with their n, and the forecast gains of the
candidates on clean twins (the margin ``FORECAST_THRESHOLD`` must clear them). Each candidate's
record also holds its ground-forecast gain ``G`` (:mod:`pavement_mcmc.criticism.ground`), and
``--effects`` restricts the catalogue effects hidden.

``--report``: no twin is run; the margin's calibration from the records already in ``--out``
(:func:`~pavement_mcmc.criticism.calibration.calibrate`: chosen on the clean twins of even
seed, measured on the odd ones; every rate with its exact 95 % interval) and the distribution
of the base model's forecast RMSE over the truth-parameter forecast on clean twins; with
ground gains in the records, the same calibration for each ground variant of the rule
(``GROUND_RULES`` of ``criticism/calibration.py``).

``--oracle [--records FILE ...]``: no rule is run; each catalogue record (of ``--records``,
else of ``--out``) gets the truth's own forecast gain
(:func:`~pavement_mcmc.criticism.campaign.oracle`: the true model at its true parameters,
scored like a candidate against the record's base forecast), the records are written to
``--out``, and the ceiling it sets is printed beside the rule's claims (``--report`` prints it
too for records that hold it). ``--param EFFECT.NAME=VALUE`` hides an effect at
other than its default strength, ``--spec NAME=VALUE`` sets a simulator setting (both end
up in the twins' names).

``--rules``: on the clean twins only, the base model's forecast RMSE under each future rule of
h(t) (``diurnal``, ``persist``) against the truth-parameter forecast under the same rule, and
the seconds of one forecast (a MAP refit of the training part).
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import re
import sys
import tempfile
import time
from pathlib import Path

# one core: numba's solver threads on a machine shared with busy processes cost 2x the CPU
# (measured: 19 s -> 8.6 s CPU a twin); set before numba is imported
os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from pavement_mcmc.criticism.calibration import GROUND_RULES, calibrate, rates_at  # noqa: E402
from pavement_mcmc.criticism.campaign import (  # noqa: E402
    FORECAST_CATALOGUE,
    diagnose_twin,
    forecast_campaign_twins,
    rates,
    truth_forecast_rmse,
)
from pavement_mcmc.criticism.entries import FORECAST_THRESHOLD  # noqa: E402
from pavement_mcmc.synthetic.corpus import forecast_twins  # noqa: E402


def compare_rules(twins, workdir: Path) -> list[dict]:
    from pavement_mcmc.criticism.fitting import refit
    from pavement_mcmc.criticism.forecast import forecast
    from pavement_mcmc.data import load_case
    from pavement_mcmc.posterior import build_problem
    from pavement_mcmc.synthetic.corpus import write_twin

    out = []
    for tw in twins:
        cfg = load_case(write_twin(tw, workdir / tw.name))
        pb = build_problem(cfg)
        base = refit(pb)
        rec = {"twin": tw.name}
        for rule in ("diurnal", "persist"):
            t0 = time.process_time()
            fc = forecast(pb, base.values(), rule=rule)
            ideal = truth_forecast_rmse(cfg, [], rule)
            rec[rule] = {"rmse_sigma": round(fc.rmse_sigma, 3),
                         "truth_rmse_sigma": round(ideal / cfg.measurements.sigma, 3),
                         "ratio": round(fc.rmse / ideal, 3),
                         "cpu_seconds": round(time.process_time() - t0, 1)}
        print(json.dumps(rec), flush=True)
        out.append(rec)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="forecast_campaign.jsonl")
    ap.add_argument("--clean", type=int, default=40)
    ap.add_argument("--per-effect", type=int, default=10)
    ap.add_argument("--off", type=int, default=3)
    ap.add_argument("--hours", type=float, default=40.0)
    ap.add_argument("--input-sigma", action="store_true")
    ap.add_argument("--rules", action="store_true")
    ap.add_argument("--report", action="store_true")
    ap.add_argument("--records", nargs="+", metavar="FILE",
                    help="with --report: the record files to pool (.jsonl or .jsonl.gz; "
                         "docs/campaign/ holds the two campaigns behind docs/VALIDATION.md)")
    ap.add_argument("--oracle", action="store_true",
                    help="the truth's own forecast gain on every catalogue twin of --records "
                         "(else of --out) (criticism.campaign.oracle), the records with it "
                         "written to --out, then the ceiling it sets beside the rule's claims")
    ap.add_argument("--param", action="append", default=[], metavar="EFFECT.NAME=VALUE",
                    help="a hidden effect's parameter other than its default (repeatable), e.g. "
                         "conductivity_temperature.kappa_beta=-0.015 (three times the default)")
    ap.add_argument("--spec", action="append", default=[], metavar="NAME=VALUE",
                    help="a simulator setting (SyntheticSpec) other than the twins' default, "
                         "e.g. et_available=net (evapotranspiration on R_n, the catalogue's form)")
    ap.add_argument("--seed-offset", type=int, default=0,
                    help="shift every twin's seed (1000: a fresh campaign that replicates the rates)")
    ap.add_argument("--effects", nargs="+", default=list(FORECAST_CATALOGUE),
                    help="the catalogue effects to hide (default: all of the campaign's)")
    args = ap.parse_args(argv)
    params = {}
    for item in args.param:
        key, _, value = item.partition("=")
        effect, _, name = key.partition(".")
        try:
            number = float(value)
        except ValueError:
            number = None
        if not (effect and name and number is not None):
            ap.error(f"--param {item!r}: expected EFFECT.NAME=VALUE with a number")
        params.setdefault(effect, {})[name] = number
    spec = {}
    for item in args.spec:
        name, _, value = item.partition("=")
        if not (name and value):
            ap.error(f"--spec {item!r}: expected NAME=VALUE")
        spec[name] = value
    try:  # bad --param / --spec: a usage error now, not at the first twin that uses them
        forecast_campaign_twins(1, 1, 0, hours=args.hours, effects=args.effects, params=params,
                                spec=spec)
    except ValueError as e:
        ap.error(str(e))
    workdir = Path(tempfile.mkdtemp(prefix="forecast_campaign_"))
    if args.rules:
        compare_rules(forecast_twins((), tuple(600 + k for k in range(args.clean)),
                                     hours=args.hours, input_sigma=args.input_sigma), workdir)
        return 0
    out = Path(args.out)
    done = {}
    if out.exists():
        done = {r["twin"]: r for r in map(json.loads, out.read_text().splitlines()) if r}
    records = list(done.values())
    if args.oracle:  # the records of --records, else those of --out (rewritten with the oracle)
        pooled = [r for p in args.records for r in _load(Path(p))] if args.records else records
        with_oracle(pooled, out, workdir, hours=args.hours, input_sigma=args.input_sigma,
                    params=params, spec=spec)
        return 0
    if args.report:
        report([r for p in args.records for r in _load(Path(p))] if args.records else records)
        return 0
    for tw in forecast_campaign_twins(args.clean, args.per_effect, args.off, hours=args.hours,
                                      input_sigma=args.input_sigma, seed_offset=args.seed_offset,
                                      effects=args.effects, params=params, spec=spec):
        if tw.name in done:
            continue
        t0 = time.process_time()
        rec = diagnose_twin(tw, workdir, forecast=True)
        rec["cpu_seconds"] = round(time.process_time() - t0, 1)
        rec.pop("verdict", None)
        with out.open("a") as f:
            f.write(json.dumps(rec) + "\n")
        records.append(rec)
        print(f"{rec['twin']}: claimed {rec['claimed']} (partial {rec['partial']}, none of these "
              f"{rec['none_of_these']}), {rec['cpu_seconds']} s cpu", flush=True)
    report(records)
    return 0


def with_oracle(records: list[dict], out: Path, workdir: Path, **kw) -> None:
    """Each catalogue record with its ``oracle`` (the twin simulated again from its name), all
    records written to ``out``; then the ceiling."""
    from pavement_mcmc.criticism.campaign import oracle
    from pavement_mcmc.data import load_case
    from pavement_mcmc.synthetic.corpus import write_twin

    with out.open("w") as f:
        for r in records:
            if r["category"] == "catalogue" and "oracle" not in r:
                effect = r["hidden"][0]
                seed = int(re.match(r"-s(\d+)", r["twin"][len(f"forecast-{effect}"):])[1])
                (tw,) = forecast_twins((effect,), (seed,), **kw)
                if tw.name != r["twin"]:
                    raise SystemExit(f"record {r['twin']} is not the twin {tw.name} of these "
                                     "settings: give its --param / --spec")
                cfg = load_case(write_twin(tw, workdir / tw.name))
                fc = {"rmse_sigma": r["forecast_rmse_sigma"], "rho": r["forecast_rho"],
                      "n": r["forecast_n"]}
                r["oracle"] = oracle(cfg, effect, fc, r["base_rmse_sigma"])
                print(f"{r['twin']}: claimed {r['claimed']}, truth's F {r['oracle']['F']}",
                      flush=True)
            f.write(json.dumps(r) + "\n")
    print_ceiling(records)


def print_ceiling(records: list[dict]) -> None:
    """The ceiling the truth's own forecast sets (criticism.campaign.ceiling), per effect."""
    from pavement_mcmc.criticism.campaign import ceiling

    c = ceiling(records, FORECAST_THRESHOLD)
    if not c:
        return
    print(f"the truth's own forecast gain (margin {FORECAST_THRESHOLD:g}): twins where it passes "
          "the margin, and the rule's claims there and in all")
    for eff, v in sorted(c.items(), key=lambda kv: (kv[0] != "clean", kv[0])):
        f = np.round(np.quantile(v["F"], [0.0, 0.5, 1.0]), 1).tolist() if v["F"] else "-"
        print(f"  {eff:26s} truth passes {v['passes']}/{v['valid']} (of {v['n']}; F min, median,"
              f" max {f}); claimed where it passes {v['claimed_where_passes']}/{v['passes']}, "
              f"in all {v['claimed']}/{v['n']}" + (f"; no oracle: {v['why']}" if v["why"] else ""))


def _load(path: Path) -> list[dict]:
    """Campaign records of a JSON-lines file, gzip-compressed when it ends in .gz."""
    with (gzip.open if path.suffix == ".gz" else open)(path, "rt", encoding="utf-8") as f:
        return [json.loads(line) for line in f if line.strip()]


def report(records: list[dict]) -> None:
    """The rates as run, the margin's calibration, the truth-forecast ratios, the CPU cost."""
    print(json.dumps(rates(records), indent=1))
    print(json.dumps(calibrate(records), indent=1))
    print("the in-sample variant (claimed when nothing forecasts better; measured, not adopted):")
    print(json.dumps(rates_at(records, FORECAST_THRESHOLD, insample=True), indent=1))
    if any("G" in e for r in records for e in r.get("entries", {}).values()):
        for g in GROUND_RULES:  # the rule with the ground forecast (criticism/ground.py)
            print(f"with the ground forecast ({g!r}), calibrated like the forcing rule:")
            print(json.dumps(calibrate(records, ground=g), indent=1))
            print(f"... at the shipped margin {FORECAST_THRESHOLD:g}:")
            print(json.dumps(rates_at(records, FORECAST_THRESHOLD, ground=g), indent=1))
    clean = [r for r in records if r["category"] == "clean"]
    ratio = np.array([r["forecast_ratio"] for r in clean if "forecast_ratio" in r])
    if ratio.size:
        q = np.quantile(ratio, [0.0, 0.1, 0.5, 0.9, 1.0]).round(3).tolist()
        print(f"forecast RMSE / truth-parameter forecast RMSE on {ratio.size} clean twins: "
              f"min, 10 %, median, 90 %, max = {q}; within 10 %: {int(np.sum(ratio <= 1.1))}")
    print_ceiling(records)
    cpu = np.array([r["cpu_seconds"] for r in records if "cpu_seconds" in r])
    if cpu.size:
        print(f"CPU seconds a twin ({cpu.size} twins): median {np.median(cpu):.1f}, "
              f"max {cpu.max():.1f}, total {cpu.sum() / 60:.0f} min")


if __name__ == "__main__":
    raise SystemExit(main())
