"""``pavement-mcmc diagnostics runs/X``: can the chain be trusted?"""

from __future__ import annotations

import argparse

import numpy as np

from .common import add_json_flag, emit

HELP = "convergence diagnostics of a stored run and a plain verdict"

def add_parser(sub) -> None:
    p = sub.add_parser(
        "diagnostics", help=HELP,
        description=HELP + ": per parameter mean, sd, IACT, ESS, split-R-hat, Geweke relative "
        "difference and z; acceptance, burn-in and drift. Works while the run is still writing.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("run", help="run directory (holding chain.h5)")
    p.add_argument("--burn-in", type=int, default=None,
                   help="steps to discard (default: stored/configured, else chosen by MSER)")
    add_json_flag(p)
    p.set_defaults(func=run)


def format_table(assessment) -> list[str]:
    """Fixed-width table of an :class:`~pavement_mcmc.report.Assessment`."""
    head = (f"  {'parameter':<10s} {'mean':>11s} {'sd':>10s} {'IACT':>7s} {'ESS':>8s} "
            f"{'R-hat':>6s} {'Gw rel':>8s} {'Gw z':>6s}  check")
    lines = [head]
    for name, s in assessment.table.items():
        fails = [k for k, lab in (("tau_ok", "IACT"), ("ess_ok", "ESS"), ("rhat_ok", "R-hat"),
                                   ("geweke_ok", "Geweke")) if not s[k]]
        check = "pass" if s["passed"] else "FAIL (" + ", ".join(
            {"tau_ok": "IACT", "ess_ok": "ESS", "rhat_ok": "R-hat", "geweke_ok": "Geweke"}[k]
            for k in fails) + ")"
        lines.append(f"  {name:<10s} {s['mean']:11.4g} {s['sd']:10.3g} {s['tau']:7.1f} "
                     f"{s['ess']:8.0f} {s['rhat']:6.3f} {100 * s['geweke_rel']:7.3f}% "
                     f"{s['geweke_z']:6.2f}  {check}")
    return lines


def run(args) -> int:
    from ..diagnostics.assessment import chains_note
    from ..runs import load_view

    view = load_view(args.run, burn_in=args.burn_in)
    a = view.assessment
    run_ = view.run
    q = np.percentile(a.acceptance_walkers, [0, 50, 100])
    lines = [
        f"run {view.path} ({view.problem.cfg.name}): {a.n_steps} steps stored x {a.n_chains} "
        f"walkers, sampler {run_.meta.get('sampler', '?')}",
        f"burn-in: {a.burn_in} steps ({view.burn_in_source}); kept {a.n_kept} steps",
        f"rule (the fit's stopping rule): {a.rule.text()}; adaptation {a.n_adapt_rows} steps "
        "(never kept)",
        *format_table(a),
        "note: " + chains_note(run_.meta.get("sampler", ""), a.rule),
        f"acceptance after burn-in: {a.acceptance:.3f} (walkers min {q[0]:.2f}, median "
        f"{q[1]:.2f}, max {q[2]:.2f})",
        f"drift of the kept log-posterior: trend z = {a.trend_z:.2f} -> "
        + ("DRIFTING" if a.drifting else f"no significant drift (|z| <= {a.rule.drift_z:g})"),
    ]
    lines += [f"warning: {w}" for w in a.warnings]
    lines.append(("TRUSTED: " if a.trusted else "NOT TRUSTED: ") + a.verdict_text())
    payload = {"run": str(view.path), "case": view.problem.cfg.name,
               "burn_in_source": view.burn_in_source, **a.to_dict(),
               "note": chains_note(run_.meta.get("sampler", ""), a.rule)}
    emit(args, payload, "\n".join(lines))
    return 0
