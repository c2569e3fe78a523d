"""A case at given parameter values, before any sampling (``simulate``, ``sensitivity``)."""

from __future__ import annotations

from pathlib import Path

from ..data import ConfigError, load_case
from ..parameters import parameter_values
from ..posterior import build_problem


def problem_at(case: str | Path, overrides: dict | None = None,
               values: dict[str, float] | None = None):
    """``(problem, values)``: the :class:`~pavement_mcmc.posterior.Problem` of ``case`` with
    config ``overrides`` (``--set grid.dx=...``) and every parameter's value, ``values`` applied
    (a group name such as ``h`` sets every member, see
    :func:`~pavement_mcmc.parameters.parameter_values`).

    Raises :class:`~pavement_mcmc.data.ConfigError` for an unknown parameter name or a bad
    value, naming the valid ones.
    """
    problem = build_problem(load_case(case, overrides or None))
    try:
        return problem, parameter_values(problem.space, values)
    except ValueError as err:  # an unknown name or a bad value given with --set
        raise ConfigError(f"--set: {err}") from None
