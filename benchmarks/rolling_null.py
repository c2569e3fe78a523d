"""The null and the power of ``pavement-mcmc rolling`` (criticism/rolling.py): how often is a
law named by chance?

``pavement-mcmc rolling BASE LAW`` fits both cases by MAP on 72 h windows a day apart, forecasts
the day after each from the forcing alone (a per-interval h by its clock-hour mean) and names
the law when it forecasts better on more days than a fair coin gives (one-sided sign test,
p <= 0.05) with a positive summed gain F. Here the same function on forecast twins of
:func:`pavement_mcmc.synthetic.corpus.forecast_twins` stretched to 18 days (15 windows, as the
grass record), the law ``energy_balance_window`` (H = (eb_h0 + eb_h1 u)(T_s - T_air),
LE = alpha s/(s+gamma) max(R_n, 0)) against the free h of the twin's Case C form:

- clean twins, whose h(t) is a diurnal shape drawn day by day from knots that no law of wind or
  radiation makes: the false-naming rate;
- wind-driven twins (``wind_convection``: h = a + b u, which the law contains): the power;
- still twins (``--still``): h a constant 10 W m-2 K-1 and no wind column, the law's no-wind
  fallback exactly (H = eb_h0 (T_s - T_air)) and no latent heat, as over a dry, windless
  site: the power where the balance adds no forcing the free h lacks and can win only by
  having fewer parameters.

    PYTHONPATH=. NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/rolling_null.py \
        --out rolling_null.jsonl [--clean 40] [--wind 10] [--clean-from 600] [--wind-from 700]
    PYTHONPATH=. python benchmarks/rolling_null.py --report rolling_null.jsonl
    ... --clean 0 --wind 40 --base-ext wind_convection   (the true law as the base: the null of
                                                          a law nearly right)
    ... --law energy_balance_window+shading --shade 10    (a law with a daily shadow: its null
                                                          on clean twins, its power on shadows)
    ... --clean 0 --wind 0 --still 10                    (the power on still twins)
    PYTHONPATH=. python benchmarks/rolling_null.py --report docs/campaign/rolling_null_s600.jsonl.gz

One JSON line per twin (resumed: twins in ``--out`` are skipped). Without OMP_NUM_THREADS=1
the BLAS threads of the MAP refits oversubscribe the cores and a twin takes minutes.
"""

from __future__ import annotations

import argparse
import gzip
import json
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from pavement_mcmc.criticism.calibration import binomial_interval
from pavement_mcmc.criticism.rolling import LEVEL, rolling_forecast
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin
from pavement_mcmc.synthetic.io import drop_columns

#: days of each twin and 72 h windows a day apart in them (as the grass record's 15)
DAYS, WINDOWS = 18, 15
CANDIDATE = "energy_balance_window"
DAY_H = 24.0
#: the grass record's figures (``pavement-mcmc rolling runs/grass.toml runs/grass_energy.toml``,
#: docs/VALIDATION.md §5): F summed, days the law forecasts better of 15, and the mean
#: log(MSE_base / MSE_law) per day
GRASS_SUM, GRASS_WINS, GRASS_LOG_RATIO = 48.3, 11, 0.78
#: the still twins' constant h, W m-2 K-1 (the forecast twins' diurnal knots run 7-16)
STILL_H = 10.0


def still_twins(seeds) -> list:
    """Clean forecast twins with a constant h and (in :func:`one_twin`) no wind column; the
    corpus's categories have none for them, their names say "still" (:func:`is_still`)."""
    return [replace(t, name=t.name.replace("clean", "still"),
                    description=t.description + "; h constant, no wind",
                    spec=replace(t.spec, h_knots=(STILL_H,) * len(t.spec.h_knots)))
            for t in forecast_twins((), hours=DAYS * DAY_H, input_sigma=True, seeds=tuple(seeds))]


def is_still(name: str) -> bool:
    return name.startswith("forecast-still")


def one_twin(twin, root: Path, base_ext: str | None = None, law: str = CANDIDATE) -> dict:
    """Per-day forecast RMSEs and F of base and law over the twin's rolling windows
    (:func:`pavement_mcmc.criticism.rolling.rolling_forecast`, as ``pavement-mcmc rolling``)."""
    t0 = time.perf_counter()
    case = write_twin(twin, root / twin.name)
    if is_still(twin.name):  # a windless record: the law takes its no-wind fallback
        drop_columns(case.parent / "measurements.csv", ("wind",))
    base = f"{case}+{base_ext}" if base_ext else str(case)
    res = rolling_forecast(base, f"{case}+{law}", days=WINDOWS)
    days = [{"F": d.F, "base": d.base_rmse, "cand": d.law_rmse, "base_in": d.base_fit,
             "cand_in": d.law_fit, "n_phi": d.n_phi} for d in res.days]
    return {"twin": twin.name, "category": twin.category, "hidden": list(twin.hidden),
            "days": days, "F_sum": res.F_sum, "wins": res.wins, "p_value": res.p_value,
            "named": res.named, "base_ext": base_ext, "law": law,
            "seconds": time.perf_counter() - t0}


