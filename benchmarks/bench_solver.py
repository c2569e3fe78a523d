"""Forward-solver benchmark on the reference case (Case C grid: 28 h of 15-min data) and on a
deep real record (72 h of 30-min data, sensors to 50 cm).

Run ``python benchmarks/bench_solver.py [--quick]``; ``make bench`` calls :func:`main`, which
prints :func:`run` (reference case), :func:`run_sweep` (the serial kernel's cost by batch size)
and :func:`run_deep` (deep record, uniform vs stretched).
For each batch size it reports the time per forward solve of the compiled Crank–Nicolson
kernel, solves per second, the grid's accuracy (max abs difference, over all nodes and
observation times, against a solution refined 4x in both dx and dt) and the speed-up over the
plain batched NumPy implementation (``solve_numpy``) timed in the same process. It also times
Du Fort–Frankel at the largest step that reaches the same accuracy. ``cpu us`` is process CPU
time per solve (all threads): on a machine shared with other busy processes wall time is
inflated, CPU time much less so. Times are medians of several repeats after a warm-up.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # the solver uses no BLAS; keep NumPy's single

import warnings  # noqa: E402

import numpy as np  # noqa: E402

from pavement_mcmc.data import (
    Measurements,  # noqa: E402
    read_csv_case,
)
from pavement_mcmc.solver import (  # noqa: E402
    DEFAULT_DT,
    DEFAULT_DX,
    Coefficients,
    Forcing,
    Grid,
    solve,
    solve_numpy,
)

CASE = Path(__file__).resolve().parents[1] / "data" / "reference_case" / "measurements.csv"
DEEP = Path(__file__).resolve().parents[2] / "shared" / "data" / "goettingen_grass" / "measurements.csv"
DEEP = Path(os.environ.get("PAVEMENT_DEEP_RECORD", DEEP))
DEEP_START_H = 168.0  # the window starts 7 days into the 18-day record
DEEP_KAPPA, DEEP_C, DEEP_H = 1.2, 2.6e6, 10.0
BATCHES = (1, 32, 256)
DEEP_BATCHES = (1, 16, 64)
DFF_DTS = (60.0, 30.0, 20.0, 15.0, 10.0, 6.0, 4.0, 3.0, 2.0, 1.0)


def load_reference(path: Path = CASE) -> Measurements:
    """The shipped reference case as Measurements (0-4 cm observed, 5 cm bottom, sigma 0.25)."""
    return read_csv_case(path, sigma=0.25)


def _coeffs(meas: Measurements, grid: Grid, n_sets: int, seed: int = 0) -> Coefficients:
    """Sets scattered around the paper's Case C estimates, with a rough-ish h(t) per set."""
    rng = np.random.default_rng(seed)
    n_int = grid.n_obs - 1
    kappa = 1.31 * rng.uniform(0.8, 1.2, n_sets)
    C = 0.99e6 * rng.uniform(0.8, 1.2, n_sets)
    h = 10.0 + np.cumsum(rng.normal(0.0, 0.5, (n_sets, n_int)), axis=1)
    return Coefficients.uniform(kappa, C, np.clip(h, 1.0, 40.0), meas.q_net, grid.n_nodes)


def _time(fn, min_time: float, repeats: int) -> tuple[float, float]:
    """Median over ``repeats`` of the mean wall time per call (each repeat lasts >= ``min_time``)
    and the matching median CPU time of the process (all threads; robust to a busy machine)."""
    fn()  # warm-up (compilation, caches)
    n = 1
    while True:
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        dt = time.perf_counter() - t0
        if dt >= min_time:
            break
        n *= 2
    times, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(n):
            fn()
        times.append((time.perf_counter() - t0) / n)
        cpu.append((time.process_time() - c0) / n)
    return float(np.median(times)), float(np.median(cpu))


