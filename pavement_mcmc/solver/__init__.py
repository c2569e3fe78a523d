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

Kernels are compiled with numba (``pavement_mcmc.solver.kernels.cn*``, ``cache=True``, ``fastmath`` limited
to FMA contraction). Parameter sets are the innermost, contiguous axis, so the loops over sets
vectorise (AVX2/AVX-512). Dispatch: up to 4 sets, a scalar one-set-at-a-time kernel (linear CN);
below 64 sets, blocks of sets on the calling thread; from 64 sets, one block per numba thread.
The solver uses no BLAS; keep BLAS single-threaded (``OMP_NUM_THREADS=1``) so it does not compete
for the cores. On a machine shared with other busy processes numba's ``workqueue`` threading
layer (``NUMBA_THREADING_LAYER=workqueue``) degrades far more gracefully than OpenMP.
"""

from .adjoint import solve_vjp
from .forward import SCHEMES, solve
from .grid import DEFAULT_DT, DEFAULT_DX, Coefficients, Forcing, Grid
from .reference import solve_numpy

__all__ = ["DEFAULT_DT", "DEFAULT_DX", "SCHEMES", "Coefficients", "Forcing", "Grid", "solve",
           "solve_numpy", "solve_vjp"]
