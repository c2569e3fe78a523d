"""The point estimate a criticism judges: a stored run's posterior mean (or median), or the MAP
of a case TOML, optionally with extensions (or ``finer_h``) added."""

from __future__ import annotations

from pathlib import Path

from ..data import load_case
from ..posterior import build_problem
from .fitting import refit


def load_point(path: str | Path, statistic: str = "mean"):
    """``(problem, values, how, label)`` from a run directory or a case TOML.

    ``CASE.toml+ext1+ext2`` adds extensions to the case (MAP fit only; for a sampled run use
    ``pavement-mcmc fit CASE.toml --add ext1 --out DIR``); ``+finer_h`` is a finer ``[model] h``,
    resolved as ``fit --add finer_h`` does (:func:`~pavement_mcmc.runs.start.resolve_finer_h`:
    a :class:`~pavement_mcmc.data.ConfigError` if h is already one value per interval).
    """
    from ..runs import point_estimate  # runs (h5py, the samplers) only when a point is loaded

    pth = Path(str(path).split("+")[0])
    if pth.suffix == ".toml":
        problem, label = case_problem(path)
        return problem, refit(problem).values(), "MAP fit", label
    problem, values = point_estimate(pth, statistic)
    return problem, values, f"posterior {statistic}", pth.name


def case_config(path: str | Path, overrides: dict | None = None):
    """``(config, label)`` of ``CASE.toml+ext1+ext2`` (see :func:`load_point`), with
    ``overrides`` (e.g. another ``data.window_hours``) applied to the case: its data read, no
    model built (cheap)."""
    from ..runs.start import resolve_finer_h

    base, *added = str(path).split("+")
    pth = Path(base)
    ov, rest = resolve_finer_h(pth, dict(overrides or {}), added)
    cfg = load_case(pth, ov or None, additions={"model": {"extensions": rest}} if rest else None)
    return cfg, cfg.name + "".join(f"+{a}" for a in added)


def case_problem(path: str | Path, overrides: dict | None = None):
    """``(problem, label)`` of :func:`case_config`'s case (building it may fit a MAP: a case
    that integrates its inputs' noise out linearises there)."""
    cfg, label = case_config(path, overrides)
    return build_problem(cfg), label