def report(records: list[dict]) -> None:
    still = [r for r in records if is_still(r["twin"])]
    clean = [r for r in records if r["category"] == "clean" and not is_still(r["twin"])]
    other = [r for r in records if r["category"] != "clean" and not r.get("base_ext")]
    truth = [r for r in records if r["category"] != "clean" and r.get("base_ext")]
    for name, rows in (("clean", clean), ("hidden effect", other),
                       ("hidden effect, its law in the base", truth),
                       ("still (h constant, no wind: the law's fallback is the truth)", still)):
        if not rows:
            continue
        s = np.array([r["F_sum"] for r in rows])
        w = np.array([r["wins"] for r in rows])
        f = np.array([x["F"] for r in rows for x in r["days"]])
        nphi = np.array([x["n_phi"] for r in rows for x in r["days"]])
        print(f"{name}: {len(rows)} twins; F summed over {WINDOWS} days: min {s.min():+.1f}, "
              f"median {np.median(s):+.1f}, max {s.max():+.1f}; days the law forecasts better: "
              f"{w.min()}-{w.max()} of {WINDOWS} (median {np.median(w):.0f}); F per day "
              f"{f.min():+.1f} ... {f.max():+.1f} (median {np.median(f):+.1f}); n/phi per day "
              f"{np.median(nphi):.1f} (median)")
        lr = np.array([np.mean([2 * np.log(x["base"] / x["cand"]) for x in r["days"]]) for r in rows])
        print(f"  mean log(MSE_base / MSE_law) per day, by twin: {lr.min():+.2f} ... {lr.max():+.2f} "
              f"(median {np.median(lr):+.2f}; the grass record: {GRASS_LOG_RATIO:+.2f})")
        named = int(sum(r["named"] for r in rows))
        lo, hi = binomial_interval(named, len(rows))
        print(f"  named by the rule (sign test p <= {LEVEL:g}, F summed > 0): {named} of "
              f"{len(rows)} (95 %: {100 * lo:.0f}-{100 * hi:.0f} %)")
        print(f"  sums above the grass record's {GRASS_SUM}: {int(np.sum(s > GRASS_SUM))} of "
              f"{len(rows)}; {GRASS_WINS}+ days better: {int(np.sum(w >= GRASS_WINS))} of {len(rows)}")
        for r in rows:
            print(f"  {r['twin']}: F summed {r['F_sum']:+.1f}, better on {r['wins']} days, "
                  f"forecast RMSE median base {np.median([x['base'] for x in r['days']]):.3f} / law "
                  f"{np.median([x['cand'] for x in r['days']]):.3f} degC ({r['seconds']:.0f} s)")
    if clean:
        s = np.sort([r["F_sum"] for r in clean])
        margin = next((m for m in (15, 30, 50, 75, 100, 150, 200, 300)
                       if np.mean(s > m) <= 1 / 20), None)
        print(f"smallest margin of 15, 30, 50, 75, 100, 150, 200, 300 with <= 1/20 clean sums "
              f"above it: {margin}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--report", type=Path)
    ap.add_argument("--clean", type=int, default=40, help="clean twins (default 40)")
    ap.add_argument("--wind", type=int, default=10, help="wind_convection twins (default 10)")
    ap.add_argument("--clean-from", type=int, default=600, help="first clean seed (600)")
    ap.add_argument("--wind-from", type=int, default=700, help="first wind seed (700)")
    ap.add_argument("--shade", type=int, default=0, help="shading twins (default 0)")
    ap.add_argument("--shade-from", type=int, default=900, help="first shading seed (900)")
    ap.add_argument("--still", type=int, default=0,
                    help=f"still twins: h {STILL_H:g} W m-2 K-1, no wind column (default 0)")
    ap.add_argument("--still-from", type=int, default=1000, help="first still seed (1000)")
    ap.add_argument("--law", default=CANDIDATE, metavar="EXT[+EXT]",
                    help=f"the law's extensions (default {CANDIDATE}; e.g. "
                    f"{CANDIDATE}+shading)")
    ap.add_argument("--base-ext", metavar="EXT",
                    help="add EXT to the base case (wind_convection on wind twins: the true law "
                    "as the base, the null of a law with more in it than the truth)")
    a = ap.parse_args(argv)
    if a.report:
        text = (gzip.decompress(a.report.read_bytes()).decode() if a.report.suffix == ".gz"
                else a.report.read_text())
        report([json.loads(ln) for ln in text.splitlines() if ln.strip()])
        return
    if a.out is None:
        ap.error("give --out (records) or --report")
    hours = DAYS * DAY_H
    twins = (forecast_twins((), hours=hours, input_sigma=True,
                            seeds=tuple(range(a.clean_from, a.clean_from + a.clean)))
             + forecast_twins(("wind_convection",), hours=hours, input_sigma=True,
                              seeds=tuple(range(a.wind_from, a.wind_from + a.wind)))
             + forecast_twins(("shading",), hours=hours, input_sigma=True,
                              seeds=tuple(range(a.shade_from, a.shade_from + a.shade)))
             + still_twins(range(a.still_from, a.still_from + a.still)))
    done = set()
    if a.out.exists():
        done = {json.loads(ln)["twin"] for ln in a.out.read_text().splitlines() if ln.strip()}
    with tempfile.TemporaryDirectory() as tmp:
        for twin in twins:
            if twin.name in done:
                continue
            rec = one_twin(twin, Path(tmp), a.base_ext, a.law)
            with a.out.open("a") as fh:
                fh.write(json.dumps(rec) + "\n")
            print(f"{rec['twin']}: F summed {rec['F_sum']:+.1f}, better on {rec['wins']} of "
                  f"{WINDOWS} days ({rec['seconds']:.0f} s)", flush=True)
    report([json.loads(ln) for ln in a.out.read_text().splitlines() if ln.strip()])


if __name__ == "__main__":
    main()
