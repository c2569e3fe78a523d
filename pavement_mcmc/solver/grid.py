"""The solver's data: the space-time :class:`Grid`, the per-set :class:`Coefficients` and the
shared :class:`Forcing` (see :mod:`pavement_mcmc.solver` for the discretisation)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..data.measurements import Measurements

DEFAULT_DX = 0.005  # m
DEFAULT_DT = 180.0  # s


@dataclass(frozen=True)
class Grid:
    """Space-time grid of one case.

    Attributes
    ----------
    L : depth of the Dirichlet bottom boundary, m.
    x : (n_nodes,) node depths, m; uniform spacing, ``x[0] = 0``, ``x[-1] = L``.
    t_obs : (n_obs,) observation times, s, strictly increasing (irregular spacing allowed).
    substeps : (n_obs-1,) int, solver steps in each observation interval; the step in interval
        ``j`` is ``(t_obs[j+1] - t_obs[j]) / substeps[j]``.
    """

    L: float
    x: np.ndarray
    t_obs: np.ndarray
    substeps: np.ndarray

    def __post_init__(self) -> None:
        x = np.asarray(self.x, dtype=float)
        t = np.asarray(self.t_obs, dtype=float)
        n = np.asarray(self.substeps)
        if x.ndim != 1 or x.size < 2:
            raise ValueError(f"Grid.x must be 1D with >= 2 nodes, got shape {x.shape}")
        dx = (x[-1] - x[0]) / (x.size - 1)
        if x[0] != 0.0 or not np.isclose(x[-1], self.L, rtol=1e-12, atol=0.0) or dx <= 0:
            raise ValueError(f"Grid.x must run from 0 to L={self.L} m, got [{x[0]}, {x[-1]}]")
        if not np.allclose(np.diff(x), dx, rtol=1e-9, atol=0.0):
            raise ValueError("Grid.x must be uniformly spaced")
        if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
            raise ValueError("Grid.t_obs must be 1D, >= 2 times, strictly increasing (s)")
        if n.shape != (t.size - 1,) or not np.issubdtype(n.dtype, np.integer) or np.any(n < 1):
            raise ValueError(f"Grid.substeps must be (n_obs-1,)=({t.size - 1},) positive ints, got {n.shape}")
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "t_obs", t)
        object.__setattr__(self, "substeps", n.astype(np.int64))
        object.__setattr__(self, "L", float(self.L))

    @classmethod
    def from_times(cls, L: float, t_obs: np.ndarray, dx: float = DEFAULT_DX, dt: float = DEFAULT_DT) -> Grid:
        """Grid with ``ceil(L/dx)`` cells and ``ceil(interval/dt)`` steps per interval.

        The actual spacing and steps are the largest uniform values not exceeding ``dx`` (m)
        and ``dt`` (s).
        """
        if not (dx > 0 and dt > 0 and L > 0):
            raise ValueError(f"need L, dx, dt > 0, got L={L}, dx={dx}, dt={dt}")
        n_cells = max(1, math.ceil(L / dx * (1.0 - 1e-12)))
        t = np.asarray(t_obs, dtype=float)
        if t.ndim != 1 or t.size < 2:
            raise ValueError("t_obs must be 1D with at least 2 times (s)")
        sub = np.maximum(1, np.ceil(np.diff(t) / dt * (1.0 - 1e-12))).astype(np.int64)
        return cls(L=L, x=np.linspace(0.0, L, n_cells + 1), t_obs=t, substeps=sub)

    @classmethod
    def build(cls, meas: Measurements, dx: float = DEFAULT_DX, dt: float = DEFAULT_DT) -> Grid:
        """Grid for a case: ``L = meas.bottom_depth``, observation times ``meas.t``.

        Defaults ``dx = 5 mm``, ``dt = 180 s``: on the reference case (kappa 1.31 W m-1 K-1,
        C 0.99 MJ m-3 K-1, h 10 W m-2 K-1, 15-min data) the CN solution is within 0.004 degC
        (max abs over all nodes and times) of a 4x refined one — 1/60 of sigma = 0.25 degC.
        """
        return cls.from_times(meas.bottom_depth, meas.t, dx=dx, dt=dt)

    @property
    def n_nodes(self) -> int:
        return int(self.x.size)

    @property
    def n_obs(self) -> int:
        return int(self.t_obs.size)

    @property
    def dx(self) -> float:
        """Node spacing, m."""
        return float(self.L / (self.x.size - 1))

    @property
    def step_dt(self) -> np.ndarray:
        """(n_obs-1,) solver step length in each observation interval, s."""
        return np.diff(self.t_obs) / self.substeps


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
    """

    T_air: np.ndarray
    T_bottom: np.ndarray
    T0: np.ndarray

    @classmethod
    def from_measurements(cls, meas: Measurements, grid: Grid) -> Forcing:
        """Forcing from a case: its air and bottom temperatures, T0 by ``meas.initial_profile``."""
        if not np.isclose(grid.L, meas.bottom_depth, rtol=1e-12, atol=0.0):
            raise ValueError(f"grid.L={grid.L} m differs from bottom_depth={meas.bottom_depth} m")
        if grid.t_obs.shape != meas.t.shape or not np.allclose(grid.t_obs, meas.t):
            raise ValueError("grid.t_obs differs from the measurement times")
        return cls(
            T_air=np.asarray(meas.T_air, dtype=float),
            T_bottom=np.asarray(meas.T_bottom, dtype=float),
            T0=meas.initial_profile(grid.x),
        )

