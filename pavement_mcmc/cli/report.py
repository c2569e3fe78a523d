"""``pavement-mcmc report runs/X [--out FILE]``: one self-contained HTML report of a run."""

from __future__ import annotations

import argparse

HELP = "write one self-contained HTML report of a run (figures, tables, config, verdict)"


def add_parser(sub) -> None:
    p = sub.add_parser(
        "report", help=HELP,
        description=HELP + ". Works on a finished run and on one still being written.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("run", help="run directory (holding chain.h5)")
    p.add_argument("--out", help="HTML file (default: <run>/report.html)")
    p.add_argument("--burn-in", type=int, default=None, help="steps to discard")
    p.add_argument("--draws", type=int, default=100,
                   help="posterior draws for the predictive band (default 100)")
    p.add_argument("--dpi", type=int, default=80, help="resolution of the embedded figures")
    p.set_defaults(func=run)


def refresh(run, out=None, burn_in=None, dpi: int = 80, draws: int = 100) -> str:
    """Write the run's report (again) and return the line saying so."""
    from ..report import build_report
    from ..runs import load_view

    view = load_view(run, burn_in=burn_in)
    out = build_report(view, out, dpi=dpi, n_draws=draws)
    a = view.assessment
    return (f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB): {a.n_steps} steps x {a.n_chains} "
            f"walkers, burn-in {a.burn_in}; " + ("converged" if a.trusted else "NOT trusted: see "
                                                   "the verdict"))


def run(args) -> int:
    from pathlib import Path

    from ..data import UserError

    if args.out is not None and not Path(args.out).resolve().parent.is_dir():
        raise UserError(f"--out {args.out}: no folder {Path(args.out).resolve().parent} to write "
                        "the report into")
    if args.draws < 1 or args.dpi < 10:
        raise UserError(f"--draws must be >= 1 and --dpi >= 10, got {args.draws} and {args.dpi}")
    print(refresh(args.run, args.out, args.burn_in, args.dpi, args.draws))
    return 0