def _accuracy(meas: Measurements, dx: float, dt: float, scheme: str, ref: np.ndarray) -> float:
    g = Grid.build(meas, dx=dx, dt=dt)
    c = Coefficients.uniform(1.31, 0.99e6, np.full(g.n_obs - 1, 10.0), meas.q_net, g.n_nodes)
    T = solve(g, Forcing.from_measurements(meas, g), c, scheme=scheme)[0]
    return float(np.abs(T - ref).max())


def run(quick: bool = False) -> list[dict]:
    """Benchmark rows: one per (scheme, batch size), as dicts of plain numbers and strings."""
    meas = load_reference()
    min_time, repeats = (0.05, 3) if quick else (0.2, 7)
    dx, dt = DEFAULT_DX, DEFAULT_DT
    fine = Grid.build(meas, dx=dx / 4, dt=dt / 4)
    cf = Coefficients.uniform(1.31, 0.99e6, np.full(fine.n_obs - 1, 10.0), meas.q_net, fine.n_nodes)
    ref = solve(fine, Forcing.from_measurements(meas, fine), cf)[0][:, ::4]
    err_cn = _accuracy(meas, dx, dt, "cn", ref)
    dt_dff, err_dff = DFF_DTS[-1], np.inf
    for cand in DFF_DTS:
        err_dff = _accuracy(meas, dx, cand, "dff", ref)
        if err_dff <= max(err_cn, 0.01):
            dt_dff = cand
            break
    rows = []
    grid = Grid.build(meas, dx=dx, dt=dt)
    forcing = Forcing.from_measurements(meas, grid)
    grid_dff = Grid.build(meas, dx=dx, dt=dt_dff)
    forcing_dff = Forcing.from_measurements(meas, grid_dff)
    for n_sets in BATCHES:
        coeffs = _coeffs(meas, grid, n_sets)
        t_cn, cpu_cn = _time(lambda c=coeffs: solve(grid, forcing, c), min_time, repeats)
        t_np, _ = _time(lambda c=coeffs: solve_numpy(grid, forcing, c), min_time, max(3, repeats // 2))
        rows.append(
            dict(
                scheme="cn",
                n_sets=n_sets,
                dx_mm=dx * 1e3,
                dt_s=dt,
                us_per_solve=1e6 * t_cn / n_sets,
                cpu_us_per_solve=1e6 * cpu_cn / n_sets,
                solves_per_s=n_sets / t_cn,
                max_err_degC=err_cn,
                numpy_us_per_solve=1e6 * t_np / n_sets,
                speedup_vs_numpy=t_np / t_cn,
            )
        )
        if quick and n_sets != BATCHES[-1]:
            continue
        cd = _coeffs(meas, grid_dff, n_sets)
        t_dff, cpu_dff = _time(lambda c=cd: solve(grid_dff, forcing_dff, c, scheme="dff"), min_time, 3)
        rows.append(
            dict(
                scheme="dff",
                n_sets=n_sets,
                dx_mm=dx * 1e3,
                dt_s=dt_dff,
                us_per_solve=1e6 * t_dff / n_sets,
                cpu_us_per_solve=1e6 * cpu_dff / n_sets,
                solves_per_s=n_sets / t_dff,
                max_err_degC=err_dff,
                numpy_us_per_solve=float("nan"),
                speedup_vs_numpy=float("nan"),
            )
        )
    return rows


SWEEP = (8, 16, 32, 64, 128, 256)
SWEEP_ROUNDS = 2  # timings of each kernel pair, the order alternated between rounds


def _sweep_kernels() -> dict:
    """``{name: cn_serial}``: the shipped kernel and the previous one (kept for this bench)."""
    import _previous_cn

    from pavement_mcmc.solver.kernels import cn_simd

    return {"previous": _previous_cn.cn_serial, "new": cn_simd.cn_serial}


def run_sweep(quick: bool = False) -> list[dict]:
    """The serial CN kernel alone (one block, on the calling thread) for growing batches, the
    new kernel beside the previous one (``benchmarks/_previous_cn.py``) in the same process:
    process CPU us per set and per node-step, minima over rounds timed in turn, in
    ``SWEEP_ROUNDS`` rounds of which every other calls the new kernel first; ``ratio`` is
    new / previous per round. The fit ``call = fixed + per_set x sets`` (16-64 sets)
    separates the per-call cost (loop set-up over ~670 steps) from the arithmetic a set costs.
    Both kernels take the package's one ``Problem`` class: a second named-tuple class of the same
    name (an own copy in the previous kernel's module) made numba's dispatch of whichever was
    called second ~130 us a call slower (the order effect noted in VALIDATION section 9)."""
    from pavement_mcmc.solver import forward as fw

    meas = load_reference()
    grid = Grid.build(meas)
    forcing = Forcing.from_measurements(meas, grid)
    kernels = _sweep_kernels()
    fns = {}
    for n in SWEEP:
        c = _coeffs(meas, grid, n)
        P = fw._problem(grid, forcing, *fw._check(grid, forcing, c), c.T_ref, False)
        out = np.empty((grid.n_obs, grid.n_nodes, n))
        for name, kern in kernels.items():
            fns[name, n] = lambda P=P, n=n, out=out, k=kern: k(P, n, out)
    rounds = []
    for k in range(SWEEP_ROUNDS):
        order = sorted(fns, key=lambda key: (key[1], (key[0] == "new") == (k % 2 == 1)))
        rounds.append(_time_interleaved({key: fns[key] for key in order}, 0.02 if quick else 0.05,
                                        3 if quick else 7))
    best = {key: min(r[key][1] for r in rounds) for key in fns}
    node_steps = (int(grid.substeps.sum()) + grid.n_obs - 1) * (grid.n_nodes - 1)  # + damped halves
    fit = [n for n in SWEEP if 16 <= n <= 64]  # (from 128 sets on the working set leaves L1)
    rows = []
    for name in kernels:
        slope, fixed = (float(v) for v in np.polyfit(fit, [best[name, n] for n in fit], 1))
        rows += [dict(kernel=name, n_sets=n, cpu_us_per_solve=1e6 * best[name, n] / n,
                      ns_per_node_step=1e9 * best[name, n] / n / node_steps,
                      fit_fixed_us=1e6 * fixed, fit_us_per_set=1e6 * slope,
                      ratio=[r["new", n][1] / r["previous", n][1] for r in rounds]) for n in SWEEP]
    return rows


def load_deep(days: float = 3.0, path: Path = DEEP) -> Measurements:
    """``days`` of the shared deep real record (2, 5, 10, 20 cm observed, 50 cm bottom)."""
    with warnings.catch_warnings():  # the G_5cm flux-plate column is not in the contract
        warnings.simplefilter("ignore", UserWarning)
        return read_csv_case(path, sigma=0.1, window_hours=[DEEP_START_H, DEEP_START_H + 24.0 * days])


def _deep_coeffs(meas: Measurements, grid: Grid, n_sets: int, seed: int = 0) -> Coefficients:
    rng = np.random.default_rng(seed)
    kappa = DEEP_KAPPA * rng.uniform(0.9, 1.1, n_sets)
    C = DEEP_C * rng.uniform(0.9, 1.1, n_sets)
    h = np.clip(DEEP_H + np.cumsum(rng.normal(0.0, 0.5, (n_sets, grid.n_obs - 1)), axis=1), 1.0, 40.0)
    return Coefficients.uniform(kappa, C, h, meas.q_net, grid.n_nodes)


def deep_grids(meas: Measurements) -> dict[str, Grid]:
    """The uniform default (5 mm, 180 s) and the recommended stretched grid for a deep record."""
    return {"uniform": Grid.build(meas), "stretched": Grid.build_stretched(meas)}


def deep_error(meas: Measurements, grid: Grid) -> float:
    """Max abs difference over all nodes and times against ``grid.refined(4)`` (kappa 1.2,
    C 2.6e6, h 10, the record's T_air and q_net), degC."""
    sols = []
    for g in (grid, grid.refined(4)):
        c = Coefficients.uniform(DEEP_KAPPA, DEEP_C, np.full(g.n_obs - 1, DEEP_H), meas.q_net, g.n_nodes)
        sols.append(solve(g, Forcing.from_measurements(meas, g), c)[0])
    return float(np.abs(sols[0] - sols[1][:, ::4]).max())


def _time_interleaved(fns: dict, min_time: float, repeats: int) -> dict:
    """``{key: (wall, cpu)}`` seconds per call, each the minimum over ``repeats`` rounds in
    which every function is timed once in turn (side by side: a busy machine slows them alike;
    the minimum is the least disturbed run)."""
    loops = {}
    for key, fn in fns.items():  # warm up; calls per round so that one round lasts >= min_time
        fn()
        n = 1
        while True:
            t0 = time.perf_counter()
            for _ in range(n):
                fn()
            if time.perf_counter() - t0 >= min_time:
                break
            n *= 2
        loops[key] = n
    best = {key: (np.inf, np.inf) for key in fns}
    for _ in range(repeats):
        for key, fn in fns.items():
            n = loops[key]
            t0, c0 = time.perf_counter(), time.process_time()
            for _ in range(n):
                fn()
            wall, cpu = (time.perf_counter() - t0) / n, (time.process_time() - c0) / n
            best[key] = (min(best[key][0], wall), min(best[key][1], cpu))
    return best


def run_deep(quick: bool = False) -> list[dict]:
    """Deep real record: us per solve on the uniform 5 mm / 180 s grid vs the recommended
    stretched grid (72 h; 1, 16, 64 sets), and the stretched grid's cost for 1, 3, 7 days.
    Compared solves are timed interleaved (minimum over rounds); the ratios ``vs_uniform`` and
    ``per_day_vs_1day`` are of process CPU times. Empty if the shared record is absent."""
    if not DEEP.exists():
        return []
    min_time, repeats = (0.05, 3) if quick else (0.1, 9)
    rows = []
    meas = load_deep(3.0)
    grids = deep_grids(meas)
    errs = {name: deep_error(meas, g) for name, g in grids.items()}
    forcings = {name: Forcing.from_measurements(meas, g) for name, g in grids.items()}
    for n_sets in DEEP_BATCHES:
        fns = {}
        for name, g in grids.items():
            c = _deep_coeffs(meas, g, n_sets)
            fns[name] = lambda g=g, f=forcings[name], c=c: solve(g, f, c)
        best = _time_interleaved(fns, min_time, repeats)
        for name, g in grids.items():
            wall, cpu = best[name]
            rows.append(dict(grid=name, days=3, n_sets=n_sets, nodes=g.n_nodes, steps=int(g.substeps.sum()),
                             us_per_solve=1e6 * wall / n_sets, cpu_us_per_solve=1e6 * cpu / n_sets,
                             max_err_degC=errs[name], vs_uniform=cpu / best["uniform"][1]))
    for n_sets in (1, 16):
        fns, grid_of = {}, {}
        for days in (1, 3, 7):
            m = load_deep(float(days))
            g = grid_of[days] = Grid.build_stretched(m)
            f, c = Forcing.from_measurements(m, g), _deep_coeffs(m, g, n_sets)
            fns[days] = lambda g=g, f=f, c=c: solve(g, f, c)
        best = _time_interleaved(fns, min_time, repeats)
        for days, g in grid_of.items():
            wall, cpu = best[days]
            rows.append(dict(grid="stretched", days=days, n_sets=n_sets, nodes=g.n_nodes,
                             steps=int(g.substeps.sum()), us_per_solve=1e6 * wall / n_sets,
                             cpu_us_per_solve=1e6 * cpu / n_sets, max_err_degC=float("nan"),
                             vs_uniform=float("nan"), per_day_vs_1day=cpu / days / best[1][1]))
    return rows


def format_sweep_table(rows: list[dict]) -> str:
    """:func:`run_sweep`'s rows, previous and new side by side per batch size."""
    by = {(r["kernel"], r["n_sets"]): r for r in rows}
    lines = [f"{'sets':>5} {'previous us':>11} {'new us':>7} {'new ns/node-step':>16}  new/previous, rounds"]
    for n in SWEEP:
        p, q = by["previous", n], by["new", n]
        cells = f"{n:5d} {p['cpu_us_per_solve']:11.2f} {q['cpu_us_per_solve']:7.2f}"
        cells += f" {q['ns_per_node_step']:16.2f}"
        lines.append(cells + "  " + " ".join(f"{x:.2f}" for x in q["ratio"]))
    for name in ("previous", "new"):
        r = by[name, SWEEP[0]]
        lines.append(f"fit {name}: {r['fit_fixed_us']:.0f} us/call + {r['fit_us_per_set']:.2f} us/set")
    return "\n".join(lines)


def format_deep_table(rows: list[dict]) -> str:
    head = (f"{'grid':9} {'days':>4} {'sets':>5} {'nodes':>5} {'steps':>6} {'us/solve':>9} {'cpu us':>8} "
            f"{'max err C':>9} {'vs unif':>7} {'per day/1d':>10}")
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['grid']:9} {r['days']:4d} {r['n_sets']:5d} {r['nodes']:5d} {r['steps']:6d} "
            f"{r['us_per_solve']:9.1f} {r['cpu_us_per_solve']:8.1f} {r['max_err_degC']:9.4f} "
            f"{r['vs_uniform']:7.2f} {r.get('per_day_vs_1day', float('nan')):10.2f}"
        )
    return "\n".join(lines)


