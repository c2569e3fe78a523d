"""``pavement-mcmc diagnose RUN [--json]``: where the model fails and which effect is missing.

RUN is a stored run directory (its posterior mean is used; nothing is re-sampled) or a case
TOML (the model is fitted by MAP first, useful before any sampling).
"""

from __future__ import annotations

import argparse
import json
import sys
import textwrap
from pathlib import Path

from ..criticism.entries import (
    DATA_THRESHOLD,
    ENERGY_LAWS,
    FORECAST_THRESHOLD,
    LOSO_NONE,
    energy_law,
)
from ..criticism.ranking import finer_h_spec
from ..criticism.verdict import headline
from ..physics.hbasis import FINER_H
from .common import add_json_flag, emit

HELP = "residual diagnosis and a ranked list of the physical effects the model may be missing"


def add_parser(sub) -> None:
    p = sub.add_parser(
        "diagnose",
        help=HELP,
        description=HELP + ". Per sensor: RMSE and bias against sigma, lag-1 autocorrelation and "
        "Ljung-Box test, 24 h amplitude and phase errors, correlations with forcing; then every "
        "catalogue extension not in the model (and a finer h(t)) is added in a quick MAP refit and "
        "scored by its penalised misfit drop (autocorrelation-aware BIC) and by its forecast: the "
        "start of the window is refitted and the rest predicted from the forcing alone; a "
        "candidate is claimed when it forecasts better by a calibrated margin.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n  pavement-mcmc diagnose runs/hidden\n"
        "  pavement-mcmc diagnose runs/hidden.toml --json",
    )
    p.add_argument("run", help="run directory (posterior mean) or case TOML (MAP fit)")
    p.add_argument("--no-rank", action="store_true", help="residual statistics only")
    p.add_argument("--only", nargs="+", metavar="EXT", help="candidates to try (default: all)")
    p.add_argument("--median", action="store_true", help="posterior median instead of mean")
    p.add_argument("--no-forecast", action="store_true",
                   help="claim by the in-sample score alone (no forecast of a held-out period)")
    p.add_argument("--force", action="store_true",
                   help="diagnose an unfinished or failed run anyway (its chain is not a posterior)")
    p.add_argument(
        "--figures",
        metavar="DIR",
        help="write the figures here (default: the run directory; none for a TOML)",
    )
    add_json_flag(p)
    p.set_defaults(func=run)


def _forecast_line(fc) -> str:
    return (f"forecast of the held-out {fc.horizon:g} h (fit to the first {fc.origins[-1]:g} h, "
            f"{fc.future}): RMSE {fc.rmse:.3f} °C = "
            f"{fc.rmse_sigma:.2f} σ, log predictive density {fc.lpd:+.2f} per datum")


def _summary(dx, how: str, label: str) -> list[str]:
    """The lines a user reads first: the model, the fit, the forecast, the verdict, what next."""
    rep = dx.residuals
    lines = [
        f"{label}: {dx.problem.model.describe()}; point estimate: {how}",
        f"fit: RMSE {rep.rmse:.3f} °C = {rep.rmse_sigma:.2f} σ (σ = {rep.sigma:g} °C; the "
        f"misfit floor of a correct model is about 1.1-1.2 σ), lag-1 {rep.rho:.2f}",
    ]
    if dx.forecast is not None:
        lines.append(_forecast_line(dx.forecast))
    rk = dx.ranking
    if rk is not None:
        lines += ["", *textwrap.wrap(headline(rk), 100), "",
                  *textwrap.wrap("Why: " + rk.verdict, 100), *next_step(rk)]
    return lines


