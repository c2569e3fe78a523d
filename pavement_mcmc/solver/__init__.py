r"""Vectorised 1D transient heat-conduction solver: many parameter sets in one call.

Problem (x downward, :math:`0 \le x \le L`)
-------------------------------------------
.. math::

    C(x)\,\partial_t T = \partial_x\left(\kappa(x, T)\,\partial_x T\right),\qquad
    \kappa\,\partial_x T\big|_{x=0} = h(t)\,(T - T_\mathrm{air}(t)) - q(t),\qquad
    T(L, t) = T_\mathrm{bottom}(t),\qquad T(x, 0) = T_0(x),

i.e. the heat flux into the ground at the surface is :math:`h (T_\mathrm{air} - T_s) + q`;
alternatively a measured top temperature, :math:`T(0, t) = T_\mathrm{top}(t)` (Dirichlet).
Units: m, s, degC, W m-1 K-1 (kappa), J m-3 K-1 (C), W m-2 K-1 (h), W m-2 (q).

Space: finite volumes (vertex-centred) on increasing nodes :math:`0 = x_0 < x_1 < \dots < x_N = L`,
uniform (:meth:`Grid.from_times`, :meth:`Grid.build`) or stretched with depth
(:meth:`Grid.stretched`). Cell ``i`` is :math:`[x_i, x_{i+1}]`, width :math:`\Delta x_i`, with
conductivity :math:`\kappa_i`; node ``i`` carries :math:`C_i` and the control volume
:math:`V_i = (\Delta x_{i-1} + \Delta x_i)/2` (surface node: :math:`V_0 = \Delta x_0/2`, which
takes the Robin flux directly — a half-cell balance, no ghost node). The semi-discrete system is

.. math::

    \dot T_0 = c_0 (T_1 - T_0) + \tfrac{1}{C_0 V_0}\,(h (T_\mathrm{air} - T_0) + q),\quad
    \dot T_i = a_i (T_{i-1} - T_i) + c_i (T_{i+1} - T_i),

with the rates (1/s) :math:`a_i = \kappa_{i-1}/(C_i V_i \Delta x_{i-1})`,
:math:`c_i = \kappa_i/(C_i V_i \Delta x_i)`, so :math:`c_0 = 2\kappa_0/(C_0\Delta x_0^2)`, and the
surface factor :math:`1/(C_0 V_0) = 2/(C_0 \Delta x_0)` (m² K J⁻¹); :math:`T_N = T_\mathrm{bottom}(t)`.
On a uniform grid these are :math:`\kappa/(C\Delta x^2)` and :math:`2/(C\Delta x)`; the kernels
evaluate them from per-node factors :math:`g_i = 1/(V_i\Delta x_{i-1})` and
:math:`\rho_i = \Delta x_{i-1}/\Delta x_i` (:math:`a_i = \kappa_{i-1} g_i / C_i`,
:math:`c_i = \kappa_i g_i \rho_i / C_i`), which equal :math:`1/\Delta x^2` and 1 exactly on a
uniform grid, so the uniform path performs the same floating-point operations as with a scalar
:math:`\Delta x`. The scheme is conservative, exact for piecewise-linear steady profiles when
layer interfaces sit on nodes, and second order in :math:`\Delta x` on uniform and smoothly
stretched grids (the half-cell boundary row and the off-centre nodes of a stretched grid are
first order locally, second order globally; verified in the tests, observed orders 2.00).

Dirichlet top (``Forcing.T_top``, e.g. the shallowest sensor, with ``x = 0`` at that sensor):
:math:`T_0 = T_\mathrm{top}(t)`, linear in time between observation times; the unknowns are nodes
``1 .. N-1`` and ``h``, ``q`` and ``T_air`` are ignored (their gradients are zero). Node 1 couples
to the top through :math:`a_1`, exactly as node ``N-1`` couples to the bottom. Same time stepping
and start-up damping as the Robin top.

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
  step (two backward-Euler half steps). Compiled serial only (parity, not speed); uniform grids
  and a Robin top only (``ValueError`` otherwise: its consistency condition is stated for one
  :math:`\Delta x`).

Temperature-dependent conductivity, :math:`\kappa(T) = \kappa (1 + \beta (T - T_\mathrm{ref}))`,
is evaluated per cell at the mean of the cell's two nodal temperatures of the PREVIOUS step
(lagged, semi-implicit: each step stays linear; the lag adds an
:math:`O(\beta\,\Delta t)` error that is small for realistic :math:`\beta \sim 10^{-3}` /K).

Default grid ``dx = 5 mm``, ``dt = 180 s``, measured on the
shipped reference case (28 h, L = 5 cm, kappa 1.31, C 0.99e6, h 10): max abs difference over all
nodes and times against a 4x refined (dx/4, dt/4) solution 0.004 degC = sigma/60 (dt = 300 s:
0.008; 900 s: 0.09); at the literature values (kappa 2.27, C 2.1e6) 0.007 degC. Sensor depths on
a 1 cm spacing fall on nodes.

Deep records (sensors to 50 cm, 30-min data): :meth:`Grid.stretched` / :meth:`Grid.build_stretched`
with their defaults ``dx_top = 4 mm``, ``growth = 1.05``, ``dx_max = 3 cm``, ``dt = 1800/7 s``
(7 steps per 30-min interval) and nodes at the sensor depths. Measured on the shared Göttingen
grass record (72 h from hour 168, L = 50 cm, nodes at 2, 5, 10, 20 cm; the record's T_air and
q_net, h = 10): 44 nodes; max abs difference over all nodes and times against
``grid.refined(4)`` 0.0085 degC at kappa 1.2, C 2.6e6 and at most 0.0097 degC over
kappa/C = 0.3-0.7 mm² s⁻¹ (kappa 1.2 with C 1.7-4.0 MJ m⁻³ K⁻¹, and C 2.6 MJ with kappa
0.78-1.82). The uniform 5 mm / 180 s grid (101 nodes, 1440 steps) gives 0.0101 degC (up to
0.019 at kappa/C = 0.3), at 2.7-2.9 times the time per solve (1-64 sets, ``make bench``). The
cells must grow slowly: with all of q_net entering the ground the daily wave still has several
degC at 10-20 cm, and a cell of width :math:`\Delta x` resolves it to a relative
:math:`\sim(\Delta x/d)^2/12` (damping depth :math:`d = \sqrt{2\kappa/(C\omega)} \approx 11`
cm), so the spacing may only grow like :math:`e^{x/2d}`, a ratio of about
:math:`1 + \Delta x_\mathrm{top}/2d`; growth 1.1, 1.2, 1.3 give 0.020, 0.049, 0.053 degC (33,
26, 25 nodes), the error peaking at 10-20 cm. dt matters as much: with the per-interval damping
the time error alone is 0.012 degC at 300 s (0.004 at 180 s; 0.003 at 300 s without that
damping). With the 2 cm sensor as a Dirichlet top the same settings give 0.0008 degC. Check
another record the same way: compare ``solve`` on ``grid`` and ``grid.refined(4)``.

Kernels are compiled with numba (``pavement_mcmc.solver.kernels.cn*``, ``cache=True``, ``fastmath`` limited
to FMA contraction). Every kernel takes its read-only inputs as one named tuple
(:class:`pavement_mcmc.solver.kernels.cn.Problem`). Parameter sets are the innermost, contiguous
axis, so the loops over sets vectorise (AVX2/AVX-512); the forward CN kernel
(``kernels.cn_simd``) runs them on explicit vectors of 8 sets kept in registers along the nodes.
Dispatch: up to 4 sets, a scalar one-set-at-a-time kernel (linear CN); below 64 sets, blocks of
sets on the calling thread; from 64 sets, one block per numba thread.
The solver uses no BLAS; keep BLAS single-threaded (``OMP_NUM_THREADS=1``) so it does not compete
for the cores. On a machine shared with other busy processes numba's ``workqueue`` threading
layer (``NUMBA_THREADING_LAYER=workqueue``) degrades far more gracefully than OpenMP.
"""

from .adjoint import solve_vjp
from .forward import SCHEMES, solve
from .grid import (
    DEFAULT_DT,
    DEFAULT_DX,
    STRETCH_DT,
    STRETCH_DX_MAX,
    STRETCH_DX_TOP,
    STRETCH_GROWTH,
    Grid,
)
from .inputs import Coefficients, Forcing
from .reference import solve_numpy

__all__ = ["DEFAULT_DT", "DEFAULT_DX", "SCHEMES", "STRETCH_DT", "STRETCH_DX_MAX", "STRETCH_DX_TOP",
           "STRETCH_GROWTH", "Coefficients", "Forcing", "Grid", "solve", "solve_numpy", "solve_vjp"]
