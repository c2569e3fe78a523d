"""`make bench`: every benchmark, each printing figures and ratios against a baseline run side by
side in the same process (never timed unit tests)."""

from __future__ import annotations

import importlib
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, os.path.dirname(__file__))

BENCHES = ["bench_solver", "bench_gradient", "bench_samplers", "bench_field", "bench_defaults",
           "bench_batch", "bench_metric_guard"]


def print_table(rows: list[dict]) -> None:
    """Print a list of dicts as an aligned text table."""
    if not rows:
        return
    cols = list(dict.fromkeys(k for r in rows for k in r))
    cell = [[_fmt(r.get(c, "")) for c in cols] for r in rows]
    width = [max(len(c), *(len(row[i]) for row in cell)) for i, c in enumerate(cols)]
    print("  ".join(c.rjust(w) for c, w in zip(cols, width)))
    for row in cell:
        print("  ".join(v.rjust(w) for v, w in zip(row, width)))


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def main() -> int:
    quick = "--quick" in sys.argv
    for name in BENCHES:
        try:
            mod = importlib.import_module(name)
        except ModuleNotFoundError as err:
            print(f"== {name}: not available ({err})")
            continue
        print(f"\n== {name} ==", flush=True)
        t0 = time.perf_counter()
        if hasattr(mod, "main"):
            mod.main(quick=quick)
        else:
            print_table(mod.run(quick=quick))
        print(f"({name} took {time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
