"""``pavement-mcmc compare RUN RUN ... [--json]``: the error ledger of several runs."""

from __future__ import annotations

import argparse
from pathlib import Path

from .common import add_json_flag, emit

HELP = ("compare runs: RMSE per sensor, max |residual|, lag-1, chi2/dof, a hold-out score and "
        "the forecast of a held-out period, ranked by it")


def add_parser(sub) -> None:
    p = sub.add_parser(
        "compare",
        help=HELP,
        description=HELP + ". Each run is evaluated at its posterior mean (a case TOML: at its MAP). "
        "The out-of-sample score is leave-one-sensor-out: each sensor is held out in turn, the "
        "model refitted by MAP on the others and the held-out series predicted; the mean Gaussian "
        "log predictive density per held-out datum is reported (higher is better). Holding out "
        "whole series keeps their time correlation out of the fit. The forecast refits the start of "
        "each window and predicts the rest (the last 24 h of windows of 48 h or more, else the "
        "last quarter) from the forcing alone; runs are ranked by its log predictive density.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="example: pavement-mcmc compare runs/hidden runs/hidden_2l",
    )
    p.add_argument(
        "runs",
        nargs="+",
        help="run directories or case TOMLs, CASE.toml+EXT adds an "
        "extension (MAP only); the first is the reference",
    )
    p.add_argument("--no-holdout", action="store_true", help="skip the leave-one-sensor-out score")
    p.add_argument("--no-forecast", action="store_true", help="skip the forecast and its ranking")
    p.add_argument("--figure", help="residuals side by side (default: <first run>/compare.png)")
    add_json_flag(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..criticism import ledger
    from ..criticism.point import load_point
    from ..plotting.criticism import plot_compare
    from .diagnose import run_guards

    runs = []
    guards = [g for path in args.runs for g in run_guards(path)]
    for path in args.runs:
        problem, values, how, label = load_point(path)
        runs.append((label, problem, values))
        if Path(str(path).split("+")[0]).is_dir():  # the sampled run against its MAP route
            from ..criticism import analyse_point, refit
            from ..criticism.guards import rmse_vs_map

            g = rmse_vs_map(label, analyse_point(problem, values).rmse, refit(problem, values).rmse)
            guards += [g] if g is not None else []
    from ..criticism.guards import same_data

    g = same_data([(label, problem) for label, problem, _ in runs])
    guards += [g] if g is not None else []
    led = ledger(runs, holdout=not args.no_holdout, forecast=not args.no_forecast)
    first = Path(args.runs[0])
    fig_path = (
        Path(args.figure)
        if args.figure
        else (first / "compare.png" if first.is_dir() else first.with_name(first.stem + "_compare.png"))
    )
    plot_compare(led).savefig(fig_path, dpi=110)
    payload = led.to_dict()
    payload["figure"] = str(fig_path)
    payload["guards"] = [g.to_dict() for g in guards]
    warn = "".join(f"WARNING: {g.text}\n" for g in guards)
    emit(args, payload, warn + led.text() + f"\nfigure: {fig_path}" + ("\n" + warn if warn else ""))
    return 0
