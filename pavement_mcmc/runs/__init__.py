"""Step 6, runs: a case driven through the sampler into a run folder, and read back.

- :mod:`.fit`: :func:`fit` (config -> problem -> sampler -> store -> tables); :mod:`.resume`:
  :func:`resume` (continue an unfinished run; a finished one only when asked for more);
- :mod:`.loop`: :func:`run_sampler`, the one loop (blocks -> store, stopping rule, progress);
- :mod:`.casefile`: the run folder's ``case.toml`` / ``config.json`` and what a resume must find
  unchanged;
- :mod:`.folder`: :class:`RunFolder`, the run folder's files, state (empty / unfinished /
  failed / finished) and the stopping rule stored with it;
- :mod:`.kept`: :func:`keep`, the one burn-in rule, and :class:`KeptChain`, the one kept-chain
  view (``get_chain(thin=, flat=)``) every reader uses;
- :mod:`.load`: :func:`load_kept`, :func:`load_run` and :func:`point_estimate` (never re-run a
  sampler);
- :mod:`.view`: :func:`load_view`, :class:`RunView` (kept chain, assessment, posterior predictive);
- :mod:`.tables`: the statistics table (``summary.csv`` / ``summary.md``);
- :mod:`.threads`: :func:`single_blas_thread` (the chain must not depend on OMP_NUM_THREADS);
- :mod:`.export`: ArviZ ``InferenceData`` of a run (optional dependency).
"""

from .casefile import to_toml
from .fit import FitOutput, fit
from .folder import RunFolder
from .kept import KeptChain, keep
from .load import load_kept, load_run, point_estimate
from .loop import RunResult, run_sampler
from .resume import resume, stored_result
from .tables import format_table, statistics_table, truth_values, write_table
from .threads import single_blas_thread
from .view import Predictive, RunView, load_view, predictive

__all__ = [
    "FitOutput",
    "KeptChain",
    "Predictive",
    "RunFolder",
    "RunResult",
    "RunView",
    "fit",
    "format_table",
    "keep",
    "load_kept",
    "load_run",
    "load_view",
    "point_estimate",
    "predictive",
    "resume",
    "run_sampler",
    "single_blas_thread",
    "statistics_table",
    "stored_result",
    "to_toml",
    "truth_values",
    "write_table",
]
