"""Field-record benchmark: the real Göttingen grass record (``runs/grass.toml``, read from
``../shared``; skipped with a reason when absent) in the paper's Case C form.

``run(quick=False) -> list[dict]``:

1. Cost of one gradient (a solve and its adjoint sweep, the unit of an ``hmc`` step) and of one
   solve, for 16 parameter sets, on windows of 1, 3 and 7 days (best of 7 repeats), with the
   ratio to the 1-day window: it should grow about linearly with the record. Side by side: the
   gradient on one thread (the serial blocks, the default) against two blocks of 8 sets on
   numba's threads (``solver.forward._PARALLEL_WORK``, off: a busy second core makes them
   several times slower); the two give the same numbers bit for bit (checked here).
   ``kernels_ms``: how much of the gradient is
   spent in the compiled forward and reverse-sweep kernels; ``python_ms``, the rest (the
   coefficients, the observation operators, the likelihood and its cotangent, in NumPy).
2. The 72-h window run to the stopping rule (ESS >= 1000 for every parameter, >= 50 tau,
   split-R-hat < 1.01, no drift) with ``hmc`` and the case file's options (three metric
   windows, log coordinates for the positive parameters away from 0, shifted sqrt ones for
   those piled against 0): the base fit and (at
   most 400 s) the fit with the surface energy balance's best candidate, ``surface_layer``;
   wall time includes the MAP. Side by side (not with ``quick``), the baseline: each fit with
   hmc's defaults (two windows, linear coordinates). Gradient counts do
   not depend on the machine's load; seconds do (the load average is printed). With 16
   chains the split-R-hat < 1.01 bound asks for an ESS of about 1600 (R-hat ~ sqrt(1 + 32 /
   ESS) for 32 half-chains), so the runs stop at a min ESS of 1300-2000, not 1000.

``python benchmarks/bench_field.py [--quick]``.
"""

from __future__ import annotations

import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pavement_mcmc.data import load_case  # noqa: E402
from pavement_mcmc.posterior import build_problem  # noqa: E402
from pavement_mcmc.runs import run_sampler  # noqa: E402
from pavement_mcmc.samplers import get_sampler  # noqa: E402
from pavement_mcmc.solver import forward  # noqa: E402
from pavement_mcmc.solver.kernels import adjoint as _kadj  # noqa: E402
from pavement_mcmc.solver.kernels import adjoint_scalar as _kadj_scalar  # noqa: E402
from pavement_mcmc.solver.kernels import cn_simd as _kcn  # noqa: E402
from pavement_mcmc.storage import MemoryStore  # noqa: E402

CASE = ROOT / "runs" / "grass.toml"
START = 168  # h: the window of runs/grass.toml starts here
#: the baseline: hmc's defaults before "auto" (two metric windows, every parameter in linear
#: coordinates; ``{}`` is "auto" now, which on this window chooses the case file's options)
BASELINE: dict = {"metric_windows": 2, "log_positive": False, "sqrt_at_zero": False}


def _problem(hours: float = 72, extensions: tuple = ()):
    over = {"data": {"window_hours": [START, START + hours]},
            "model": {"extensions": list(extensions)}}
    return build_problem(load_case(CASE, over))


def _best(fn, repeats: int = 7) -> float:
    fn()
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def _kernel_time(fn, repeats: int = 7) -> float:
    """The least time, over ``repeats`` calls of ``fn``, spent inside the compiled forward and
    reverse-sweep kernels (the rest of a gradient is Python): the kernels are wrapped with a
    timer for the duration. The plain solves count too (a gradient whose states exceed
    ``solver.adjoint._STORE_MAX`` takes its forward from ``solve``)."""
    mods = {_kadj: ("fwd_serial", "fwd_parallel", "vjp_serial", "vjp_parallel"),
            _kadj_scalar: ("fwd_scalar", "vjp_scalar"), _kcn: ("cn_serial", "cn_parallel"),
            forward: ("cn_scalar",)}
    spent = [0.0]
    saved = {(m, n): getattr(m, n) for m, names in mods.items() for n in names}

    def timed(kernel):
        def call(*args):
            t = time.perf_counter()
            kernel(*args)
            spent[0] += time.perf_counter() - t
        return call

    try:
        for (m, n), kernel in saved.items():
            setattr(m, n, timed(kernel))
        fn()
        best = np.inf
        for _ in range(repeats):
            spent[0] = 0.0
            fn()
            best = min(best, spent[0])
    finally:
        for (m, n), kernel in saved.items():
            setattr(m, n, kernel)
    return best


