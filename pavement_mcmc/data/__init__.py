"""Step 1, the data: a case's CSV and TOML, checked, as :class:`Measurements` and a :class:`CaseConfig`.

- :mod:`.measurements`: :class:`Measurements`, the in-memory form every later step consumes;
- :mod:`.reader`: :func:`read_csv_case`, the CSV column contract and its checks of columns and
  sensors; :mod:`.checks`: :class:`DataError` and the row-level checks (times, window, cells,
  ranges); :mod:`.table`: a CSV file read into a table, other dialects refused;
- :mod:`.extras`: the optional named series (``T_surf_IR``, ``RH``, radiation components, LE,
  H) and the merge of a second CSV on time (heat-flux plates ``G_<d>cm`` too);
  :mod:`.fluxsite`: AmeriFlux / FLUXNET presets;
- :mod:`.case`: :func:`load_case` (TOML -> :class:`CaseConfig`), overrides and the run record;
  :mod:`.schema`: the TOML's keys, :class:`ConfigError` and their validation;
- :mod:`.toml_writer`: the one TOML writer; :mod:`.plugins`: the one plugin loader
  (:class:`~.plugins.Registry`) of extensions, samplers and twin effects.
"""

from .case import CaseConfig, dump_config, load_case, merge_overrides, parse_set, record_times
from .checks import DataError
from .errors import RunError, RunExists, RunNotFound, UserError
from .measurements import Measurements
from .reader import read_csv_case
from .schema import (
    DATA_KEYS,
    GRID_DEFAULTS,
    PARAMETER_KEYS,
    SAMPLER_DEFAULTS,
    SECTIONS,
    ConfigError,
)

__all__ = [
    "DATA_KEYS",
    "GRID_DEFAULTS",
    "PARAMETER_KEYS",
    "SAMPLER_DEFAULTS",
    "SECTIONS",
    "CaseConfig",
    "ConfigError",
    "DataError",
    "Measurements",
    "RunError",
    "RunExists",
    "RunNotFound",
    "UserError",
    "dump_config",
    "load_case",
    "merge_overrides",
    "parse_set",
    "read_csv_case",
    "record_times",
]
