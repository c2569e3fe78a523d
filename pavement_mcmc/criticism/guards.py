"""Guards before judging a stored run: is it finished, converged, away from its bounds, and does
its posterior agree with the MAP route the criticism refits from?

A diagnosis of a run that did not converge, sits at a bound or stopped half-way judges the
sampler, not the model (a base fit stuck at C = 1e4 J m-3 K-1 with R-hat 14.7 was diagnosed
without a word). :func:`check_run` returns the findings; the command line refuses an unfinished
run (unless forced) and prints the others loudly. Numbers and words only; nothing prints.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: a parameter is "at a bound" when this share of its kept draws lies within BOUND_REL of it
BOUND_SHARE = 0.5
BOUND_REL = 1e-3
#: MAP and posterior mean disagree when they differ by more than this many posterior sd
MAP_SD = 3.0


@dataclass(frozen=True)
class Guard:
    """One finding: ``level`` ``"refuse"`` (unfinished or failed) or ``"warn"``."""

    level: str
    kind: str
    text: str

    def to_dict(self) -> dict:
        return dict(self.__dict__)


def check_run(run_dir: str | Path) -> list[Guard]:
    """Findings on the stored run ``run_dir`` (empty when it is fit to judge)."""
    from ..runs.folder import RunFolder

    folder = RunFolder(run_dir)
    run_dir = folder.path
    if not folder.contents():
        from ..data import RunNotFound

        raise RunNotFound(f"{run_dir}: not a run directory (no case.toml, no chain.h5); give the "
                          "--out folder of 'pavement-mcmc fit'")
    out: list[Guard] = []
    res = folder.read_result()
    if res is None:
        what = (f"{folder.chain.name} without {folder.result.name}" if folder.chain.exists()
                else f"no {folder.result.name}")
        return [Guard("refuse", "unfinished", f"{run_dir}: the run is unfinished ({what}: the fit "
                      "failed, was killed or is still running); its chain is not a posterior to judge")]
    if res.get("failed"):
        return [Guard("refuse", "failed", f"{run_dir}: the fit failed ({res.get('reason', '?')})")]
    if not folder.summary_csv.exists():
        out.append(Guard("warn", "unfinished", f"{run_dir}: no {folder.summary_csv.name} (the run "
                         "did not finish writing)"))
    if not res.get("converged", False):
        rhat = res.get("rhat") or []
        mr = f"; max R-hat {max(rhat):.3g}" if rhat else ""
        out.append(Guard("warn", "not_converged", f"{run_dir}: NOT converged ({res.get('reason', '?')}"
                         f"{mr}): the posterior mean may be far from the posterior"))
    out += _bounds(run_dir)
    return out


def _bounds(run_dir: Path) -> list[Guard]:
    from ..runs import load_kept

    try:
        problem, kept = load_kept(run_dir)
    except (OSError, ValueError, KeyError):
        return []
    flat = kept.get_chain(flat=True)
    names = kept.param_names
    lo, hi = problem.space.bounds()
    free = problem.space.free
    cols = [j for j, n in enumerate(names) if n in free]
    idx = [free.index(names[j]) for j in cols]
    return bound_findings([names[j] for j in cols], flat[:, cols], lo[idx], hi[idx])


def bound_findings(names: list[str], draws: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list[Guard]:
    """Parameters (columns of ``draws``) with :data:`BOUND_SHARE` of their draws within
    :data:`BOUND_REL` of the span at a finite bound. A lower bound at zero is the quantity's own
    limit (h >= 0 at a calm night, the smoothness precision, a resistance): a posterior may
    legitimately pile up there, so only the other bounds (C >= 1e4, an offset's 1 cm) count."""
    out = []
    for j, name in enumerate(names):
        a, b = lo[j], hi[j]
        span = b - a if np.isfinite(b - a) else max(float(np.abs(draws[:, j]).max()), 1.0)
        near = np.zeros(draws.shape[0], bool)
        if np.isfinite(a) and a != 0.0:
            near |= draws[:, j] - a <= BOUND_REL * span
        if np.isfinite(b):
            near |= b - draws[:, j] <= BOUND_REL * span
        if near.mean() >= BOUND_SHARE:
            out.append(Guard("warn", "at_bound", f"{name} sits at a bound ({100 * near.mean():.0f} % "
                             f"of the kept draws within {BOUND_REL:g} of the range [{a:g}, {b:g}]): "
                             "the chain is stuck or the model needs the parameter beyond its range"))
    return out


def map_vs_sampled(values: dict[str, float], sd: dict[str, float], map_values: dict[str, float],
                   names: list[str] | None = None) -> Guard | None:
    """A warning if the MAP route and the sampled posterior mean disagree by more than
    :data:`MAP_SD` posterior sd on any of ``names`` (default every name in ``sd``)."""
    bad = []
    for n in names or list(sd):
        if n in values and n in map_values and sd.get(n, 0) > 0:
            z = (map_values[n] - values[n]) / sd[n]
            if abs(z) > MAP_SD:
                bad.append(f"{n}: MAP {map_values[n]:.4g}, posterior mean {values[n]:.4g} "
                           f"± {sd[n]:.2g} ({z:+.0f} sd)")
    if not bad:
        return None
    return Guard("warn", "map_vs_sampled", "the MAP route (the criticism's refits start from it) and "
                 "the sampled run disagree: " + "; ".join(bad[:6])
                 + (f" (and {len(bad) - 6} more)" if len(bad) > 6 else ""))


def sampled_sd(run_dir: str | Path) -> dict[str, float]:
    """Posterior sd of every sampled parameter but the h pieces, over the kept chain."""
    from ..runs import load_kept

    problem, kept = load_kept(run_dir)
    flat = kept.get_chain(flat=True)
    return {n: float(flat[:, j].std()) for j, n in enumerate(kept.param_names)
            if n in problem.space and problem.space[n].group != "h"}


def rmse_vs_map(label: str, rmse_sampled: float, rmse_map: float, rel: float = 1.2) -> Guard | None:
    """A warning if a run's RMSE at its posterior mean is more than ``rel`` times that of a MAP
    refit of the same model from there (a chain stuck away from the mode: ``fit --add
    evaporation`` gave 0.865 where the MAP route gave 0.302)."""
    if rmse_sampled <= rel * rmse_map + 1e-3:
        return None
    return Guard("warn", "map_vs_sampled", f"{label}: RMSE {rmse_sampled:.3f} °C at the posterior mean "
                 f"against {rmse_map:.3f} °C at the MAP of the same model: the chain is not at the "
                 "mode (stuck at a bound or unconverged); resume or refit before comparing")


def same_data(runs: list[tuple[str, object]]) -> Guard | None:
    """``(label, problem)`` of the runs a comparison ranks: a warning when they were not fitted
    to the same sensor data (another window, file, sensor set or sigma), whose errors do not
    compare. Other streams (a plate, the infrared temperature) may differ: they are not scored."""
    hashes = [pb.meas.sensors_hash() for _, pb in runs]
    if len(set(hashes)) <= 1:
        return None
    first = runs[0][0]
    other = [f"{lab} (#{i + 1})" for i, ((lab, _), h) in enumerate(zip(runs, hashes, strict=True))
             if h != hashes[0]]
    return Guard("warn", "data", f"{', '.join(other)} {'was' if len(other) == 1 else 'were'} "
                 f"fitted to other data than {first} (#1; another window, file, sensors or sigma): "
                 "their errors and scores do not compare")