def cost_by_length(sets: int = 16) -> list[dict]:
    """Gradient and solve time for 1, 3 and 7 days (see the module docstring)."""
    rows = []
    default = forward._PARALLEL_WORK
    for days in (1, 3, 7):
        pb = _problem(24 * days)
        theta = np.tile(pb.space.initial(), (sets, 1)) * np.linspace(0.9, 1.1, sets)[:, None]

        def grad(pb=pb, th=theta):
            return pb.posterior.loglik_and_grad(th)

        try:
            forward._PARALLEL_WORK = np.inf
            serial, g1 = _best(grad), grad()
            forward._PARALLEL_WORK = 0.0  # two blocks of 8 on numba's threads
            threads, g2 = _best(grad), grad()
            kernels = _kernel_time(grad)
        finally:
            forward._PARALLEL_WORK = default
        assert all(np.array_equal(a, b) for a, b in zip(g1, g2, strict=True))
        s = _best(lambda pb=pb, th=theta: pb.posterior(th))
        rows.append({"days": days, "intervals": pb.model.grid.n_obs - 1,
                     "nodes": pb.model.grid.n_nodes, "params": len(pb.space.free),
                     "threads_by_default": forward._parallel(sets, pb.model.grid),
                     "grad_ms": 1e3 * serial, "grad_ms_2threads": 1e3 * threads,
                     "thread_speedup": serial / threads, "kernels_ms": 1e3 * kernels,
                     "python_ms": 1e3 * (serial - kernels), "solve_ms": 1e3 * s})
    for r in rows:
        r["grad_vs_1day"] = r["grad_ms"] / rows[0]["grad_ms"]
        r["length_vs_1day"] = r["intervals"] / rows[0]["intervals"]
    return rows


def to_target(extensions: tuple = (), options: dict | None = None, label: str = "",
              max_seconds: float = 900) -> dict:
    """``hmc`` on the 72-h window to the stopping rule; wall time includes the MAP."""
    pb = _problem(72, extensions)
    if options is None:  # the case file's [sampler.options], as `fit` uses them
        options = pb.cfg.sampler.get("options") or None
    pb.posterior.loglik_and_grad(pb.space.initial()[None])  # compile outside the timing
    t0 = time.perf_counter()
    s = get_sampler("hmc", pb.posterior, seed=1, options=options)
    s.prepare()
    store = MemoryStore.create(pb.space.free, pb.posterior.blob_names, s.n_chains,
                               {"sampler": s.name})
    res = run_sampler(s, store, ess_target=1000, max_steps=10**7, max_seconds=max_seconds)
    wall = time.perf_counter() - t0
    d = store.read()
    means = {k: float(d.chain[res.burn_in:, :, pb.space.free.index(k)].mean())
             for k in ("kappa", "C")}
    return {"fit": "+".join(("base",) + tuple(extensions)), "metric": label,
            "converged": res.converged, "wall_s": wall, "steps": res.n_steps,
            "gradients": res.n_evals, "min_ess": float(res.ess.min()),
            "max_rhat": float(res.rhat.max()), "kappa": means["kappa"],
            "C_MJ": means["C"] / 1e6}


def run(quick: bool = False) -> list[dict]:
    if not CASE.is_file() or not (ROOT.parent / "shared" / "data" / "goettingen_grass").is_dir():
        print("skipped: the shared Göttingen record is not at ../shared/data/goettingen_grass")
        return []
    warnings.simplefilter("ignore")
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at start")
    from run_all import print_table

    print("cost of a gradient / a solve (16 parameter sets) against the record's length")
    print_table(cost_by_length())
    case, base = "grass.toml: 3 windows, log/sqrt coordinates", "2 windows, linear (pre-auto)"
    rows = [to_target(label=case)]
    if not quick:
        rows.append(to_target(options=BASELINE, label=base))
    rows.append(to_target(("surface_layer",), label=case, max_seconds=400))
    if not quick:
        rows.append(to_target(("surface_layer",), options=BASELINE, label=base, max_seconds=400))
    print(f"\n72-h window to the stopping rule (load average {os.getloadavg()[0]:.1f} at end)")
    print_table(rows)
    return []


def main(quick: bool = False) -> None:
    run(quick)


if __name__ == "__main__":
    main("--quick" in sys.argv)
