"""``pavement-mcmc sensitivity CASE.toml [--set ...]``: reduced sensitivity coefficients and
identifiability before any sampling."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from .common import add_json_flag, add_set_option, emit, split_assignments
from .simulate import describe_values

HELP = "sensitivity coefficients p dT/dp and identifiability (parameter correlations) at a point"


def add_parser(sub) -> None:
    p = sub.add_parser(
        "sensitivity",
        help=HELP,
        description=HELP + ". Central differences with dp = 1e-2 p (the paper), all perturbed "
        "sets in one batched model call.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("case", help="case TOML file")
    add_set_option(p)
    p.add_argument("--rel-step", type=float, default=1e-2, help="relative step dp/p (default 1e-2)")
    p.add_argument("--threshold", type=float, default=0.95,
                   help="report parameter pairs with |correlation| above this (default 0.95)")
    p.add_argument("--out", help="figure directory (default: <case dir>/<name>_sensitivity)")
    add_json_flag(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..analysis.sensitivity import default_names, identifiability, reduced_sensitivity
    from ..plotting import plot_identifiability, plot_sensitivity
    from ..runs.case_at import problem_at

    problem, values = problem_at(args.case, *split_assignments(args.assign))
    names = default_names(problem.space, problem.model)
    sens = reduced_sensitivity(problem.model, values, names, rel_step=args.rel_step,
                               space=problem.space)
    sigma = float(problem.meas.sigma)
    ident = identifiability(sens, sigma, threshold=args.threshold)
    name = problem.cfg.name
    out = Path(args.out) if args.out else problem.cfg.path.parent / f"{name}_sensitivity"
    out.mkdir(parents=True, exist_ok=True)
    f1, f2 = out / "sensitivity.png", out / "identifiability.png"
    plot_sensitivity(sens, sigma=sigma).savefig(f1, dpi=110)
    plot_identifiability(ident).savefig(f2, dpi=110)

    mx = np.max(np.abs(sens.coefficients), axis=0)  # (n_sensors, n_params)
    lines = [f"{name}: reduced sensitivity coefficients p dT/dp at "
             f"{describe_values(values, problem.space)}",
             f"max |p dT/dp| per sensor (degC; sigma = {sigma:g}), and the relative sd the data "
             "alone would give (linearised, no prior):"]
    head = f"  {'parameter':<10s}" + "".join(f"{s:>8s}" for s in sens.sensors)
    lines.append(head + f"{'sd alone':>10s}{'sd joint':>10s}")
    for j, n in enumerate(names):
        lines.append(f"  {n:<10s}" + "".join(f"{v:8.3f}" for v in mx[:, j])
                     + f"{_pct(ident.rel_sd_alone[j]):>10s}{_pct(ident.rel_sd_joint[j]):>10s}")
    if len(names) <= 10:
        lines.append("correlation of the scaled sensitivity columns:")
        lines.append("  " + " " * 10 + "".join(f"{n[:7]:>8s}" for n in names))
        for j, n in enumerate(names):
            lines.append(f"  {n:<10s}" + "".join(f"{c:8.3f}" for c in ident.correlation[j]))
    lines.append(f"condition number of the scaled sensitivity matrix: {ident.condition_number:.4g}")
    lines.append("verdict:")
    lines += [f"  - {v}" for v in ident.verdict]
    note = problem.model.boundary_note()
    if note:
        lines.append(f"  - {note}")
    if problem.model.plate_names:
        lines.append(f"  - not in this table: {', '.join(problem.model.plate_names)} (a plate's "
                     "calibration factor enters only the plate's reading, not the temperatures)")
    lines += [f"wrote {f1}", f"wrote {f2}"]
    payload = {
        "case": name,
        "values": values,
        "rel_step": sens.rel_step,
        "sigma": sigma,
        "max_abs": {n: dict(zip(sens.sensors, mx[:, j].tolist())) for j, n in enumerate(names)},
        "identifiability": ident.to_dict(),
        "boundary_note": note,
        "figures": [str(f1), str(f2)],
    }
    emit(args, payload, "\n".join(lines))
    return 0


def _pct(x: float) -> str:
    return f"{100 * x:.2f}%" if np.isfinite(x) else "inf"