def _candidates(rk) -> list[str]:
    fc = rk.forecast is not None
    ground = any(e.ground_gain is not None for e in rk.entries)
    rule = (f"* claimable: its forecast gain F > {FORECAST_THRESHOLD:g} and no worse in-sample "
            f"fit (S >= -{rk.threshold:g})" if fc else
            f"* claimable: S > {rk.threshold:g} and D > {DATA_THRESHOLD:g}")
    lines = [
        "",
        "Candidates (S = penalised misfit drop, autocorrelation-aware BIC; D = its data part, "
        "the misfit drop alone, never credited for fewer parameters; "
        + ("F = forecast gain, the held-out period's effective count times log(base forecast "
           "MSE / candidate's); " if fc else "")
        + ("G = the same gain of the ground forecast (the deeper sensors from the measured top "
           "sensor; ground and sensor candidates only), the larger of F and G is claimed; "
           if ground else "")
        + f"{rule}, or it brings an impossible fit back into range; "
        "~ prior-driven: S passes through Δprior or fewer parameters, not claimed; "
        "! a parameter of its own at a bound, or per-sensor offsets that line up with depth, "
        "or a sensor its fit to the others misses by more than "
        f"{LOSO_NONE:g} σ, not claimed):",
        f"  {'#':<3}{'candidate':<26}{'S':>8}{'D':>8}{'Δχ²':>9}{'Δprior':>8}{'+params':>8}"
        f"{'RMSE':>7}{'/σ':>6}" + (f"{'F':>8}{'fc /σ':>7}" if fc else "")
        + (f"{'G':>8}" if ground else ""),
    ]
    for i, e in enumerate(rk.entries, 1):
        mark = ("*" if e.detected else "!" if e.at_bound or e.profile or e.unpredicted
                else "~" if e.prior_driven else " ")
        lines.append(
            f"{mark} {i:<3}{e.name:<26}{e.score:8.1f}{e.data_score:8.1f}{e.delta_chi2:9.1f}"
            f"{e.delta_prior:8.1f}{e.added_params:8.2f}{e.rmse:7.3f}{e.rmse_sigma:6.2f}"
            + (f"{e.forecast_gain:8.1f}{e.forecast_rmse_sigma:7.2f}" if fc else "")
            + ((f"{e.ground_gain:8.1f}" if e.ground_gain is not None else f"{'-':>8}")
               if ground else "")
            + (f"  LOSO lpd {e.loso_lpd:+.3f}" if e.loso_lpd is not None else "")
            + (f"  at bound: {', '.join(e.at_bound)}" if e.at_bound else "")
            + ("  offsets: one coherent depth profile" if e.profile else "")
            + (f"  misses the {e.unpredicted[0]} sensor out of sensor: {e.unpredicted[1]:.1f} σ"
               if e.unpredicted else "")
            + (f"  out of sensor ≤ {max(e.loso_rmse_sigma.values()):.1f} σ"
               if e.loso_rmse_sigma and not e.unpredicted else "")
        )
        if i <= 3 or e.detected:
            for ev in e.evidence:
                lines.append(f"        - {ev}")
            if e.values:
                lines.append("        fitted: " + ", ".join(f"{k}={v:.4g}" for k, v in e.values.items()))
    for k, why in rk.skipped.items():
        lines.append(f"  (not tried: {k}: {why})")
    return lines


def _text(dx, how: str, label: str) -> str:
    """The verdict first (:func:`_summary`), then the tables it rests on."""
    rep = dx.residuals
    lines = [
        *_summary(dx, how, label),
        "",
        "Details",
        f"{'sensor':<8}{'RMSE':>7}{'/σ':>6}{'mean':>8}{'lag-1':>7}{'LB p':>9}"
        f"{'amp ratio':>10}{'phase h':>9}  strongest correlation",
    ]
    for s in rep.sensors:
        best = max(s.correlations.items(), key=lambda kv: abs(kv[1][1]))
        lines.append(
            f"{s.label:<8}{s.rmse:7.3f}{s.rmse_sigma:6.2f}{s.bias:+8.3f}{s.lag1:7.2f}"
            f"{s.ljung_box_p:9.1e}{s.amp_ratio:10.3f}{s.phase_error_h:+9.2f}  "
            f"{best[0]} r={best[1][0]:+.2f} z={best[1][1]:+.1f}"
        )
    if dx.findings:
        lines += ["", "Plausibility of the point estimate:", *[f"  {f.text()}" for f in dx.findings]]
    if dx.energy is not None:
        lines += ["", "Surface energy balance:", *[f"  {x}" for x in dx.energy.text().splitlines()]]
    rk = dx.ranking
    if rk is None:
        return "\n".join(lines)
    lines += _candidates(rk)
    if rk.unexplained is not None:
        lines += ["", *rk.unexplained.text().splitlines()[1:]]
    return "\n".join(lines)


