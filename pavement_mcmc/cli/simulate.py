"""``pavement-mcmc simulate CASE.toml --set kappa=1.3 C=1.0e6 h=10``: run the forward model once.

Writes the predicted temperatures (CSV: ``time`` and ``T_<d>cm`` columns) and a measured-vs-
predicted figure with residuals (PNG), and prints the RMSE per sensor.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from ..data.times import times_after
from .common import add_json_flag, add_set_option, emit, split_assignments

HELP = "run the forward model at given parameter values; write predictions and a figure"


def add_parser(sub) -> None:
    p = sub.add_parser(
        "simulate",
        help=HELP,
        description=HELP + ". Unspecified parameters keep their config (or literature) values.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="example: pavement-mcmc simulate runs/caseA.toml --set kappa=1.3 C=1.0e6 h=10",
    )
    p.add_argument("case", help="case TOML file")
    add_set_option(p)
    p.add_argument("--out", help="output directory (default: <case dir>/<name>_simulate)")
    add_json_flag(p)
    p.set_defaults(func=run)


def describe_values(values: dict[str, float], space) -> str:
    """Compact ``name=value`` listing; consecutive h pieces with one value are merged."""
    parts, h = [], [n for n in values if space[n].group == "h"]
    hv = {values[n] for n in h}
    for n, v in values.items():
        if n in h:
            continue
        parts.append(f"{n}={v:.4g}")
    if h:
        parts.append(f"{h[0]}..{h[-1]}={hv.pop():.4g}" if len(hv) == 1 else f"{len(h)} h pieces")
    return " ".join(parts)


def iso_times(meas) -> list[str]:
    """ISO 8601 UTC time of each observation."""
    return times_after(meas.time0, meas.t)


def rmse_per_sensor(meas, pred: np.ndarray) -> dict[str, float]:
    """RMSE of ``pred`` (n_obs, n_sensors) against the data, initial-condition row excluded."""
    r = pred[1:] - meas.T_obs[1:]
    out = {lab: float(np.sqrt(np.mean(r[:, s] ** 2))) for s, lab in enumerate(meas.sensor_labels)}
    out["all"] = float(np.sqrt(np.mean(r**2)))
    return out


def run(args) -> int:
    from ..plotting import plot_fit
    from ..runs.case_at import problem_at

    problem, values = problem_at(args.case, *split_assignments(args.assign))
    meas = problem.meas
    p = {k: np.array([v]) for k, v in values.items()}
    pred = problem.model.predict(p)[0]
    name = problem.cfg.name
    out = Path(args.out) if args.out else problem.cfg.path.parent / f"{name}_simulate"
    out.mkdir(parents=True, exist_ok=True)
    csv_path, png_path = out / "predicted.csv", out / "simulate.png"
    with open(csv_path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time"] + [f"T_{d * 100:g}cm" for d in meas.depths])
        for ts, row in zip(iso_times(meas), pred):
            w.writerow([ts] + [f"{x:.4f}" for x in row])
    fig = plot_fit(meas, pred, label="simulated")
    fig.suptitle(f"{name}: {describe_values(values, problem.space)}", fontsize=9)
    fig.savefig(png_path, dpi=110)
    rmse = rmse_per_sensor(meas, pred)
    lines = [
        f"{name}: forward model at {describe_values(values, problem.space)}",
        f"RMSE per sensor (degC; sigma = {meas.sigma:g}; initial row excluded):",
        *(f"  {k:>6s}  {v:.4f}" for k, v in rmse.items()),
        f"wrote {csv_path}",
        f"wrote {png_path}",
    ]
    payload = {"case": name, "values": values, "rmse": rmse, "sigma": meas.sigma,
               "csv": str(csv_path), "figure": str(png_path)}
    emit(args, payload, "\n".join(lines))
    return 0
