"""``pavement-mcmc urban runs/X [--wind other.csv] [--emissivity 0.95]``: the paper's urban-scale
comparison of h = 4 + 4 v against the estimated h(t)."""

from __future__ import annotations

import argparse

from .common import add_json_flag, emit

HELP = "compare the standard h = 4 + 4 v with the estimated h(t): surface T and long-wave"


def add_parser(sub) -> None:
    p = sub.add_parser(
        "urban", help=HELP,
        description=HELP + " emission (the same ground and forcing, two h's).",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("run", help="run directory (holding chain.h5)")
    p.add_argument("--wind", help="CSV with columns time,wind (m s-1) of another station "
                   "(default: the site's wind)")
    p.add_argument("--emissivity", type=float, default=0.95, help="surface emissivity (0.95)")
    p.add_argument("--draws", type=int, default=100, help="posterior draws for the bands (100)")
    p.add_argument("--burn-in", type=int, default=None, help="steps to discard")
    p.add_argument("--out", help="figure path (default: <run>/urban.png)")
    add_json_flag(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from pathlib import Path

    from ..analysis.urban import compare, read_wind_csv
    from ..plotting import plot_urban
    from ..runs import load_view

    view = load_view(args.run, burn_in=args.burn_in)
    pb = view.problem
    wind = read_wind_csv(args.wind, pb.meas) if args.wind else None
    mean = pb.space.expand(view.flat.mean(axis=0)[None, :])
    draws = pb.space.expand(view.draws(args.draws)) if args.draws > 0 else None
    c = compare(pb.model, {k: v[0] for k, v in mean.items()}, draws=draws, wind=wind,
                emissivity=args.emissivity)
    out = Path(args.out) if args.out else view.path / "urban.png"
    plot_urban(c).savefig(out, dpi=110)
    s = c.summary()
    src = args.wind or "the site's measured wind"
    lines = [
        f"{pb.cfg.name}: standard h = 4 + 4 v (wind: {src}) vs estimated h(t) (posterior mean)",
        f"  mean h: standard {s['mean_h_standard']:.2f}, estimated {s['mean_h_estimated']:.2f} "
        "W m-2 K-1",
        f"  max |dT_s|  = {s['max_abs_dTs']:.2f} degC at {s['time_of_max_dTs_h']:.2f} h "
        f"(dT_s = T_s(standard) - T_s(estimated) = {s['dTs_at_max']:+.2f})",
        f"  max |dq_LW| = {s['max_abs_dq_lw']:.2f} W m-2 at {s['time_of_max_dq_lw_h']:.2f} h "
        f"(emissivity {s['emissivity']:g})",
        f"  mean dT_s = {s['mean_dTs']:+.2f} degC, mean dq_LW = {s['mean_dq_lw']:+.2f} W m-2",
    ]
    if "max_abs_dTs_q2.5" in s:
        lines.append(f"  max |dT_s| over {args.draws} posterior draws: 95 % in "
                     f"[{s['max_abs_dTs_q2.5']:.2f}, {s['max_abs_dTs_q97.5']:.2f}] degC")
    lines.append("  (paper: more than 2 degC and about 15 W m-2)")
    lines.append(f"wrote {out}")
    emit(args, {"run": str(view.path), "wind": src, **s, "figure": str(out)}, "\n".join(lines))
    return 0