def next_step(rk) -> list[str]:
    """The command or config change that acts on the verdict (empty if there is none)."""
    lines = []
    if rk.best is not None and rk.best.name == FINER_H:
        spec = finer_h_spec(rk.base.problem)
        edges = ", ".join(f"{x:g}" for x in spec["edges_hours"])
        lines.append(
            "Next: give h(t) finer pieces: in the case file set\n"
            f"  [model]\n  h = {{ kind = \"pieces\", edges_hours = [{edges}] }}\n"
            f"or run: pavement-mcmc fit <case.toml> --add {FINER_H} --out <new run> (the same "
            "change), then pavement-mcmc compare <this run> <new run>")
    elif rk.best is not None:
        order = [e.name for e in rk.best.fit.problem.model.extensions]
        if order[-1] != rk.best.name:  # it must come before the model's other extensions
            lines.append(
                f"Next: set [model] extensions = {json.dumps(order)} in the case file (in this order), refit "
                "with pavement-mcmc fit, then pavement-mcmc compare <this run> <new run>"
            )
        else:
            lines.append(
                f"Next: pavement-mcmc fit <case.toml> --add {rk.best.name} --out <new run>, "
                "then pavement-mcmc compare <this run> <new run>"
            )
    elif rk.unexplained is not None:
        lines.append("Next: write the extension (template above) in a module of your own, then "
                     "pavement-mcmc diagnose <case.toml>+mymodule:MyEffect to score it")
    law = next((e.name for e in rk.entries if e.name in ENERGY_LAWS), None)  # the energy check
    if rk.best is None and (rk.points_at or law) and not rk.base.problem.model.replaces_h:
        law = law or energy_law(rk.base.problem.meas)  # the one the record supports
        lines.append("Next: one held-out day is a weak test on a field record; over a longer "
                     "record test a surface energy balance day after day: pavement-mcmc rolling "
                     f"<case.toml> <case.toml>+{law} (or a case of your own "
                     "with the balance)")
    return lines


def _best_forecast(rk):
    """The claimed candidate, else the one with the largest forecast gain (None without any)."""
    if rk.best is not None and rk.best.forecast is not None:
        return rk.best
    return max((e for e in rk.entries if e.forecast is not None), key=lambda e: e.forecast_gain,
               default=None)


def run_guards(path: str) -> list:
    """:func:`~pavement_mcmc.criticism.guards.check_run` of a run directory ([] for a TOML)."""
    from ..criticism.guards import check_run

    base = str(path).split("+")[0]
    return check_run(base) if Path(base).is_dir() else []


def run(args) -> int:
    from ..criticism import diagnose
    from ..criticism.guards import map_vs_sampled, sampled_sd
    from ..criticism.point import load_point

    guards = run_guards(args.run)
    refuse = [g for g in guards if g.level == "refuse"]
    if refuse and not args.force:
        for g in refuse:
            print(f"pavement-mcmc diagnose: error: {g.text}; refusing to diagnose it (--force to "
                  "do it anyway)", file=sys.stderr)
        return 2
    problem, values, how, label = load_point(args.run, "median" if args.median else "mean")
    dx = diagnose(problem, values, rank=not args.no_rank, candidates=args.only,
                  forecast=not args.no_forecast)
    if Path(args.run).is_dir() and dx.ranking is not None:
        g = map_vs_sampled(values, sampled_sd(args.run), dx.ranking.base.values())
        guards += [g] if g is not None else []
    figdir = Path(args.figures) if args.figures else (Path(args.run) if Path(args.run).is_dir() else None)
    figs = []
    if figdir is not None:
        from ..plotting.criticism import (
            plot_forecast,
            plot_ranking,
            plot_residual_correlations,
            plot_residual_map,
        )

        figdir.mkdir(parents=True, exist_ok=True)
        out = {
            "residual_map.png": plot_residual_map(dx.residuals),
            "residual_correlations.png": plot_residual_correlations(dx.residuals),
        }
        if dx.ranking is not None:
            out["missing_effects.png"] = plot_ranking(dx.ranking)
        if dx.forecast is not None:
            best = None if dx.ranking is None else _best_forecast(dx.ranking)
            sensors = list(dx.problem.meas.sensor_labels)
            out["forecast.png"] = plot_forecast(
                dx.forecast, None if best is None else best.forecast,
                labels=("base", "" if best is None else best.name),
                sensors=sensors if len(sensors) == dx.forecast.observed.shape[1] else None)
        for name, fig in out.items():
            fig.savefig(figdir / name, dpi=110)
            figs.append(str(figdir / name))
    payload = dx.to_dict()
    payload["figures"] = figs
    payload["guards"] = [g.to_dict() for g in guards]
    text = _text(dx, how, label) + ("\nfigures: " + ", ".join(figs) if figs else "")
    if guards:
        warn = "\n".join(f"WARNING: {g.text}" for g in guards)
        text = f"{warn}\n\n{text}\n\n{warn}"
    emit(args, payload, text)
    return 0
