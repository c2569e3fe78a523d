"""The in-memory form of a case's measurements (what every downstream module consumes)."""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType

import numpy as np


@dataclass(frozen=True)
class Measurements:
    """Validated measurements of one case, in SI units and degC.

    Attributes
    ----------
    t : (n_obs,) seconds since the window start; strictly increasing, ``t[0] == 0``.
    time0 : ISO 8601 UTC time of ``t == 0``.
    T_air : (n_obs,) air temperature, degC (NaN where missing: only with a measured top).
    q_net : (n_obs,) net radiation, W m-2, positive into the ground (NaN likewise).
    wind : (n_obs,) wind speed, m s-1, or None.
    rain : (n_obs,) precipitation, mm per step, or None.
    depths : (n_sensors,) depths of the observed sensors, m, increasing.
    T_obs : (n_obs, n_sensors) observed temperatures, degC.
    bottom_depth : depth of the Dirichlet boundary sensor, m (deeper than every observed one).
    T_bottom : (n_obs,) temperature at ``bottom_depth``, degC.
    sigma : measurement noise standard deviation, degC.
    source : where the data came from (CSV path).
    fill_report : gaps filled by interpolation, as ``(column, first_row, last_row)`` tuples.
    flux_depths : (n_plates,) depths of heat-flux plates, m, increasing; or None.
    G_obs : (n_obs, n_plates) plate readings, W m-2, positive downward; or None.
    T_top : (n_obs,) temperature of a measured (Dirichlet) top boundary, degC, or None (the
        surface energy balance is the top): see :meth:`with_measured_top`.
    depth_offset : depth below the soil surface of the model's ``x = 0``, m (0, or the top
        sensor's depth with a measured top). Every depth in this object is below ``x = 0``;
        labels show the depth below the soil surface.
    extras : named optional series at the observation times, ``{role: (n_obs,) array}``
        (read-only mapping): ``T_surf_IR`` (infrared surface temperature, degC), ``RH`` (%),
        ``SW_in``, ``SW_out``, ``LW_in``, ``LW_out`` (W m-2, each positive in the direction its
        name says), ``LE``, ``H`` (measured turbulent fluxes, W m-2, upward) — from the case CSV
        or a second CSV merged on time (``[data] extras``); see
        :data:`pavement_mcmc.data.extras.EXTRA_ROLES`.
    midday : UTC clock hour (0-24) of the daily peak of ``q_net`` over every row of the file the
        window was cut from (:func:`~pavement_mcmc.data.times.daily_peak_hour`), so that every
        window, training part and forecast of one record share it; None if not known.
    """

    t: np.ndarray
    time0: str
    T_air: np.ndarray
    q_net: np.ndarray
    wind: np.ndarray | None
    rain: np.ndarray | None
    depths: np.ndarray
    T_obs: np.ndarray
    bottom_depth: float
    T_bottom: np.ndarray
    sigma: float
    source: str = ""
    fill_report: tuple = field(default_factory=tuple)
    flux_depths: np.ndarray | None = None
    G_obs: np.ndarray | None = None
    T_top: np.ndarray | None = None
    depth_offset: float = 0.0
    extras: Mapping[str, np.ndarray] = field(default_factory=lambda: MappingProxyType({}))
    midday: float | None = None

    @property
    def n_plates(self) -> int:
        return 0 if self.flux_depths is None else int(self.flux_depths.size)

    @property
    def plate_labels(self) -> list[str]:
        """Labels such as ``'G5cm'`` for each heat-flux plate."""
        if self.flux_depths is None:
            return []
        return [f"G{(d + self.depth_offset) * 100:g}cm" for d in self.flux_depths]

    @property
    def n_obs(self) -> int:
        return int(self.t.size)

    @property
    def n_sensors(self) -> int:
        return int(self.depths.size)

    @property
    def sensor_labels(self) -> list[str]:
        """Labels such as ``'0cm'`` for each observed sensor."""
        return [f"{(d + self.depth_offset) * 100:g}cm" for d in self.depths]

    def initial_profile(self, x: np.ndarray) -> np.ndarray:
        """Initial temperature at depths ``x`` (m): linear interpolation of every sensor at t = 0."""
        z = np.append(self.depths, self.bottom_depth)
        T = np.append(self.T_obs[0], self.T_bottom[0])
        if self.T_top is not None:
            z, T = np.append(0.0, z), np.append(self.T_top[0], T)
        return np.interp(x, z, T)

    def with_measured_top(self) -> Measurements:
        """The same data with the shallowest sensor as a measured (Dirichlet) top boundary.

        Depths are shifted so that ``x = 0`` is that sensor; the other sensors stay observed
        (at least one must remain); plates must lie at or below it (a plate at the top sensor's
        depth observes the flux the measured top lets in). The surface energy balance (air
        temperature, net radiation, h) no longer enters: temperatures alone then fix only the
        diffusivity kappa/C; kappa itself needs a flux observation or a prior.
        """
        if self.T_top is not None:
            return self
        if self.n_sensors < 2:
            raise ValueError("a measured top needs at least two observed sensors (the shallowest "
                             "becomes the boundary, the others are observed)")
        z0 = float(self.depths[0])
        fd = self.flux_depths
        if fd is not None and np.any(fd < z0 - 1e-9):  # a plate at the top: its flux in
            raise ValueError(f"heat-flux plates at {fd * 100} cm are above the measured top "
                             f"at {z0 * 100:g} cm")
        return replace(
            self, depths=self.depths[1:] - z0, T_obs=self.T_obs[:, 1:], bottom_depth=self.bottom_depth - z0,
            T_top=self.T_obs[:, 0], depth_offset=z0,
            flux_depths=None if fd is None else np.maximum(fd - z0, 0.0),
        )

    def select_rows(self, rows) -> Measurements:
        """The same case restricted to observation ``rows`` (must keep row 0, the initial state)."""
        rows = np.asarray(rows)
        if rows.size < 2 or rows[0] != 0 or np.any(np.diff(rows) <= 0):
            raise ValueError("select_rows needs increasing row indices starting at 0")

        def pick(a):
            return None if a is None else a[rows]

        return replace(
            self, t=self.t[rows], T_air=self.T_air[rows], q_net=self.q_net[rows],
            wind=pick(self.wind), rain=pick(self.rain), T_obs=self.T_obs[rows],
            T_bottom=self.T_bottom[rows], G_obs=pick(self.G_obs), T_top=pick(self.T_top),
            extras=MappingProxyType({k: v[rows] for k, v in self.extras.items()}),
        )

    def sensors_hash(self) -> str:
        """SHA-256 over what a comparison of fits scores: the times, the buried sensors' depths
        and readings, and sigma (not the forcing, plates or extras)."""
        h = hashlib.sha256()
        for arr in (self.t, self.depths, self.T_obs):
            h.update(np.ascontiguousarray(arr, dtype=np.float64).tobytes())
        h.update(repr(float(self.sigma)).encode())
        return h.hexdigest()

    def data_hash(self) -> str:
        """SHA-256 over the numerical content, so a stored run can refuse changed data."""
        h = hashlib.sha256()
        for arr in (self.t, self.T_air, self.q_net, self.depths, self.T_obs, self.T_bottom):
            h.update(np.ascontiguousarray(arr, dtype=np.float64).tobytes())
        for arr in (self.wind, self.rain):
            h.update(b"none" if arr is None else np.ascontiguousarray(arr, float).tobytes())
        h.update(repr((float(self.bottom_depth), float(self.sigma))).encode())
        if self.G_obs is not None:  # runs on data without plates keep their hash
            for arr in (self.flux_depths, self.G_obs):
                h.update(np.ascontiguousarray(arr, dtype=np.float64).tobytes())
        if self.T_top is not None:
            h.update(np.ascontiguousarray(self.T_top, dtype=np.float64).tobytes())
            h.update(repr(float(self.depth_offset)).encode())
        for name in sorted(self.extras):  # runs on data without extras keep their hash
            h.update(name.encode())
            h.update(np.ascontiguousarray(self.extras[name], dtype=np.float64).tobytes())
        return h.hexdigest()
