"""The solver's space-time :class:`Grid` (see :mod:`pavement_mcmc.solver` for the
discretisation; the per-set :class:`~.inputs.Coefficients` and the shared
:class:`~.inputs.Forcing` are in :mod:`.inputs`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..data.measurements import Measurements

DEFAULT_DX = 0.005  # m
DEFAULT_DT = 180.0  # s
# Grid.stretched defaults: the recommended grid for deep records (L = 50 cm, 30-min data; the
# measurements are in the pavement_mcmc.solver docstring): 44 nodes, 0.0085 degC from 4x refined
STRETCH_DX_TOP = 0.004  # m
STRETCH_GROWTH = 1.05
STRETCH_DX_MAX = 0.03  # m
STRETCH_DT = 1800.0 / 7  # s: 7 steps per 30-min interval


@dataclass(frozen=True)
class Grid:
    """Space-time grid of one case.

    Attributes
    ----------
    L : depth of the Dirichlet bottom boundary, m.
    x : (n_nodes,) node depths, m, strictly increasing, ``x[0] = 0``, ``x[-1] = L``; uniform
        (:meth:`from_times`, :meth:`build`) or stretched with depth (:meth:`stretched`).
    t_obs : (n_obs,) observation times, s, strictly increasing (irregular spacing allowed).
    substeps : (n_obs-1,) int, solver steps in each observation interval; the step in interval
        ``j`` is ``(t_obs[j+1] - t_obs[j]) / substeps[j]``.
    soil_top : ``x`` of the soil surface, m: 0, or the thickness of a skin node put above the
        soil (:meth:`with_skin`); sensor depths, the initial profile and ``L - soil_top`` (the
        bottom sensor's depth) are measured from it.

    A grid whose spacings all agree with ``L / (n_nodes - 1)`` to 1e-9 (relative) is
    :attr:`uniform`; the solver then uses that nominal spacing, :attr:`dx`, for every cell.
    """

    L: float
    x: np.ndarray
    t_obs: np.ndarray
    substeps: np.ndarray
    soil_top: float = 0.0

    def __post_init__(self) -> None:
        x = np.asarray(self.x, dtype=float)
        t = np.asarray(self.t_obs, dtype=float)
        n = np.asarray(self.substeps)
        if x.ndim != 1 or x.size < 2:
            raise ValueError(f"Grid.x must be 1D with >= 2 nodes, got shape {x.shape}")
        if x[0] != 0.0 or not np.isclose(x[-1], self.L, rtol=1e-12, atol=0.0) or x[-1] <= 0:
            raise ValueError(f"Grid.x must run from 0 to L={self.L} m, got [{x[0]}, {x[-1]}]")
        steps = np.diff(x)
        if np.any(steps <= 0):
            k = int(np.argmax(steps <= 0))
            raise ValueError(f"Grid.x must be strictly increasing: x[{k}]={x[k]} m, x[{k + 1}]={x[k + 1]} m")
        if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
            raise ValueError("Grid.t_obs must be 1D, >= 2 times, strictly increasing (s)")
        if n.shape != (t.size - 1,) or not np.issubdtype(n.dtype, np.integer) or np.any(n < 1):
            raise ValueError(f"Grid.substeps must be (n_obs-1,)=({t.size - 1},) positive ints, got {n.shape}")
        nominal = (x[-1] - x[0]) / (x.size - 1)
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "t_obs", t)
        object.__setattr__(self, "substeps", n.astype(np.int64))
        object.__setattr__(self, "L", float(self.L))
        top = float(self.soil_top)
        if top != 0.0 and not (x.size > 2 and np.isclose(x[1], top, rtol=1e-12, atol=0.0)):
            raise ValueError(f"Grid.soil_top={top} m must be 0 or the second node x[1]={x[1]} m")
        object.__setattr__(self, "soil_top", top)
        object.__setattr__(self, "_uniform", bool(np.allclose(steps, nominal, rtol=1e-9, atol=0.0)))

    @classmethod
    def from_times(cls, L: float, t_obs: np.ndarray, dx: float = DEFAULT_DX, dt: float = DEFAULT_DT) -> Grid:
        """Uniform grid with ``ceil(L/dx)`` cells and ``ceil(interval/dt)`` steps per interval.

        The actual spacing and steps are the largest uniform values not exceeding ``dx`` (m)
        and ``dt`` (s).
        """
        if not (dx > 0 and dt > 0 and L > 0):
            raise ValueError(f"need L, dx, dt > 0, got L={L}, dx={dx}, dt={dt}")
        n_cells = max(1, math.ceil(L / dx * (1.0 - 1e-12)))
        x = np.linspace(0.0, L, n_cells + 1)
        return cls(L=L, x=x, t_obs=_times(t_obs), substeps=_substeps(t_obs, dt))

    @classmethod
    def build(cls, meas: Measurements, dx: float = DEFAULT_DX, dt: float = DEFAULT_DT) -> Grid:
        """Uniform grid for a case: ``L = meas.bottom_depth``, observation times ``meas.t``.

        Defaults ``dx = 5 mm``, ``dt = 180 s``: on the reference case (kappa 1.31 W m-1 K-1,
        C 0.99 MJ m-3 K-1, h 10 W m-2 K-1, 15-min data) the CN solution is within 0.004 degC
        (max abs over all nodes and times) of a 4x refined one — 1/60 of sigma = 0.25 degC.
        With a measured top (:meth:`~pavement_mcmc.data.Measurements.with_measured_top`) the
        depths are already below the top sensor.
        """
        return cls.from_times(meas.bottom_depth, meas.t, dx=dx, dt=dt)

    @classmethod
    def stretched(
        cls,
        L: float,
        t_obs: np.ndarray,
        *,
        dx_top: float = STRETCH_DX_TOP,
        growth: float = STRETCH_GROWTH,
        dx_max: float = STRETCH_DX_MAX,
        dt: float = STRETCH_DT,
        nodes_at: np.ndarray | list[float] = (),
    ) -> Grid:
        """Grid whose cells grow geometrically with depth, with nodes exactly at ``nodes_at``.

        Cell ``k`` from the surface is at most ``min(dx_top growth^k, dx_max)``: the target
        spacing at depth ``x`` is ``s(x) = min(dx_top + (growth - 1) x, dx_max)`` (a geometric
        sequence of cells has exactly this spacing at its nodes). Every depth in ``nodes_at``
        (sensor and flux-plate depths, m; 0 and ``L`` are always nodes) becomes a node, so
        observations need no interpolation; between two such depths the nodes are equally
        spaced in the cell-count coordinate ``n(x)`` of the geometric sequence (with the count
        rounded up), so no cell exceeds its target and the spacing stays smooth.
        Steps as :meth:`from_times`: ``ceil(interval/dt)`` per observation interval.

        The defaults are the recommended grid for deep records (see :mod:`pavement_mcmc.solver`).
        """
        if not (L > 0 and dx_top > 0 and dx_max >= dx_top and growth >= 1.0 and dt > 0):
            raise ValueError(
                f"Grid.stretched needs L > 0, 0 < dx_top <= dx_max, growth >= 1, dt > 0; got L={L}, "
                f"dx_top={dx_top}, dx_max={dx_max}, growth={growth}, dt={dt}"
            )
        z = np.atleast_1d(np.asarray(nodes_at, dtype=float))
        if z.ndim != 1 or np.any(~np.isfinite(z)) or np.any(z < 0) or np.any(z > L * (1 + 1e-12)):
            raise ValueError(f"Grid.stretched: nodes_at must be depths in [0, L={L}] m, got {z}")
        z = np.unique(np.concatenate([[0.0, float(L)], z[(z > 0) & (z < L * (1 - 1e-12))]]))
        if np.any(np.diff(z) < 1e-9):
            raise ValueError(f"Grid.stretched: nodes_at contains depths closer than 1e-9 m: {z}")
        count = _CellCount(dx_top, growth, dx_max)
        x = [0.0]
        for za, zb in zip(z[:-1], z[1:]):
            na, nb = count(za), count(zb)
            k = max(1, math.ceil((nb - na) * (1.0 - 1e-9)))
            x.extend(count.inverse(na + (nb - na) * np.arange(1, k) / k))
            x.append(zb)
        return cls(L=L, x=np.array(x), t_obs=_times(t_obs), substeps=_substeps(t_obs, dt))

    @classmethod
    def build_stretched(cls, meas: Measurements, **kwargs) -> Grid:
        """:meth:`stretched` grid for a case: ``L = meas.bottom_depth``, times ``meas.t``, nodes
        at the sensor and heat-flux plate depths unless ``nodes_at`` is given (then add the
        sensor depths yourself if you want them). With a measured top
        (:meth:`~pavement_mcmc.data.Measurements.with_measured_top`) every depth is already
        below the top sensor. Other keywords as :meth:`stretched`."""
        plates = meas.flux_depths if meas.flux_depths is not None else []
        kwargs.setdefault("nodes_at", np.concatenate([meas.depths, plates]))
        return cls.stretched(meas.bottom_depth, meas.t, **kwargs)

    def refined(self, factor: int = 4) -> Grid:
        """The same grid refined ``factor`` times in space and time: every cell split into
        ``factor`` equal cells (node ``i`` becomes node ``factor * i``) and ``factor`` times the
        substeps. ``solve`` on it, sampled at ``[:, :, ::factor]``, is the reference for a grid
        convergence check (the defaults are checked this way: max error over all nodes and
        times against ``refined(4)``)."""
        k = int(factor)
        if k < 1 or k != factor:
            raise ValueError(f"Grid.refined: factor must be a positive integer, got {factor}")
        if self.soil_top:
            raise ValueError("Grid.refined: a grid with a skin node (a lumped node, not a cell to "
                             "split); refine the soil's grid, then add the skin")
        if self._uniform:
            x = np.linspace(0.0, self.L, k * (self.x.size - 1) + 1)
        else:
            w = np.arange(k) / k
            x = np.r_[(self.x[:-1, None] + w * np.diff(self.x)[:, None]).ravel(), self.x[-1]]
        return Grid(L=self.L, x=x, t_obs=self.t_obs, substeps=k * self.substeps)

    def with_skin(self, thickness: float) -> Grid:
        """This grid below a skin node: a node at ``x = 0`` and a first cell of ``thickness``
        (m) above the soil, whose nodes move down by it (``soil_top = thickness``, ``L`` +
        ``thickness``). A canopy's skin (physics/catalogue/canopy.py) sits there; depths stay
        measured from the soil surface."""
        if self.soil_top:
            raise ValueError("Grid.with_skin: the grid already has a skin node")
        if not thickness > 0:
            raise ValueError(f"Grid.with_skin: thickness must be > 0, got {thickness}")
        return Grid(L=self.L + thickness, x=np.r_[0.0, self.x + thickness], t_obs=self.t_obs,
                    substeps=self.substeps, soil_top=thickness)

    @property
    def soil_x(self) -> np.ndarray:
        """(n_nodes,) depth of each node below the soil surface, m (negative for a skin node)."""
        return self.x - self.soil_top

    @property
    def n_nodes(self) -> int:
        return int(self.x.size)

    @property
    def n_obs(self) -> int:
        return int(self.t_obs.size)

    @property
    def uniform(self) -> bool:
        """True if every spacing equals ``L / (n_nodes - 1)`` (to 1e-9, relative)."""
        return self._uniform

    @property
    def dx(self) -> float:
        """Node spacing of a uniform grid, m (``L / (n_nodes - 1)``); see :attr:`dx_cells`."""
        if not self._uniform:
            raise ValueError(
                f"Grid.dx: the grid is non-uniform (cells {self.dx_cells.min():.4g} to "
                f"{self.dx_cells.max():.4g} m); use Grid.dx_cells"
            )
        return float(self.L / (self.x.size - 1))

    @property
    def dx_cells(self) -> np.ndarray:
        """(n_nodes-1,) width of cell ``[x_i, x_i+1]``, m (all :attr:`dx` on a uniform grid)."""
        if self._uniform:
            return np.full(self.x.size - 1, self.dx)
        return np.diff(self.x)

    @property
    def volumes(self) -> np.ndarray:
        """(n_nodes,) control-volume width of each node, m: ``(dx_i-1 + dx_i)/2`` inside,
        ``dx_0/2`` at the surface and ``dx_N-1/2`` at the bottom."""
        d = self.dx_cells
        return 0.5 * (np.r_[0.0, d] + np.r_[d, 0.0])

    @property
    def step_dt(self) -> np.ndarray:
        """(n_obs-1,) solver step length in each observation interval, s."""
        return np.diff(self.t_obs) / self.substeps

    def _rate_geometry(self) -> _Geometry:
        """Per-node factors of the rates, for the kernels and the adjoint (computed once per
        grid, read-only); see :class:`_Geometry`."""
        geom = self.__dict__.get("_geometry")
        if geom is None:
            geom = _Geometry.of(self.dx_cells)
            object.__setattr__(self, "_geometry", geom)
        return geom


class _Geometry(NamedTuple):
    """The grid's rate factors, each (N,) with N = n_nodes-1 unless stated.

    ``d[i] = dx_i``; ``Vd[i] = V_i`` (``Vd[0] = dx_0 = 2 V_0``); ``ga[i] = 1 / (Vd[i] dx_i-1)``
    (``ga[0] = 1 / dx_0^2``); ``rho[i] = dx_i-1 / dx_i`` (``rho[0] = 1``). Then ``a_i = kappa_i-1
    ga_i / C_i``, ``c_i = kappa_i ga_i rho_i / C_i``, ``c_0 = 2 kappa_0 ga_0 / C_0`` and the surface
    factor is ``2 / (C_0 dx_0)``. For the kernels: ``kernel`` = (2, N) ``(ga, rho)``, ``dx0``.
    For the adjoint's gradients (:func:`pavement_mcmc.solver.adjoint._gradients`): ``vol_ratio
    [k] = Vd_k / Vd_k+1`` (N-1,), ``inv_rho = 1 / rho`` as ``dx_i / dx_i-1`` and ``den = Vd d``.
    On a uniform grid ``Vd = d = dx``, ``rho = vol_ratio = inv_rho = 1`` exactly and ``ga = den^-1
    = 1 / (dx dx)``: the same floating-point operations as a scalar ``dx``.
    """

    d: np.ndarray
    Vd: np.ndarray
    ga: np.ndarray
    rho: np.ndarray
    kernel: np.ndarray
    dx0: float
    vol_ratio: np.ndarray
    inv_rho: np.ndarray
    den: np.ndarray

    @classmethod
    def of(cls, d: np.ndarray) -> _Geometry:
        prev = np.r_[d[0], d[:-1]]
        Vd = np.r_[d[0], 0.5 * (d[:-1] + d[1:])]
        ga, rho = 1.0 / (Vd * prev), prev / d
        geom = cls(d, Vd, ga, rho, np.stack((ga, rho)), float(d[0]), Vd[:-1] / Vd[1:], d / prev, Vd * d)
        for a in geom:
            if isinstance(a, np.ndarray):
                a.setflags(write=False)
        return geom


class _CellCount:
    """Cell-count coordinate of a geometric grid capped at ``dx_max``: ``n(x)`` cells of sizes
    ``dx_top growth^k`` fill ``[0, x]`` (fractional counts interpolate), and its inverse."""

    def __init__(self, dx_top: float, growth: float, dx_max: float) -> None:
        self.d, self.g, self.dmax = dx_top, growth, dx_max
        self.lg = math.log(growth)
        if growth == 1.0 or dx_max == dx_top:  # uniform dx_top
            self.xc, self.nc, self.dmax = 0.0, 0.0, dx_top
        else:  # where the cells reach dx_max
            self.nc = math.log(dx_max / dx_top) / self.lg
            self.xc = (dx_max - dx_top) / (growth - 1.0)

    def __call__(self, x: float) -> float:
        if x <= self.xc and self.nc > 0:
            return math.log1p((self.g - 1.0) * x / self.d) / self.lg
        return self.nc + (x - self.xc) / self.dmax

    def inverse(self, n: np.ndarray) -> np.ndarray:
        n = np.asarray(n, dtype=float)
        geo = self.d * np.expm1(np.minimum(n, self.nc) * self.lg) / (self.g - 1.0) if self.nc > 0 else 0.0 * n
        return np.where(n <= self.nc, geo, self.xc + (n - self.nc) * self.dmax)


def _times(t_obs: np.ndarray) -> np.ndarray:
    t = np.asarray(t_obs, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise ValueError("t_obs must be 1D with at least 2 times (s)")
    return t


def _substeps(t_obs: np.ndarray, dt: float) -> np.ndarray:
    """``ceil(interval / dt)`` solver steps per observation interval (at least 1)."""
    return np.maximum(1, np.ceil(np.diff(_times(t_obs)) / dt * (1.0 - 1e-12))).astype(np.int64)
