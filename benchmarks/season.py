"""A season in daily windows: its figure, its convergence and what it cost, from a batch folder.

``PYTHONPATH=. python benchmarks/season.py runs/season [--case runs/desert_daily.toml]
[--figure docs/figures/desert_season.png] [--wall-seconds S]``

Reads the batch folder of ``pavement-mcmc batch runs/desert_daily.toml --window 24h --step 24h
--out runs/season`` (``batch.csv`` and ``batch_costs.csv``; while the batch still runs, the
finished units' ``unit.json``), adds the record's own midday G/Rn (``G_surface`` of the
``extras.csv`` beside the case's CSV over its ``q_net``: measured, not fitted), draws
:func:`~pavement_mcmc.plotting.plot_season` and prints: units converged / not / failed (with the
reasons), the July days, κ/C by month, the cost per fitted unit (CPU s, wall s on a worker,
peak resident memory; units refused by the data checks left out) and the extrapolation to
1,000 stations × a year of daily windows. The wall
time of the batch is ``--wall-seconds`` or ``ended - started`` (two files of epoch seconds the
caller wrote into the folder).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pavement_mcmc.batch import COLUMNS, COSTS, TABLE, read_table, season_rows  # noqa: E402
from pavement_mcmc.data import load_case  # noqa: E402

#: the extrapolation: stations, daily windows a year each
STATIONS, DAYS = 1000, 365
#: July 2025 in hours from the record's first row (2025-03-01T07Z): the 30 days of issue 25
JULY = (2928.0, 3648.0)


def _rows(out: Path) -> tuple[list[dict], list[dict]]:
    """The batch rows and cost records, from the tables or, mid-batch, the units' unit.json."""
    if (out / TABLE).is_file():
        return read_table(out / TABLE), read_table(out / COSTS)
    recs = [json.loads(p.read_text()) for p in sorted(out.glob("*/unit.json"))]
    recs.sort(key=lambda r: r["start_h"])
    rows = [{c: r.get(c, math.nan) for c in COLUMNS} for r in recs]
    return rows, recs


def _stats(v) -> dict:
    v = np.asarray([x for x in v if x == x], float)
    if not v.size:
        return {}
    return {"n": int(v.size), "mean": float(v.mean()), "median": float(np.median(v)),
            "p90": float(np.percentile(v, 90)), "max": float(v.max())}


def summarise(rows: list[dict], costs: list[dict], wall_s: float | None) -> dict:
    """Counts, the July days, κ/C by month, costs and the extrapolation (plain numbers)."""
    status = [r["status"] for r in rows]
    july = [r for r in rows if JULY[0] <= r["start_h"] < JULY[1]]
    reasons: dict[str, int] = {}
    for r in rows:
        if r["status"] != "ok":
            key = f"{r['status']}: {str(r['reason'])[:90]}"
            reasons[key] = reasons.get(key, 0) + 1
    months: dict[str, list[float]] = {}
    share: dict[str, list[float]] = {}
    for r in rows:
        if r["status"] != "failed" and r["start_time"]:
            months.setdefault(r["start_time"][:7], []).append(r["diffusivity"] * 1e6)
        if r["start_time"] and r.get("G_Rn_midday", math.nan) == r.get("G_Rn_midday"):
            share.setdefault(r["start_time"][:7], []).append(r["G_Rn_midday"])
    fitted = {r["key"] for r in rows if r["status"] != "failed"}  # refused units cost ~0 s
    cpu, wall, mem = (_stats(c.get(k, math.nan) for c in costs if c["key"] in fitted)
                      for k in ("cpu_s", "elapsed_s", "peak_rss_mb"))
    units = STATIONS * DAYS
    out = {"units": len(rows), "converged": status.count("ok"),
           "not_converged": status.count("not converged"), "failed": status.count("failed"),
           "reasons": reasons,
           "july": {"units": len(july), "converged": sum(r["status"] == "ok" for r in july)},
           "diffusivity_mm2_s_by_month": {m: [round(float(np.median(v)), 3), round(min(v), 3),
                                              round(max(v), 3), len(v)] for m, v in months.items()},
           "G_Rn_midday": _stats(r.get("G_Rn_midday", math.nan) for r in rows),
           "G_Rn_midday_median_by_month": {m: round(float(np.median(v)), 3) for m, v in share.items()},
           "cpu_s_per_unit": cpu, "wall_s_per_unit_on_a_worker": wall, "peak_rss_mb_per_unit": mem,
           "batch_wall_s": wall_s}
    if cpu:
        core_h = units * cpu["mean"] / 3600.0
        out["extrapolation"] = {
            "units": units, "core_hours": core_h,
            "days_on_2_cores": core_h / 2 / 24, "hours_on_1000_cores": core_h / 1000,
            "memory_per_worker_mb": mem.get("max"),
            "note": f"{STATIONS} stations x {DAYS} daily windows at the mean CPU s per unit "
                    "measured here (one single-threaded worker per core, memory per worker = "
                    "the largest unit's peak)"}
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="the batch folder, e.g. runs/season")
    ap.add_argument("--case", type=Path, default=ROOT / "runs" / "desert_daily.toml")
    ap.add_argument("--figure", type=Path, default=None, help="PNG to write (default OUT/season.png)")
    ap.add_argument("--wall-seconds", type=float, default=None)
    args = ap.parse_args(argv)
    rows, costs = _rows(args.out)
    if not rows:
        raise SystemExit(f"{args.out}: no finished units")
    csv = load_case(args.case).csv_path
    rows = season_rows(rows, csv, csv.parent / "extras.csv", flux="G_surface")
    wall = args.wall_seconds
    if wall is None and (args.out / "ended").is_file():
        wall = float((args.out / "ended").read_text()) - float((args.out / "started").read_text())
    from pavement_mcmc.plotting import plot_season

    n = len(rows)
    fig = plot_season(rows, title=f"SoilVUE desert record, measured 5 cm top: {n} daily windows",
                      flux_label="measured surface flux G_surface (extras.csv)",
                      note="κ and C separately rest on their priors: the temperatures below a "
                           "measured top fix only κ/C")
    fig_path = args.figure or args.out / "season.png"
    fig.savefig(fig_path, dpi=80)
    print(json.dumps(summarise(rows, costs, wall), indent=1))
    print(f"wrote {fig_path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
