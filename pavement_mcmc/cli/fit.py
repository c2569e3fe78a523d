"""``pavement-mcmc fit`` and ``pavement-mcmc resume``: sample a case's posterior into a run dir."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from .common import add_json_flag, add_set_option, emit, split_assignments
from .progress import Progress


def add_parser(sub) -> None:
    p = sub.add_parser(
        "fit", help="sample the posterior of a case into a run directory",
        description="Build the case's model and posterior, sample it until every parameter has "
                    "ESS >= the target (or the budget runs out), and write RUN/chain.h5, "
                    "RUN/summary.csv and RUN/summary.md.")
    p.add_argument("case", help="the case TOML, e.g. runs/caseA.toml")
    p.add_argument("--out", required=True, help="run directory, e.g. runs/caseA")
    p.add_argument("--overwrite", action="store_true", help="replace an existing run in --out")
    p.add_argument("--add", action="append", metavar="EXT", default=[],
                   help="add a physics extension (repeatable), e.g. --add two_layer")
    add_set_option(p)
    p.add_argument("--sampler", metavar="KIND", help="override sampler.kind: emcee, mh, fast or hmc")
    p.add_argument("--seed", type=int, help="override sampler.seed")
    p.add_argument("--max-seconds", type=float, help="wall-time budget of the sampling")
    p.add_argument("--ess", type=float, help="target effective sample size per parameter")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_json_flag(p)
    p.set_defaults(func=run_fit)

    r = sub.add_parser(
        "resume", help="continue an interrupted or unconverged run",
        description="Continue RUN from its last saved block (after Ctrl-C, kill -9 or a spent "
                    "budget); the chain is the same, bit for bit, as one run straight through. "
                    "Refused if the case's config or data changed since. A finished run is left "
                    "as it is unless --more-steps or --ess-target asks for more; a report.html "
                    "in RUN is rebuilt when the chain grows.")
    r.add_argument("run", help="run directory, e.g. runs/caseC")
    r.add_argument("--max-seconds", type=float, help="wall-time budget of this invocation")
    r.add_argument("--more-steps", type=int, metavar="N",
                   help="sample N steps more, even if the run is finished")
    r.add_argument("--ess-target", type=float, metavar="X",
                   help="a new ESS target for the run (continues a finished run until it is met)")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_json_flag(r)
    r.set_defaults(func=run_resume)


def _report(args, out) -> int:
    res = out.result
    payload = {"run_dir": str(out.run_dir), "converged": res.converged, "reason": res.reason,
               "n_steps": res.n_steps, "burn_in_rows": res.burn_in, "n_evals": res.n_evals,
               "elapsed_s": res.elapsed, "acceptance": res.acceptance,
               "min_ess": float(np.min(res.ess)) if res.ess.size else None,
               "max_rhat": float(np.max(res.rhat)) if res.rhat.size else None,
               "table": out.table, "plausibility": [f.text() for f in out.findings],
               "sampler_chosen": out.chosen, "grid_chosen": out.grid_chosen}
    from ..runs import format_table

    shown = out.table if len(out.table) <= 12 else out.table[:6] + out.table[-3:]
    text = "\n".join([
        format_table(shown)
        + ("\n(... see summary.md for every parameter)" if len(shown) < len(out.table) else ""),
        "",
        *[f.text() for f in out.findings],
        *([f"note: {n}"] if (n := out.problem.model.boundary_note()) else []),
        *([eb] if (eb := _energy_line(out)) else []),
        *([_grid_line(out.grid_chosen)] if out.grid_chosen else []),
        *([_chosen_line(out.chosen)] if out.chosen else []),
        f"{'converged' if res.converged else 'NOT converged'}: {res.reason}",
        f"{res.n_steps} steps, {res.n_evals} solves, {res.elapsed:.1f} s; "
        f"acceptance {res.acceptance:.2f}; wrote {out.run_dir}/chain.h5, summary.csv, summary.md",
    ])
    if not res.converged:
        text += f"\nto continue: pavement-mcmc resume {out.run_dir}"
    emit(args, payload, text)
    return 0 if res.converged else 1


def _energy_line(out) -> str | None:
    """The midday Bowen ratio, G/Rn and LE/Rn at the posterior mean, for an energy balance."""
    from ..physics.catalogue.energy import EnergyBalance, energy_partition

    pb = out.problem
    if not any(isinstance(e, EnergyBalance) for e in pb.model.extensions):
        return None
    from ..criticism.tower import tower_check

    p = {k: np.array([v]) for k, v in pb.space.value_dict().items()}
    p.update({r["parameter"]: np.array([r["mean"]]) for r in out.table})
    part = energy_partition(pb.model, p)
    tower = tower_check(part, pb.meas)
    return (part.summary_text() + " (posterior mean; bands in the report)"
            + ("" if tower is None else "\n" + tower.text()))


def _chosen_line(chosen: dict) -> str:
    """The sampler's options chosen from the problem, e.g. ``sampler options chosen: metric_windows
    = 3, log_positive = True (147 parameters ...)``."""
    vals = ", ".join(f"{k} = {v}" for k, v in chosen.items() if k != "why")
    return f"sampler options chosen: {vals}" + (f" ({chosen['why']})" if chosen.get("why") else "")


def _grid_line(g: dict) -> str:
    """The solver grid chosen from the case, e.g. ``grid chosen: stretched, 44 nodes (4 mm at
    the top to 30 mm), 7 steps per interval (the bottom boundary at 50 cm is deeper ...)``."""
    cells = (f"{g['top_mm']:g} mm at the top to {g['deep_mm']:g} mm" if g["kind"] == "stretched"
             else f"{g['top_mm']:g} mm")
    return (f"grid chosen: {g['kind']}, {g['nodes']} nodes ({cells}), {g['steps_per_interval']} "
            f"steps per interval ({g['why']})")


def _interrupted(run_dir) -> int:
    print(f"\ninterrupted: the chain up to the last saved block is in {run_dir}/chain.h5\n"
          f"to continue: pavement-mcmc resume {run_dir}", file=sys.stderr)
    return 130


def _progress(args) -> Progress | None:
    return None if (args.no_progress or args.json) else Progress()


def run_fit(args: argparse.Namespace) -> int:
    from ..runs import fit

    overrides, values = split_assignments(args.assign)
    bar = _progress(args)
    try:
        out = fit(args.case, args.out, overwrite=args.overwrite, add=args.add,
                  set_values=values, overrides=overrides or None, sampler=args.sampler, seed=args.seed,
                  max_seconds=args.max_seconds, ess_target=args.ess, callback=bar)
    except KeyboardInterrupt:
        return _interrupted(args.out)
    finally:
        if bar is not None:
            bar.close()
    return _report(args, out)


def run_resume(args: argparse.Namespace) -> int:
    from ..runs import resume

    bar = _progress(args)
    try:
        out = resume(args.run, max_seconds=args.max_seconds, callback=bar,
                     more_steps=args.more_steps, ess_target=args.ess_target)
    except KeyboardInterrupt:
        return _interrupted(args.run)
    finally:
        if bar is not None:
            bar.close()
    if not out.ran:
        res = out.result
        emit(args, {"run_dir": str(out.run_dir), "finished": True, "n_steps": res.n_steps,
                    "reason": res.reason},
             f"{out.run_dir} is finished ({res.n_steps} steps; {res.reason}); nothing to do.\n"
             "to sample more: pavement-mcmc resume RUN --more-steps N, or --ess-target X")
        return 0
    code = _report(args, out)
    if out.report_removed:  # the chain changed: the report follows it
        from .report import refresh

        print(refresh(out.run_dir), file=sys.stderr)
    return code
