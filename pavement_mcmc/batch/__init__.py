"""Step 10, batch: many fits at once on Dask distributed (windows of a long record, many sites).

- :mod:`.units`: :class:`Unit`, :func:`window_units`, :func:`case_units`, :func:`unit_seed`;
- :mod:`.engine`: :func:`map_units` (the one scheduler of independent fits, for the CLI and the
  validation campaigns), :func:`connect`, :class:`Failure`, :class:`SchedulerLost`;
- :mod:`.unit`: :func:`run_unit` (one ordinary run folder: fit, resume or read back) and its row;
- :mod:`.table`: :func:`run_batch` and the batch table ``batch.csv``;
- :mod:`.drift`: :func:`drift`, an estimate's trend and scatter over the windows;
- :mod:`.season`: :func:`season_rows`, the rows beside the record's measured midday G/Rn.
"""

from .drift import Drift, drift
from .engine import SCHEDULER_ENV, Failure, SchedulerLost, connect, default_workers, map_units
from .season import G_RN, midday_ratio, season_rows
from .table import COSTS, TABLE, read_table, run_batch, write_table
from .unit import COLUMNS, run_unit, unit_row
from .units import Unit, case_units, parse_duration, unit_seed, window_units

__all__ = [
    "COLUMNS",
    "COSTS",
    "Drift",
    "SCHEDULER_ENV",
    "TABLE",
    "G_RN",
    "Failure",
    "SchedulerLost",
    "Unit",
    "case_units",
    "connect",
    "default_workers",
    "drift",
    "map_units",
    "midday_ratio",
    "parse_duration",
    "read_table",
    "run_batch",
    "run_unit",
    "season_rows",
    "unit_row",
    "unit_seed",
    "window_units",
    "write_table",
]
