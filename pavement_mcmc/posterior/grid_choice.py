r"""The solver grid of a case: as ``[grid]`` sets it, or chosen from the case (``kind = "auto"``,
the default).

``"auto"`` is uniform (5 mm, 180 s) when ``dx`` is given or the bottom boundary is no deeper
than :data:`AUTO_UNIFORM_MAX` (the shallow columns of Cases A-C, whose default was validated
on the reference case), and otherwise **stretched, as coarse as the data allow**: of the
:meth:`~pavement_mcmc.solver.Grid.stretched` defaults scaled by the factors of :data:`LADDER`
(``dx_top``, ``dx_max`` and ``dt`` together), the coarsest whose discretisation error at the
sensors is at most :data:`ERROR_FRACTION` of the data's sd ``sigma``. The error of a grid is
the largest difference, over every observed sensor and time, between its predictions and those
of the same grid refined twice in space and time (:meth:`~pavement_mcmc.solver.Grid.refined`),
at the parameters' values of the case (the prior's centre: kappa, C, a constant h, and the
extensions' own values). On the 72-h windows of the Göttingen grass record (30-min data) and
the SoilVUE desert record (hourly) at sigma = 0.1 degC: grass 1.25x the defaults, 40 nodes x 6
steps per interval (0.082 sigma; 1.5x: 0.103), desert 1.5x, 37 nodes x 10 steps (0.100 sigma;
2x: 0.131), against 0.070 / 0.067 sigma for the defaults (44 nodes x 7 / 14 steps): 22 % / 40 %
fewer node-steps per solve. The error falls only about linearly with the grid there, so
little more is to be had (docs/VALIDATION.md). A record with a smaller sigma gets a finer
grid. Setting any of ``kind``, ``dx_top``, ``growth``, ``dx_max``, ``dt`` by hand turns the
choice off.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..solver import STRETCH_DT, STRETCH_DX_MAX, STRETCH_DX_TOP, Grid

#: the deepest bottom boundary that ``[grid] kind = "auto"`` meets with a uniform grid, m
AUTO_UNIFORM_MAX = 0.10
#: the discretisation error a chosen stretched grid may make at the sensors, in units of sigma
ERROR_FRACTION = 0.1
#: factors of the stretched defaults (dx_top, dx_max, dt) tried, coarsest first
LADDER = (3.0, 2.5, 2.0, 1.5, 1.25, 1.0, 0.75, 0.5)
#: [grid] keys that shape a stretched grid: any of them set by hand keeps it as set
_STRETCH_KEYS = ("dx_top", "growth", "dx_max", "dt")


def build_grid(meas, grid_cfg: dict, predict: Callable | None = None) -> tuple[Grid, dict]:
    """The solver grid of a ``[grid]`` section and what was chosen (:func:`describe`; {} when
    the kind was set by hand).

    Parameters
    ----------
    meas : the case's measurements (depths, times, ``sigma``).
    grid_cfg : the ``[grid]`` section: uniform (``dx``, ``dt``; 5 mm, 180 s by default),
        stretched (``dx_top``, ``growth``, ``dx_max``, ``dt``; the defaults of
        :meth:`~pavement_mcmc.solver.Grid.stretched`, nodes at every sensor and plate) or
        ``"auto"`` (see the module docstring).
    predict : ``predict(grid) -> (n_obs, n_sensors)`` sensor temperatures at the case's
        parameter values on ``grid``, degC; without it an ``"auto"`` stretched grid keeps the
        defaults (no error is measured).
    """
    kind, why = grid_kind(meas, grid_cfg)
    if kind == "uniform":
        grid = Grid.build(meas, **{k: grid_cfg[k] for k in ("dx", "dt") if grid_cfg.get(k) is not None})
        return grid, describe(kind, grid, why)
    hand = {k: grid_cfg[k] for k in _STRETCH_KEYS if grid_cfg.get(k) is not None}
    if not why or hand or predict is None:
        grid = Grid.build_stretched(meas, **hand)
    else:
        grid, note = coarsest_stretched(meas, predict)
        why = f"{why}; {note}"
    return grid, describe(kind, grid, why)


def grid_kind(meas, grid_cfg: dict) -> tuple[str, str]:
    """The grid kind ``[grid]`` asks for (``"auto"`` decided from the case) and why: an empty
    reason when the kind was set by hand (``kind = "uniform"``/``"stretched"``)."""
    kind = grid_cfg.get("kind", "auto")
    if kind != "auto":
        return kind, ""
    depth = f"the bottom boundary at {100 * meas.bottom_depth:g} cm"
    if grid_cfg.get("dx") is not None:
        return "uniform", "[grid] dx is given"
    if meas.bottom_depth <= AUTO_UNIFORM_MAX + 1e-12:
        return "uniform", f"{depth} is within {100 * AUTO_UNIFORM_MAX:g} cm"
    return "stretched", f"{depth} is deeper than {100 * AUTO_UNIFORM_MAX:g} cm"


def stretched_at(meas, factor: float) -> Grid:
    """The stretched grid of a case with ``dx_top``, ``dx_max`` and ``dt`` ``factor`` times
    :meth:`~pavement_mcmc.solver.Grid.stretched`'s defaults (the growth unchanged)."""
    return Grid.build_stretched(meas, dx_top=STRETCH_DX_TOP * factor,
                                dx_max=STRETCH_DX_MAX * factor, dt=STRETCH_DT * factor)


def discretisation_error(grid: Grid, predict: Callable) -> float:
    """The largest difference, over sensors and times, between the predictions on ``grid`` and
    on ``grid.refined(2)`` (degC)."""
    return float(np.max(np.abs(np.asarray(predict(grid)) - np.asarray(predict(grid.refined(2))))))


def coarsest_stretched(meas, predict: Callable) -> tuple[Grid, str]:
    """The coarsest grid of :data:`LADDER` whose :func:`discretisation_error` is at most
    :data:`ERROR_FRACTION` ``sigma`` (the finest rung if none is), and a sentence saying so."""
    bound = ERROR_FRACTION * float(meas.sigma)
    tried = []
    for factor in LADDER:
        grid = stretched_at(meas, factor)
        err = discretisation_error(grid, predict)
        tried.append(f"{factor:g}x: {err / meas.sigma:.3f}")
        if err <= bound:
            break
    verdict = "within" if err <= bound else "none within"
    return grid, (f"{factor:g}x the stretched defaults, {verdict} {ERROR_FRACTION:g} sigma of "
                  f"the 2x refined grid at the parameters' values (error/sigma {', '.join(tried)})")


def describe(kind: str, grid: Grid, why: str) -> dict:
    """What ``"auto"`` chose, for ``fit`` to print and ``result.json`` to keep: ``{"kind",
    "nodes", "top_mm", "deep_mm", "steps_per_interval", "why"}``; {} when set by hand
    (``why`` empty)."""
    if not why:
        return {}
    dx = np.diff(grid.x)
    return {"kind": kind, "nodes": int(grid.n_nodes), "top_mm": round(1e3 * float(dx[0]), 1),
            "deep_mm": round(1e3 * float(dx.max()), 1),
            "steps_per_interval": int(np.max(grid.substeps)), "why": why}
