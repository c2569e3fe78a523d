"""The batch: units through :func:`~.engine.map_units` into run folders, and its one table."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable
from pathlib import Path

from ..storage import write_atomic
from .engine import Failure, map_units
from .unit import COLUMNS, run_unit
from .units import Unit, check_unique

#: the batch table in the output folder (reproducible: the same bytes for the same batch)
TABLE = "batch.csv"
#: what each unit cost (wall time s, the worker's CPU time s, its peak resident memory MB while
#: the unit ran)
COSTS = "batch_costs.csv"
COST_COLUMNS = ("key", "elapsed_s", "cpu_s", "peak_rss_mb")


def run_batch(units: list[Unit], out: str | Path, *, seed: int = 0, scheduler: str | None = None,
              n_workers: int | None = None, client=None, retries: int = 1,
              max_seconds: float | None = None, on_done: Callable | None = None,
              counter: str | Path | None = None) -> list[dict]:
    """Fit every unit into ``out/<key>/`` on a Dask cluster and write ``out/batch.csv``.

    Units already finished in ``out`` are read back, not recomputed; interrupted ones are
    resumed. Returns the rows in the units' order; a unit whose task failed even after Dask's
    retries gets a row with ``status = "failed"`` and the reason.
    """
    units = check_unique(list(units))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / TABLE).unlink(missing_ok=True)  # a table is there only when its batch ended
    results = map_units(run_unit, units, key=lambda u: u.key, client=client, scheduler=scheduler,
                        n_workers=n_workers, retries=retries, on_done=on_done, out=str(out),
                        batch_seed=int(seed), max_seconds=max_seconds,
                        counter=str(counter) if counter else None)
    rows = [_failed_row(u, r) if isinstance(r, Failure) else {c: r[c] for c in COLUMNS}
            for u, r in zip(units, results)]
    write_table(rows, out / TABLE)
    _write_costs(units, results, out / COSTS)
    return rows


def _write_costs(units: list[Unit], results: list, path: Path) -> None:
    """What each unit cost where it ran: wall and CPU time and the worker's peak memory (measured,
    so it differs from run to run: kept out of the reproducible ``batch.csv``)."""
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(COST_COLUMNS)
    for u, r in zip(units, results):
        rec = {} if isinstance(r, Failure) else r
        w.writerow([u.key, *(_cell(rec.get(c, float("nan"))) for c in COST_COLUMNS[1:])])
    write_atomic(path, buf.getvalue())


def _failed_row(unit: Unit, f: Failure) -> dict:
    row = {c: float("nan") for c in COLUMNS}
    row.update(key=unit.key, site=unit.site, start_time=unit.start_time, status="failed",
               converged=False, verdict="", reason=f.reason, run_dir="")
    if unit.window_hours:
        row["start_h"], row["end_h"] = unit.window_hours
    return row


def write_table(rows: list[dict], path: str | Path) -> Path:
    """The batch table as CSV (floats written with ``repr``: the exact values, so two tables
    are equal as files exactly when their numbers are equal)."""
    path = Path(path)
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(COLUMNS)
    for r in rows:
        w.writerow([_cell(r.get(c)) for c in COLUMNS])
    write_atomic(path, buf.getvalue())
    return path


def _cell(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "" if math.isnan(v) else repr(v)
    return "" if v is None else str(v)


def read_table(path: str | Path) -> list[dict]:
    """Read a batch table back (numbers as floats, empty cells as nan)."""
    text_cols = {"key", "site", "start_time", "status", "verdict", "reason", "run_dir"}
    rows = []
    with open(path, newline="", encoding="utf-8") as fh:
        for r in csv.DictReader(fh):
            row = {}
            for k, v in r.items():
                if k in text_cols:
                    row[k] = v
                elif k == "converged":
                    row[k] = v == "true"
                else:
                    row[k] = float(v) if v else float("nan")
            rows.append(row)
    return rows
