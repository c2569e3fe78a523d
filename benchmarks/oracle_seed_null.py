"""The truth's forecast gain against the clean null of its own seed (review of issue 22's ceiling).

``PYTHONPATH=. python benchmarks/oracle_seed_null.py --records FILE ... [--hours H]
[--no-input-sigma]``

The truth's F of a record (``oracle``, :func:`~pavement_mcmc.criticism.campaign.oracle`) scores
the truth-parameter forecast against the *fitted* base's: on a clean twin of the same seed
(same weather, h(t) and noise) it is not zero but the gain of knowing the true h(t) over the
training part instead of fitting it. This prints that null per seed (a MAP refit of the clean
twin, about 1 s) and, per hidden effect (and strength), how often the truth's F, the truth's F
minus its seed's null and the fitted candidate's F pass the margin, beside the rule's claims.
"""

from __future__ import annotations

import argparse
import gzip
import json
import re
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

from pavement_mcmc.criticism.campaign import truth_forecast_rmse
from pavement_mcmc.criticism.entries import FORECAST_THRESHOLD
from pavement_mcmc.criticism.fitting import refit
from pavement_mcmc.criticism.forecast import forecast, gain
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin


def seed_null(seed: int, workdir: Path, hours: float, input_sigma: bool) -> float:
    """The truth's F on the clean forecast twin of ``seed``."""
    (tw,) = forecast_twins((), (seed,), hours=hours, input_sigma=input_sigma)
    cfg = load_case(write_twin(tw, workdir / tw.name))
    pb = build_problem(cfg)
    fc = forecast(pb, refit(pb).values())
    return gain(fc.n, fc.rho, fc.rmse, truth_forecast_rmse(cfg, [], fc.rule))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", nargs="+", required=True, metavar="FILE")
    ap.add_argument("--hours", type=float, default=40.0)
    ap.add_argument("--no-input-sigma", action="store_true")
    args = ap.parse_args(argv)
    rows = []
    for p in args.records:
        with (gzip.open if p.endswith(".gz") else open)(p, "rt", encoding="utf-8") as f:
            rows += [r for r in map(json.loads, f) if r.get("oracle", {}).get("valid")]
    if not rows:
        sys.exit("no record holds a valid oracle (forecast_campaign.py --oracle adds it)")
    workdir = Path(tempfile.mkdtemp(prefix="oracle_seed_null_"))
    seeds = sorted({int(re.search(r"-s(\d+)", r["twin"])[1]) for r in rows})
    null = {s: seed_null(s, workdir, args.hours, not args.no_input_sigma) for s in seeds}
    print("clean null of the truth's F per seed:", {s: round(f, 1) for s, f in null.items()})
    m = FORECAST_THRESHOLD
    table = defaultdict(lambda: [0, 0, 0, 0, 0])
    for r in rows:
        eff = r["hidden"][0]
        seed = re.search(r"-s(\d+)", r["twin"])
        key = eff + r["twin"][seed.end():]
        f = r["oracle"]["F"]
        c = table[key]
        c[0] += 1
        c[1] += f > m
        c[2] += f - null[int(seed[1])] > m
        c[3] += r["entries"][eff]["F"] > m
        c[4] += r["claimed"] == eff
    print(f"{'effect':44s} n  truth F>{m:g}  truth F - seed null>{m:g}  candidate F>{m:g}  claimed")
    for key, (n, a, b, c, d) in table.items():
        print(f"{key:44s} {n:2d}  {a:10d}  {b:23d}  {c:14d}  {d:7d}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