def format_table(rows: list[dict]) -> str:
    head = (
        f"{'scheme':6} {'sets':>5} {'dx mm':>6} {'dt s':>6} {'us/solve':>9} {'cpu us':>7} {'solves/s':>10} "
        f"{'max err C':>10} {'numpy us':>9} {'speedup':>8}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['scheme']:6} {r['n_sets']:5d} {r['dx_mm']:6.2f} {r['dt_s']:6.0f} "
            f"{r['us_per_solve']:9.2f} {r['cpu_us_per_solve']:7.2f} {r['solves_per_s']:10.0f} "
            f"{r['max_err_degC']:10.4f} "
            f"{r['numpy_us_per_solve']:9.1f} {r['speedup_vs_numpy']:8.1f}"
        )
    return "\n".join(lines)


def main(quick: bool = False) -> None:
    """Print both tables (``make bench``)."""
    import numba

    print(
        f"reference case {CASE.name}; numba threads: {numba.get_num_threads()}; "
        f"layer {numba.config.THREADING_LAYER}; load average {os.getloadavg()[0]:.1f}"
    )
    print(format_table(run(quick=quick)))
    print(f"\nserial CN kernel alone, by batch size, new beside previous (process CPU, min of "
          f"{SWEEP_ROUNDS} rounds, the order alternated; ratio new/previous per round; fit over 16-64 sets)")
    print(format_sweep_table(run_sweep(quick=quick)))
    rows = run_deep(quick=quick)
    if not rows:
        print(f"\ndeep real record not found at {DEEP} (set PAVEMENT_DEEP_RECORD): rows skipped")
        return
    print(
        f"\ndeep real record {DEEP.parent.name}, 30-min data, L = 50 cm (kappa {DEEP_KAPPA}, C {DEEP_C:.2g}, "
        f"h {DEEP_H}); max err: against the grid refined 4x in space and time"
    )
    print(format_deep_table(rows))


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats, fewer DFF rows")
    main(quick=ap.parse_args().quick)
