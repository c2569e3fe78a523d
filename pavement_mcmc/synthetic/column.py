"""Finite-volume heat conduction in a deep ground column (the twin simulator's numerical core).

Independent of the inversion solver on purpose: vertex-centred finite volumes on a fine grid
(0.25 mm by default) that is stretched geometrically below the sensors down to a deep Dirichlet
boundary, exact series (harmonic) face conductances for layered ground, and BDF2 time stepping
(first step backward Euler) with the surface emission and a temperature-dependent conductivity
linearised about the extrapolated temperature ``2 T^n - T^(n-1)``.

Equations (x downward, SI units, degC)::

    C(x) dT/dt = d/dx( kappa(x) (1 + beta (T - T_ref)) dT/dx ) + s(x)          0 < x < L
    -kappa dT/dx |_0 = q_abs(t) - e_rad (T_s + 273.15)^4 + h(t) (T_air(t) - T_s) - q_sink(t) - LE(t)
    T(L, t) = T_deep(t)

where the left-hand side of the surface condition is the heat flux into the ground, s(x) a
steady volumetric heat source (W m-3; a buried pipe is a concentrated one) and LE the
Priestley-Taylor evapotranspiration (W m-2, zero unless switched on)::

    LE^n = f_PT(t^n) max(R_n^n - G^(n-1), 0),    R_n = q_abs - e_rad (T_s + 273.15)^4

(or ``max(R_n^n, 0)``, the net radiation alone as the available energy, with ``et_ground=False``)

with f_PT = alpha s / (s + gamma) given per time level, the net radiation at the extrapolated
surface temperature and G the conductive flux from the surface node into the ground one step
earlier (lagged, so the step stays linear; the lag relaxes with ratio f_PT < 1 per step).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

KELVIN = 273.15
"""Offset from degC to K."""
STEFAN_BOLTZMANN = 5.670374419e-8
"""Stefan-Boltzmann constant, W m-2 K-4."""


@dataclass(frozen=True)
class Column:
    """A discretised ground column.

    Attributes
    ----------
    z : (n_nodes,) node depths, m; ``z[0] == 0`` (surface), ``z[-1] == L`` (Dirichlet bottom).
    heat_capacity : (n_nodes,) heat capacity of each node's control volume per unit area,
        J m-2 K-1 (the integral of C over the control volume).
    conductance : (n_nodes - 1,) thermal conductance of each cell ``[z_i, z_i+1]`` per unit
        area at ``T_ref``, W m-2 K-1: ``1 / integral(dx / kappa)`` (exact for layered ground).
    """

    z: np.ndarray
    heat_capacity: np.ndarray
    conductance: np.ndarray

    @property
    def n_nodes(self) -> int:
        return int(self.z.size)


def stretched_nodes(fine_depth: float, depth: float, dz: float, growth: float = 1.08) -> np.ndarray:
    """Node depths: uniform spacing ``dz`` down to ``fine_depth``, then geometric growth.

    Parameters
    ----------
    fine_depth : depth of the uniformly resolved zone, m (rounded up to a multiple of ``dz``).
    depth : total column depth L, m (the last node).
    dz : uniform cell size in the fine zone, m.
    growth : ratio between consecutive cell sizes below the fine zone (> 1).

    Returns
    -------
    (n_nodes,) increasing depths, m, from 0 to ``depth``.
    """
    if not 0 < dz < depth:
        raise ValueError(f"cell size dz={dz} m must be in (0, column depth {depth} m)")
    n_fine = int(np.ceil(min(fine_depth, depth) / dz - 1e-9))
    z = list(np.arange(n_fine + 1) * dz)
    step = dz
    while z[-1] < depth - 1e-12:
        step *= growth
        z.append(min(z[-1] + step, depth))
    if z[-1] - z[-2] < 0.3 * (z[-2] - z[-3]):  # merge a sliver cell at the bottom
        z.pop(-2)
    return np.asarray(z, dtype=float)


def layered_column(z: np.ndarray, interfaces: np.ndarray, kappa: np.ndarray, C: np.ndarray) -> Column:
    """Finite-volume coefficients of a column made of horizontal layers.

    Parameters
    ----------
    z : (n_nodes,) node depths, m, increasing from 0.
    interfaces : (n_layers - 1,) depths of the layer interfaces, m, increasing.
    kappa : (n_layers,) thermal conductivity of each layer, W m-1 K-1.
    C : (n_layers,) volumetric heat capacity of each layer, J m-3 K-1.

    Returns
    -------
    Column with exact integrals of C over control volumes and of 1/kappa over cells.
    """
    interfaces = np.atleast_1d(np.asarray(interfaces, float))
    kappa = np.atleast_1d(np.asarray(kappa, float))
    C = np.atleast_1d(np.asarray(C, float))
    if not (kappa.size == C.size == interfaces.size + 1):
        raise ValueError("need one kappa and one C per layer and n_layers - 1 interfaces")
    edges = np.concatenate(([-np.inf], interfaces, [np.inf]))

    def integral(a: np.ndarray, b: np.ndarray, values: np.ndarray) -> np.ndarray:
        # integral over [a, b] of a piecewise-constant property
        total = np.zeros_like(a)
        for lo, hi, v in zip(edges[:-1], edges[1:], values, strict=True):
            total += np.clip(np.minimum(b, hi) - np.maximum(a, lo), 0.0, None) * v
        return total

    resistance = integral(z[:-1], z[1:], 1.0 / kappa)
    mid = 0.5 * (z[:-1] + z[1:])
    lo = np.concatenate(([z[0]], mid))
    hi = np.concatenate((mid, [z[-1]]))
    return Column(z=z, heat_capacity=integral(lo, hi, C), conductance=1.0 / resistance)


@dataclass(frozen=True)
class ColumnRun:
    """What :func:`march` returns.

    Attributes
    ----------
    profiles : (n_records, n_nodes) temperatures at the recorded time levels, degC.
    latent : (n_steps + 1,) evapotranspiration LE at every time level, W m-2 (zeros if off).
    """

    profiles: np.ndarray
    latent: np.ndarray


@njit(cache=True, error_model="numpy")
def _integrate(
    M, G, beta, T_ref, T_init, dt, T_air, h, q_abs, q_sink, e_rad, T_deep, record_every, S, f_pt, et_on,
    et_ground,
):  # pragma: no cover - compiled
    n = M.size
    n_steps = T_air.size - 1
    out = np.empty((n_steps // record_every + 1, n))
    latent = np.zeros(n_steps + 1)
    c = M / dt
    T_old = T_init.copy()
    T = T_init.copy()
    T[n - 1] = T_deep[0]
    out[0] = T
    K = G.copy()
    di = np.empty(n)
    rhs = np.empty(n)
    for step in range(1, n_steps + 1):
        # BDF2 (backward Euler on the first step): a T^{n+1} - hist = dt/M * (fluxes at n+1)
        first = step == 1
        a = 1.0 if first else 1.5
        if beta != 0.0:  # kappa at the extrapolated state 2 T^n - T^{n-1}
            for i in range(n - 1):
                Tm = 0.5 * (T[i] + T[i + 1]) if first else T[i] + T[i + 1] - 0.5 * (T_old[i] + T_old[i + 1])
                K[i] = G[i] * (1.0 + beta * (Tm - T_ref))
        Ts = T[0] if first else 2.0 * T[0] - T_old[0]
        tk = Ts + 273.15
        rad = e_rad * tk**4
        drad = 4.0 * e_rad * tk**3
        sink = q_sink[step]
        if et_on:  # Priestley-Taylor on the available energy, G lagged one step
            ground = et_ground * K[0] * (T[0] - T[1])
            latent[step] = f_pt[step] * max(q_abs[step] - rad - ground, 0.0)
            sink += latent[step]
        # surface row: radiation linearised about Ts, convection, latent sink
        hist = T[0] if first else 2.0 * T[0] - 0.5 * T_old[0]
        di[0] = a * c[0] + K[0] + h[step] + drad
        rhs[0] = c[0] * hist + q_abs[step] - sink + h[step] * T_air[step] - rad + drad * Ts + S[0]
        # interior rows, assembled and eliminated downwards (Thomas); row n-1 is Dirichlet
        for i in range(1, n - 1):
            hist = T[i] if first else 2.0 * T[i] - 0.5 * T_old[i]
            w = -K[i - 1] / di[i - 1]
            di[i] = a * c[i] + K[i - 1] + K[i] + w * K[i - 1]
            rhs[i] = c[i] * hist + S[i] - w * rhs[i - 1]
        for i in range(n):
            T_old[i] = T[i]
        T[n - 1] = T_deep[step]
        for i in range(n - 2, -1, -1):
            T[i] = (rhs[i] + K[i] * T[i + 1]) / di[i]
        if step % record_every == 0:
            out[step // record_every] = T
    return out, latent


def march(
    column: Column,
    T_init: np.ndarray,
    dt: float,
    T_air: np.ndarray,
    h: np.ndarray,
    q_abs: np.ndarray,
    q_sink: np.ndarray,
    T_deep: np.ndarray,
    *,
    emissivity: float = 0.0,
    beta: float = 0.0,
    T_ref: float = 20.0,
    record_every: int = 1,
    source: np.ndarray | None = None,
    pt_factor: np.ndarray | None = None,
    et_ground: bool = True,
) -> ColumnRun:
    """March the column in time with BDF2.

    Parameters
    ----------
    column : the discretised column.
    T_init : (n_nodes,) initial temperature, degC.
    dt : time step, s.
    T_air : (n_steps + 1,) air temperature at each time level, degC.
    h : (n_steps + 1,) surface heat transfer coefficient, W m-2 K-1.
    q_abs : (n_steps + 1,) radiation absorbed at the surface, excluding the surface's own
        emission, W m-2 (into the ground).
    q_sink : (n_steps + 1,) other heat flux out of the ground (latent heat), W m-2.
    T_deep : (n_steps + 1,) Dirichlet temperature at the bottom node, degC.
    emissivity : factor ``e`` of the surface emission ``e * sigma_SB * (T_s + 273.15)^4``
        (0 switches emission off; the radiation factor f multiplies it in).
    beta : temperature coefficient of the conductivity, 1/K.
    T_ref : reference temperature of ``beta``, degC.
    record_every : keep every ``record_every``-th time level (starting with level 0).
    source : (n_nodes,) steady heat source of each node's control volume per unit area, W m-2
        (None: none); see :func:`point_source`.
    pt_factor : (n_steps + 1,) Priestley-Taylor factor alpha s / (s + gamma) at each time level
        (None: no evapotranspiration). Must stay below 1 (the lagged closure relaxes with it).
    et_ground : True: the available energy of the evapotranspiration is R_n - G (G lagged);
        False: R_n alone.

    Returns
    -------
    ColumnRun: profiles (n_steps // record_every + 1, n_nodes) in degC, and LE per time level.
    """
    arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in (T_air, h, q_abs, q_sink, T_deep)]
    if len({a.size for a in arrays}) != 1:
        raise ValueError("forcing arrays must all have n_steps + 1 entries")
    n = column.n_nodes
    S = np.zeros(n) if source is None else np.ascontiguousarray(source, dtype=np.float64)
    if S.shape != (n,):
        raise ValueError(f"source must have one entry per node ({n}), got shape {S.shape}")
    et_on = pt_factor is not None
    f_pt = np.zeros(arrays[0].size) if pt_factor is None else np.ascontiguousarray(pt_factor, float)
    if f_pt.shape != arrays[0].shape:
        raise ValueError("pt_factor must have n_steps + 1 entries like the forcing")
    if et_on and not (np.all(f_pt >= 0) and np.all(f_pt < 1)):
        raise ValueError("the Priestley-Taylor factor alpha s/(s + gamma) must be in [0, 1)")
    profiles, latent = _integrate(
        np.ascontiguousarray(column.heat_capacity, dtype=np.float64),
        np.ascontiguousarray(column.conductance, dtype=np.float64),
        float(beta),
        float(T_ref),
        np.ascontiguousarray(T_init, dtype=np.float64),
        float(dt),
        *arrays[:4],
        float(emissivity) * STEFAN_BOLTZMANN,
        arrays[4],
        int(record_every),
        S,
        f_pt,
        et_on,
        1.0 if et_ground else 0.0,
    )
    return ColumnRun(profiles=profiles, latent=latent)


def integrate(
    column: Column,
    T_init: np.ndarray,
    dt: float,
    T_air: np.ndarray,
    h: np.ndarray,
    q_abs: np.ndarray,
    q_sink: np.ndarray,
    T_deep: np.ndarray,
    *,
    emissivity: float = 0.0,
    beta: float = 0.0,
    T_ref: float = 20.0,
    record_every: int = 1,
) -> np.ndarray:
    """March the column in time with BDF2 and return the recorded profiles.

    The parameters are those of :func:`march` (no source, no evapotranspiration).

    Returns
    -------
    (n_steps // record_every + 1, n_nodes) temperatures, degC.
    """
    return march(
        column,
        T_init,
        dt,
        T_air,
        h,
        q_abs,
        q_sink,
        T_deep,
        emissivity=emissivity,
        beta=beta,
        T_ref=T_ref,
        record_every=record_every,
    ).profiles


def point_source(z: np.ndarray, depth: float, flux: float) -> np.ndarray:
    """A heat source concentrated at ``depth``, shared by the two nodes around it.

    Parameters
    ----------
    z : (n_nodes,) node depths, m.
    depth : depth of the source, m (strictly inside the column).
    flux : power of the source per unit area, W m-2 (negative: a sink).

    Returns
    -------
    (n_nodes,) source per node control volume, W m-2: linear (hat-function) weights, so the
    total power and its centre of mass are exact.
    """
    if not z[0] <= depth < z[-1]:
        raise ValueError(f"source depth {depth} m must lie inside the column [0, {z[-1]}) m")
    i = int(np.searchsorted(z, depth, side="right")) - 1
    w = (depth - z[i]) / (z[i + 1] - z[i])
    out = np.zeros(z.size)
    out[i] = (1.0 - w) * flux
    out[i + 1] = w * flux
    return out


def conductive_flux(
    column: Column, profiles: np.ndarray, depths: np.ndarray, beta: float = 0.0, T_ref: float = 20.0
) -> np.ndarray:
    """Conductive heat flux -kappa dT/dx at given depths, W m-2, positive downward.

    Parameters
    ----------
    column : the discretised column.
    profiles : (n_times, n_nodes) temperatures, degC.
    depths : (n_depths,) depths, m, in ``[0, L]``.
    beta, T_ref : temperature dependence of kappa as in :func:`march` (1/K, degC).

    Returns
    -------
    (n_times, n_depths) fluxes: the finite-volume face fluxes ``K_i (T_i - T_i+1)`` (exact
    conservation at the cell mid-points) interpolated linearly to each depth; constant
    extrapolation above the first and below the last mid-point.
    """
    profiles = np.atleast_2d(profiles)
    K = column.conductance * (1.0 + beta * (0.5 * (profiles[:, :-1] + profiles[:, 1:]) - T_ref))
    faces = K * (profiles[:, :-1] - profiles[:, 1:])
    mid = 0.5 * (column.z[:-1] + column.z[1:])
    return np.stack([np.interp(depths, mid, row) for row in faces])
