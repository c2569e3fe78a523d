"""What a user gets with the defaults (issue 25): cases with no ``[grid]`` and no
``[sampler.options]`` run to the stopping rule beside the hand-tuned case files, in the same
process, as ratios.

1. The 72-h field windows written in the plain Case C form, ``runs/grass_plain.toml`` and
   ``runs/desert_plain.toml`` (the grid and hmc's coordinates and metric windows chosen from the
   case), against ``runs/grass.toml`` / ``runs/desert.toml`` (the same windows with the hand
   options): the base fit (target 20 s) and with the added surface physics (``surface_layer``
   on grass, ``two_layer`` on desert; target 40 s). Skipped, saying why, without ``../shared``.
2. The README tutorial's fits, ``runs/hidden.toml`` base and ``--add two_layer`` (target 60 s
   each).

``prep_s`` is the MAP and the sampler's preparation; ``ms_per_gradient`` the sampling's wall
time per gradient after it (one chain's solve and adjoint sweep, in batches of 16). Wall time
is the fit's as ``pavement-mcmc fit`` spends it (the MAP, the sampler's preparation
and the sampling; not the build of the problem and the kernels' compilation), beside the
process's CPU time over the same span (the fits' solves run on one thread, or on two for long
windows, so on a quiet machine the wall time is at most the CPU time; on a busy one the CPU
time is the better guess of it); gradient counts
(solves for the MAP) do not depend on the machine's load, seconds do (the load average is
printed). ``python benchmarks/bench_defaults.py [--quick] [grass desert hidden]`` (quick: the
base fits only; names: only those records).
"""

from __future__ import annotations

import os
import sys
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pavement_mcmc.data import load_case  # noqa: E402
from pavement_mcmc.posterior import build_problem, find_map  # noqa: E402
from pavement_mcmc.runs import run_sampler  # noqa: E402
from pavement_mcmc.samplers import get_sampler  # noqa: E402
from pavement_mcmc.storage import MemoryStore  # noqa: E402

RUNS = ROOT / "runs"
SHARED = ROOT.parent / "shared" / "data"
#: (plain case, hand-tuned case, the added physics, record folder, target s base / added)
FIELD = [("grass_plain", "grass", "surface_layer", "goettingen_grass", 20.0, 40.0),
         ("desert_plain", "desert", "two_layer", "soilvue_utah", 20.0, 40.0)]
TUTORIAL = ("hidden", "two_layer", 60.0)


def to_target(case: str, extensions: tuple = (), max_seconds: float = 900.0) -> dict:
    """``case`` (a name in ``runs/``) with ``extensions`` to the stopping rule, as ``fit`` runs it."""
    cfg = load_case(RUNS / f"{case}.toml", {"model": {"extensions": list(extensions)}})
    pb = build_problem(cfg)
    scfg = cfg.sampler
    pb.posterior.loglik_and_grad(pb.space.initial()[None])  # compile outside the timing
    t0, c0 = time.perf_counter(), time.process_time()
    s = get_sampler(scfg["kind"], pb.posterior, n_chains=scfg.get("n_walkers"), seed=scfg.get("seed"),
                    options=scfg.get("options") or None)
    lap = find_map(pb.posterior) if s.needs_laplace() else None
    s.n_prep_evals += 0 if lap is None else lap.n_evals
    s.prepare(laplace=lap)
    t_prep = time.perf_counter() - t0
    store = MemoryStore.create(pb.space.free, pb.posterior.blob_names, s.n_chains, {"sampler": s.name})
    res = run_sampler(s, store, ess_target=scfg.get("ess_target", 1000), max_steps=10**7,
                      max_seconds=max_seconds)
    chosen = {k: v for k, v in getattr(s, "chosen", {}).items() if k != "why"}
    wall = time.perf_counter() - t0
    return {"case": case, "fit": "+".join(("base",) + tuple(extensions)),
            "converged": res.converged, "wall_s": wall,
            "cpu_s": time.process_time() - c0, "prep_s": t_prep,
            "ms_per_gradient": 1e3 * (wall - t_prep) / max(res.n_evals - s.n_prep_evals, 1),
            "steps": res.n_steps, "gradients": res.n_evals, "prep_evals": s.n_prep_evals,
            # no check yet (a budget ran out first): no ESS, no R-hat
            "min_ess": float(res.ess.min()) if res.ess.size else float("nan"),
            "max_rhat": float(res.rhat.max()) if res.rhat.size else float("nan"),
            "grid": _grid(pb),
            "chosen": ", ".join(f"{k}={v}" for k, v in chosen.items()) or "by hand"}


def _shown(case: str, extensions: tuple) -> dict:
    """:func:`to_target`, its row printed as soon as it is measured (a long run that is cut
    short keeps what it measured)."""
    r = to_target(case, extensions)
    print(f"{r['case']} {r['fit']}: converged={r['converged']} wall {r['wall_s']:.1f} s, cpu "
          f"{r['cpu_s']:.1f} s, prep {r['prep_s']:.1f} s, {r['steps']} steps, {r['gradients']} "
          f"gradients, {r['ms_per_gradient']:.2f} ms/gradient, load {os.getloadavg()[0]:.1f}",
          flush=True)
    return r


def _grid(pb) -> str:
    """The grid chosen from the case as ``kind nodes x steps per interval``, or "by hand"."""
    g = pb.grid_chosen
    return f"{g['kind']} {g['nodes']}x{g['steps_per_interval']}" if g else "by hand"


def _met(r: dict, target: float) -> dict:
    """Whether the fit converged within ``target`` seconds of wall time, and of CPU time (at
    least the wall time a quiet machine would take)."""
    return {"case": r["case"], "fit": r["fit"], "target_s": target,
            "met_wall": r["converged"] and r["wall_s"] <= target,
            "met_cpu": r["converged"] and r["cpu_s"] <= target}


def _vs(plain: dict, hand: dict, target: float) -> dict:
    return {**_met(plain, target), "wall_vs_hand": plain["wall_s"] / hand["wall_s"],
            "gradients_vs_hand": plain["gradients"] / hand["gradients"]}


def run(quick: bool = False, only: tuple = ()) -> list[dict]:
    warnings.simplefilter("ignore")
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at start")
    from run_all import print_table

    rows, ratios = [], []
    for plain, hand, ext, folder, base_s, added_s in FIELD:
        if only and hand not in only:
            continue
        if not (SHARED / folder).is_dir():
            print(f"skipped {plain}: the shared record is not at ../shared/data/{folder}")
            continue
        for exts, target in [((), base_s)] + ([] if quick else [((ext,), added_s)]):
            pair = [_shown(plain, exts), _shown(hand, exts)]
            rows += pair
            ratios.append(_vs(*pair, target))
    name, ext, target = TUTORIAL
    for exts in ([()] + ([] if quick else [(ext,)])) * (not only or name in only):
        r = _shown(name, exts)
        rows.append(r)
        ratios.append(_met(r, target))
    print(f"\nto the stopping rule (load average {os.getloadavg()[0]:.1f} at end)")
    print_table(rows)
    print("\nthe plain cases against the hand-tuned ones (same process)")
    print_table(ratios)
    return []


def main(quick: bool = False, only: tuple = ()) -> None:
    run(quick, only)


if __name__ == "__main__":
    main("--quick" in sys.argv, tuple(a for a in sys.argv[1:] if not a.startswith("-")))
