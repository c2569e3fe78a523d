"""The solver's inputs: the per-set :class:`Coefficients` (what depends on the parameters) and
the shared :class:`Forcing` (boundary and initial data) on a :class:`~.grid.Grid`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..data.measurements import Measurements
from .grid import Grid


@dataclass
class Coefficients:
    """Everything the solver consumes that depends on the parameters; one row per set.

    Attributes
    ----------
    kappa : (n_sets, n_nodes-1) conductivity of cell ``[x_i, x_i+1]``, W m-1 K-1.
    C : (n_sets, n_nodes) volumetric heat capacity at the nodes, J m-3 K-1 (the bottom node's
        value is unused: that node is Dirichlet).
    h : (n_sets, n_obs-1) surface transfer coefficient, constant on each observation interval,
        W m-2 K-1.
    q : (n_sets, n_obs) surface source into the ground at the observation times (linear in
        between), W m-2.
    beta : (n_sets,) or None; ``kappa(T) = kappa (1 + beta (T - T_ref))``, 1/K.
    T_ref : reference temperature of ``beta``, degC.
    """

    kappa: np.ndarray
    C: np.ndarray
    h: np.ndarray
    q: np.ndarray
    beta: np.ndarray | None = None
    T_ref: float = 20.0

    @property
    def n_sets(self) -> int:
        return int(np.shape(self.kappa)[0])

    @classmethod
    def uniform(
        cls,
        kappa: np.ndarray | float,
        C: np.ndarray | float,
        h: np.ndarray | float,
        q: np.ndarray | float,
        n_nodes: int,
        beta: np.ndarray | float | None = None,
        T_ref: float = 20.0,
    ) -> Coefficients:
        """Homogeneous ground: broadcast per-set ``kappa``, ``C`` (n_sets,) along depth.

        ``h`` may be (n_obs-1,) or (n_sets, n_obs-1) and ``q`` (n_obs,) or (n_sets, n_obs);
        1D rows are shared by every set. ``n_sets`` is the broadcast of all leading sizes.
        """
        k = np.atleast_1d(np.asarray(kappa, dtype=float))
        c = np.atleast_1d(np.asarray(C, dtype=float))
        hh = np.atleast_2d(np.asarray(h, dtype=float))
        qq = np.atleast_2d(np.asarray(q, dtype=float))
        if k.ndim != 1 or c.ndim != 1:
            raise ValueError("Coefficients.uniform: kappa and C must be scalars or (n_sets,)")
        sizes = [k.size, c.size, hh.shape[0], qq.shape[0]]
        if beta is not None:
            beta = np.atleast_1d(np.asarray(beta, dtype=float))
            sizes.append(beta.size)
        n_sets = max(sizes)
        if any(s not in (1, n_sets) for s in sizes):
            raise ValueError(f"Coefficients.uniform: inconsistent numbers of sets {sizes}")
        return cls(
            kappa=np.broadcast_to(k[:, None], (n_sets, n_nodes - 1)).copy(),
            C=np.broadcast_to(c[:, None], (n_sets, n_nodes)).copy(),
            h=np.broadcast_to(hh, (n_sets, hh.shape[1])).copy(),
            q=np.broadcast_to(qq, (n_sets, qq.shape[1])).copy(),
            beta=None if beta is None else np.broadcast_to(beta, (n_sets,)).copy(),
            T_ref=T_ref,
        )


@dataclass(frozen=True)
class Forcing:
    """Boundary and initial data shared by every parameter set.

    Attributes
    ----------
    T_air : (n_obs,) air temperature at the observation times, degC (linear in between).
    T_bottom : (n_obs,) temperature at ``x = L``, degC (linear in between).
    T0 : (n_nodes,) initial temperature at the nodes, degC.
    T_top : (n_obs,) or None. If given, the top is Dirichlet: ``T(0, t) = T_top(t)`` (degC,
        linear in time between observation times, e.g. the shallowest sensor), the surface
        coefficients ``h`` and ``q`` (and ``T_air``) are ignored and ``T0[0]`` is replaced by
        ``T_top[0]``. If None (default), the top is the Robin surface balance.
    """

    T_air: np.ndarray
    T_bottom: np.ndarray
    T0: np.ndarray
    T_top: np.ndarray | None = None

    @classmethod
    def from_measurements(cls, meas: Measurements, grid: Grid) -> Forcing:
        """Forcing from a case: its air and bottom temperatures, T0 by ``meas.initial_profile``,
        and a Dirichlet top ``T_top`` where the case has a measured top
        (:meth:`~pavement_mcmc.data.Measurements.with_measured_top`: its depths, and so the
        grid's ``x``, start at the top sensor)."""
        if not np.isclose(grid.L - grid.soil_top, meas.bottom_depth, rtol=1e-12, atol=0.0):
            raise ValueError(f"grid.L={grid.L} m (soil top at {grid.soil_top} m) differs from "
                             f"bottom_depth={meas.bottom_depth} m")
        if grid.t_obs.shape != meas.t.shape or not np.allclose(grid.t_obs, meas.t):
            raise ValueError("grid.t_obs differs from the measurement times")
        T_air = np.asarray(meas.T_air, dtype=float)
        if meas.T_top is not None:  # unused under a measured top, where it may have gaps
            T_air = np.nan_to_num(T_air, nan=0.0)
        return cls(
            T_air=T_air,
            T_bottom=np.asarray(meas.T_bottom, dtype=float),
            T0=meas.initial_profile(np.maximum(grid.soil_x, 0.0)),
            T_top=None if meas.T_top is None else np.asarray(meas.T_top, dtype=float),
        )
