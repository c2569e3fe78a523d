r"""Vectorised 1D transient heat-conduction solver: many parameter sets in one call.

Problem (x downward, :math:`0 \le x \le L`)
-------------------------------------------
.. math::

    C(x)\,\partial_t T = \partial_x\left(\kappa(x, T)\,\partial_x T\right),\qquad
    \kappa\,\partial_x T\big|_{x=0} = h(t)\,(T - T_\mathrm{air}(t)) - q(t),\qquad
    T(L, t) = T_\mathrm{bottom}(t),\qquad T(x, 0) = T_0(x),

i.e. the heat flux into the ground at the surface is :math:`h (T_\mathrm{air} - T_s) + q`.
Units: m, s, degC, W m-1 K-1 (kappa), J m-3 K-1 (C), W m-2 K-1 (h), W m-2 (q).

Space: finite volumes on uniform nodes :math:`x_i = i\,\Delta x`. Cell ``i`` is
:math:`[x_i, x_{i+1}]` with conductivity :math:`\kappa_i`; node ``i`` carries :math:`C_i` and a
control volume :math:`\Delta x` (interior) or :math:`\Delta x/2` (surface node, which takes the
Robin flux directly — a half-cell balance, no ghost node). The semi-discrete system is

.. math::

    \dot T_0 = c_0 (T_1 - T_0) + \tfrac{2}{C_0\Delta x}\,(h (T_\mathrm{air} - T_0) + q),\quad
    \dot T_i = a_i (T_{i-1} - T_i) + c_i (T_{i+1} - T_i),

with :math:`a_i = \kappa_{i-1}/(C_i\Delta x^2)`, :math:`c_i = \kappa_i/(C_i\Delta x^2)`,
:math:`c_0 = 2\kappa_0/(C_0\Delta x^2)`; :math:`T_N = T_\mathrm{bottom}(t)`. It is second order
in :math:`\Delta x` (the half-cell boundary row is first order locally, second order globally).

Time: each observation interval :math:`[t_j, t_{j+1}]` is cut into ``Grid.substeps[j]`` equal
steps. ``h`` is constant on the interval; ``T_air``, ``T_bottom`` and ``q`` are linear in time
between observation times (evaluated at the step ends).

- ``"cn"`` Crank–Nicolson (default), second order in :math:`\Delta t`. The matrix
  :math:`I + \tfrac{\Delta t}{2} A` depends on ``h`` only through the surface row, so it is
  eliminated from the BOTTOM up (reverse Thomas): the pivots of every row below the surface are
  computed once per parameter set and step length, and only the surface pivot
  :math:`d_0 + \Delta t\,h/(C_0\Delta x)` is recomputed per observation interval. The factorisation
  is redone when the step length changes between consecutive intervals (irregular times), so
  memory stays O(1) in the number of distinct steps.
  Damping (Rannacher start-up): CN is A- but not L-stable, so the stiff modes excited by a kinked
  initial profile (interpolated sensors) or by a jump of ``h`` ring for many steps when
  :math:`\kappa\Delta t/(C\Delta x^2) \gg 1`. The first CN step of the run AND of every
  observation interval is therefore replaced by two backward-Euler half steps (they use the very
  same matrix, so cost nothing extra). The number of such steps does not grow as
  :math:`\Delta t \to 0`, so the scheme stays second order (verified in the tests). Measured on
  the reference case with a rough random h(t) at dt = 180 s: 0.06 degC error instead of 1.2 degC.
- ``"dff"`` Du Fort–Frankel (the paper's scheme, kept for parity): the three-level explicit scheme
  :math:`(T^{n+1}_i - T^{n-1}_i)/(2\Delta t)` = the discrete operator with :math:`T_i^n` replaced
  by :math:`(T_i^{n+1} + T_i^{n-1})/2` in every self term (conduction and the surface ``h T``
  term of the half-cell balance). Unconditionally stable but consistent only as
  :math:`\Delta t/\Delta x \to 0` (truncation error :math:`\propto D (\Delta t/\Delta x)^2
  \partial_t^2 T`). Started — and restarted whenever the step length changes — with one implicit
  step (two backward-Euler half steps). Compiled serial only (parity, not speed).

Temperature-dependent conductivity, :math:`\kappa(T) = \kappa (1 + \beta (T - T_\mathrm{ref}))`,
is evaluated per cell at the mean of the cell's two nodal temperatures of the PREVIOUS step
(lagged, semi-implicit: each step stays linear; the lag adds an
:math:`O(\beta\,\Delta t)` error that is small for realistic :math:`\beta \sim 10^{-3}` /K).

Default grid ``dx = 5 mm``, ``dt = 180 s`` (5 steps per 15-min interval), measured on the
shipped reference case (28 h, L = 5 cm, kappa 1.31, C 0.99e6, h 10): max abs difference over all
nodes and times against a 4x refined (dx/4, dt/4) solution 0.004 degC = sigma/60 (dt = 300 s:
0.008; 900 s: 0.09); at the literature values (kappa 2.27, C 2.1e6) 0.007 degC. Sensor depths on
a 1 cm spacing fall on nodes.

Kernels are compiled with numba (``pavement_mcmc._kernels*``, ``cache=True``, ``fastmath`` limited
to FMA contraction). Parameter sets are the innermost, contiguous axis, so the loops over sets
vectorise (AVX2/AVX-512). Dispatch: up to 4 sets, a scalar one-set-at-a-time kernel (linear CN);
below 64 sets, blocks of sets on the calling thread; from 64 sets, one block per numba thread.
The solver uses no BLAS; keep BLAS single-threaded (``OMP_NUM_THREADS=1``) so it does not compete
for the cores. On a machine shared with other busy processes numba's ``workqueue`` threading
layer (``NUMBA_THREADING_LAYER=workqueue``) degrades far more gracefully than OpenMP.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from pavement_mcmc import _kernels, _kernels_dff
from pavement_mcmc._kernels_scalar import cn_scalar
from pavement_mcmc.measurements import Measurements

SCHEMES = ("cn", "dff")
DEFAULT_DX = 0.005  # m
DEFAULT_DT = 180.0  # s
_BLOCK_MAX = 256  # most parameter sets per compiled block (working set stays in L2)
_SCALAR_MAX = 4  # up to this many sets: the one-set-at-a-time scalar CN kernel
_PARALLEL_MIN = 64  # from this many sets: blocks run on numba's threads
_N_START = 1  # CN steps replaced by two backward-Euler half steps each (Rannacher start-up)
_DAMP = True  # ... and the first CN step of every observation interval (h jumps there)


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


def _check(grid: Grid, forcing: Forcing, coeffs: Coefficients) -> tuple[np.ndarray, ...]:
    """Validate shapes and values; return float64 kappa, C, h, q, beta (beta may be None)."""
    n_obs, n_nodes = grid.n_obs, grid.n_nodes
    kappa = np.asarray(coeffs.kappa, dtype=float)
    if kappa.ndim != 2 or kappa.shape[0] < 1:
        raise ValueError(f"Coefficients.kappa must be (n_sets, n_nodes-1), got {kappa.shape}")
    S = kappa.shape[0]
    want = {
        "kappa": (S, n_nodes - 1),
        "C": (S, n_nodes),
        "h": (S, n_obs - 1),
        "q": (S, n_obs),
    }
    arrays = {"kappa": kappa}
    for name in ("C", "h", "q"):
        arrays[name] = np.asarray(getattr(coeffs, name), dtype=float)
    for name, shape in want.items():
        if arrays[name].shape != shape:
            raise ValueError(
                f"Coefficients.{name} has shape {arrays[name].shape}, expected {shape} "
                f"(n_sets={S}, n_nodes={n_nodes}, n_obs={n_obs})"
            )
        if not np.all(np.isfinite(arrays[name])):
            raise ValueError(f"Coefficients.{name} contains non-finite values")
    if np.any(kappa <= 0) or np.any(arrays["C"][:, :-1] <= 0):
        raise ValueError("Coefficients.kappa and C must be positive")
    beta = coeffs.beta
    if beta is not None:
        beta = np.asarray(beta, dtype=float)
        if beta.shape != (S,) or not np.all(np.isfinite(beta)):
            raise ValueError(f"Coefficients.beta must be finite (n_sets,)=({S},), got {beta.shape}")
    for name, shape in (("T_air", (n_obs,)), ("T_bottom", (n_obs,)), ("T0", (n_nodes,))):
        arr = np.asarray(getattr(forcing, name))
        if arr.shape != shape:
            raise ValueError(f"Forcing.{name} has shape {arr.shape}, expected {shape}")
    return kappa, arrays["C"], arrays["h"], arrays["q"], beta


def solve(grid: Grid, forcing: Forcing, coeffs: Coefficients, scheme: str = "cn") -> np.ndarray:
    """Nodal temperatures at the observation times for every parameter set.

    Parameters
    ----------
    grid : space-time grid.
    forcing : air/bottom temperatures and the initial profile, degC.
    coeffs : per-set kappa, C, h, q (and optional beta), SI units.
    scheme : ``"cn"`` (Crank–Nicolson, default) or ``"dff"`` (Du Fort–Frankel).

    Returns
    -------
    (n_sets, n_obs, n_nodes) temperatures, degC. Row ``0`` is ``forcing.T0``; the last node is
    ``T_bottom``. (A transposed view of the kernel's sets-innermost buffer.)
    """
    if scheme not in SCHEMES:
        raise ValueError(f"unknown scheme {scheme!r}; valid schemes: {', '.join(SCHEMES)}")
    kappa, C, h, q, beta = _check(grid, forcing, coeffs)
    S = kappa.shape[0]
    nonlin = beta is not None and bool(np.any(beta != 0.0))
    out = np.empty((grid.n_obs, grid.n_nodes, S))
    T_air = np.ascontiguousarray(forcing.T_air, dtype=float)
    T_bot = np.ascontiguousarray(forcing.T_bottom, dtype=float)
    T0 = np.ascontiguousarray(forcing.T0, dtype=float)
    kT, CT, hT, qT = (np.ascontiguousarray(v.T) for v in (kappa, C, h, q))
    if scheme == "cn" and not nonlin and S <= _SCALAR_MAX and grid.n_nodes > 2:
        cn_scalar(kT, CT, hT, qT, T_air, T_bot, T0, grid.t_obs, grid.substeps, grid.dx, _N_START, _DAMP, out)
        return out.transpose(2, 0, 1)
    threads = numba.get_num_threads()
    parallel = threads > 1 and S >= _PARALLEL_MIN
    per_thread = -(-S // threads) if parallel else S
    block = min(_BLOCK_MAX, -(-per_thread // 8) * 8)
    kernels = {
        ("cn", False): _kernels.cn_serial,
        ("cn", True): _kernels.cn_parallel,
        ("dff", False): _kernels_dff.dff_serial,
        ("dff", True): _kernels_dff.dff_serial,
    }
    kernels[scheme, parallel](
        kT,
        CT,
        hT,
        qT,
        np.zeros(S) if beta is None else np.ascontiguousarray(beta),
        float(coeffs.T_ref),
        nonlin,
        T_air,
        T_bot,
        T0,
        grid.t_obs,
        grid.substeps,
        grid.dx,
        _N_START,
        _DAMP,
        block,
        out,
    )
    return out.transpose(2, 0, 1)


def _operator(kappa: np.ndarray, C: np.ndarray, dx: float) -> tuple[np.ndarray, np.ndarray]:
    """Dense (n_sets, N, N) operator ``A`` (``dT/dt = -A T + ...``) and the bottom rate ``c_N-1``."""
    S, N = kappa.shape
    a = kappa[:, :-1] / (C[:, 1:N] * dx**2)  # rows 1..N-1, coupling to the node above
    c = kappa / (C[:, :N] * dx**2)
    c[:, 0] *= 2.0
    A = np.zeros((S, N, N))
    idx = np.arange(N)
    A[:, idx, idx] = c
    A[:, idx[1:], idx[1:]] += a
    A[:, idx[1:], idx[:-1]] = -a
    A[:, idx[:-1], idx[1:]] = -c[:, :-1]
    return A, c[:, -1]


def solve_numpy(grid: Grid, forcing: Forcing, coeffs: Coefficients) -> np.ndarray:
    """Plain batched NumPy Crank–Nicolson (same scheme as ``solve(..., "cn")``).

    Vectorised over sets with a Python loop over time steps. It takes an independent linear
    algebra route — per interval the dense one-step propagator
    :math:`P = (I + \\tfrac{\\Delta t}{2}A)^{-1}(I - \\tfrac{\\Delta t}{2}A)` from
    ``np.linalg.solve`` (per step, with lagged kappa, when ``beta`` is set) — so it cross-checks
    the compiled reverse-Thomas kernel, and it is the baseline of the benchmark.

    Returns
    -------
    (n_sets, n_obs, n_nodes) temperatures, degC.
    """
    kappa, C, h, q, beta = _check(grid, forcing, coeffs)
    S, N = kappa.shape
    dx = grid.dx
    Ta, Tb = np.asarray(forcing.T_air, float), np.asarray(forcing.T_bottom, float)
    hs = 2.0 / (C[:, 0] * dx)
    out = np.empty((S, grid.n_obs, N + 1))
    T = np.broadcast_to(np.asarray(forcing.T0, float)[:N], (S, N)).copy()
    out[:, 0, :N] = T
    out[:, 0, N] = Tb[0]
    nonlin = beta is not None and bool(np.any(beta != 0.0))
    eye = np.eye(N)
    A, cN = _operator(kappa, C, dx)
    nstep = 0

    def lin(v: np.ndarray, j: int, w: float) -> np.ndarray:
        return v[..., j] + w * (v[..., j + 1] - v[..., j])

    for j in range(grid.n_obs - 1):
        ns = int(grid.substeps[j])
        r = 0.5 * (grid.t_obs[j + 1] - grid.t_obs[j]) / ns
        for m in range(ns):
            if nonlin or m == 0:
                if nonlin:
                    Tc = 0.5 * (
                        T
                        + np.concatenate([T[:, 1:], lin(Tb, j, m / ns)[None, None] * np.ones((S, 1))], axis=1)
                    )
                    A, cN = _operator(kappa * (1.0 + beta[:, None] * (Tc - coeffs.T_ref)), C, dx)
                K = A.copy()
                K[:, 0, 0] += hs * h[:, j]
                Linv = np.linalg.solve(eye + r * K, np.broadcast_to(eye, K.shape))
                P = np.einsum("sij,sjk->sik", Linv, eye - r * K)
            w0, wh, w1 = m / ns, (m + 0.5) / ns, (m + 1) / ns
            if nstep < _N_START or (m == 0 and _DAMP):
                # two backward-Euler half steps: T+ = Linv (T + r b(t+))
                for w in (wh, w1):
                    b = np.zeros((S, N))
                    b[:, 0] += r * hs * (h[:, j] * lin(Ta, j, w) + lin(q, j, w))
                    b[:, N - 1] += r * cN * lin(Tb, j, w)
                    T = np.einsum("sij,sj->si", Linv, T + b)
            else:
                b = np.zeros((S, N))
                b[:, 0] += (
                    r * hs * (h[:, j] * (lin(Ta, j, w0) + lin(Ta, j, w1)) + lin(q, j, w0) + lin(q, j, w1))
                )
                b[:, N - 1] += r * cN * (lin(Tb, j, w0) + lin(Tb, j, w1))
                T = np.einsum("sij,sj->si", P, T) + np.einsum("sij,sj->si", Linv, b)
            nstep += 1
        out[:, j + 1, :N] = T
        out[:, j + 1, N] = Tb[j + 1]
    return out
