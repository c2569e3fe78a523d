"""``pavement-mcmc batch``: many fits on Dask (windows of a long record and/or many sites)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .common import add_json_flag, add_set_option, emit, split_assignments


def add_parser(sub) -> None:
    p = sub.add_parser(
        "batch", help="fit windows of a long record and/or many sites on a Dask cluster",
        description="Fit every unit (a window of a case's record, or a case) into OUT/<unit>/, an "
                    "ordinary run folder (report, diagnose, resume work on it), on Dask distributed: "
                    "a local cluster of one single-threaded worker process per core unless "
                    "--scheduler (or DASK_SCHEDULER_ADDRESS) names an existing one. Writes "
                    "OUT/batch.csv (one row per unit) and OUT/batch.png. Run it again to resume: "
                    "finished units are skipped, interrupted ones continue bit for bit.")
    p.add_argument("cases", nargs="+", help="case TOMLs, or folders of them (one unit per case)")
    p.add_argument("--out", required=True, help="batch folder, e.g. runs/grass_daily")
    p.add_argument("--window", metavar="DUR", help="cut each case's record into windows, e.g. 24h")
    p.add_argument("--step", metavar="DUR", help="start of one window to the next (default: --window)")
    p.add_argument("--windows", metavar="A-B", nargs="+",
                   help="explicit windows in hours from the record's start, e.g. 0-24 48-72")
    add_set_option(p)
    p.add_argument("--seed", type=int, default=0, help="batch seed (unit seeds derive from it and the unit)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="an existing Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: "
                        "$DASK_SCHEDULER_ADDRESS, else a local cluster)")
    p.add_argument("--workers", type=int, help="local cluster: worker processes (default: one per core)")
    p.add_argument("--retries", type=int, default=1, help="Dask retries of a unit that raised")
    p.add_argument("--max-seconds", type=float,
                   help="wall-time budget per unit (default none: stopping depends on steps only)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--no-figure", action="store_true", help="do not draw OUT/batch.png")
    add_json_flag(p)
    p.set_defaults(func=run_batch_command)


def _units(args, overrides):
    from ..batch import case_units, window_units

    paths = []
    for c in args.cases:
        c = Path(c)
        paths.extend(sorted(c.glob("*.toml")) if c.is_dir() else [c])
    if not (args.window or args.windows):
        return case_units(paths, overrides)
    windows = None
    if args.windows:
        windows = []
        for w in args.windows:
            a, sep, b = w.partition("-")
            try:
                windows.append((float(a), float(b)))
            except ValueError:
                raise ValueError(f"--windows expects START-END in hours, got {w!r}") from None
    return [u for c in paths for u in window_units(c, args.window, args.step, windows, overrides)]


def run_batch_command(args: argparse.Namespace) -> int:
    from ..batch import TABLE, run_batch

    overrides, values = split_assignments(args.assign)
    for name, v in values.items():
        overrides.setdefault("parameters", {}).setdefault(name, {})["value"] = v
    units = _units(args, overrides)
    bar = None
    if not (args.no_progress or args.json):
        from tqdm import tqdm

        bar = tqdm(total=len(units), unit="unit", file=sys.stderr, desc="batch")

    def done(i, outcome):
        if bar is not None:
            bar.update(1)
            status = outcome.get("status", "failed") if isinstance(outcome, dict) else "failed"
            bar.set_postfix_str(f"{units[i].key}: {status}")

    try:
        rows = run_batch(units, args.out, seed=args.seed, scheduler=args.scheduler,
                         n_workers=args.workers, retries=args.retries, max_seconds=args.max_seconds,
                         on_done=done)
    finally:
        if bar is not None:
            bar.close()
    out = Path(args.out)
    if not args.no_figure:
        from ..plotting import plot_batch

        plot_batch(rows, title=f"{out.name}: {len(rows)} units").savefig(out / "batch.png", dpi=120)
    failed = [r for r in rows if r["status"] == "failed"]
    unconv = [r for r in rows if r["status"] == "not converged"]
    lines = [f"{len(rows)} units: {len(rows) - len(failed) - len(unconv)} converged, "
             f"{len(unconv)} not converged, {len(failed)} failed; wrote {out / TABLE}"
             + ("" if args.no_figure else f" and {out / 'batch.png'}")]
    lines += [f"  not converged {r['key']}: {r['reason']} (pavement-mcmc resume {out / r['run_dir']})"
              for r in unconv]
    lines += [f"  FAILED {r['key']}: {r['reason']}" for r in failed]
    lines += [_costs_line(out)]
    emit(args, {"table": str(out / TABLE), "rows": rows}, "\n".join(lines))
    return 1 if failed else 0


def _costs_line(out: Path) -> str:
    """Wall time and peak memory per unit, from OUT/batch_costs.csv."""
    from ..batch import COSTS, read_table

    rows = read_table(out / COSTS)
    mem = [r["peak_rss_mb"] for r in rows if r["peak_rss_mb"] == r["peak_rss_mb"]]
    secs = [r["elapsed_s"] for r in rows if r["elapsed_s"] == r["elapsed_s"]]
    cpu = [r["cpu_s"] for r in rows if r.get("cpu_s", float("nan")) == r.get("cpu_s")]
    if not mem:
        return f"costs per unit: see {out / COSTS}"
    return (f"per unit: {sum(secs) / len(secs):.1f} s on a worker on average"
            + (f" ({sum(cpu) / len(cpu):.1f} CPU s)" if cpu else "")
            + f", peak memory {max(mem):.0f} MB at most ({out / COSTS})")
