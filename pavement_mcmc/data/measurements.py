"""The in-memory form of a case's measurements (what every downstream module consumes)."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field, replace

import numpy as np


@dataclass(frozen=True)
class Measurements:
    """Validated measurements of one case, in SI units and degC.

    Attributes
    ----------
    t : (n_obs,) seconds since the window start; strictly increasing, ``t[0] == 0``.
    time0 : ISO 8601 UTC time of ``t == 0``.
    T_air : (n_obs,) air temperature, degC.
    q_net : (n_obs,) net radiation, W m-2, positive into the ground.
    wind : (n_obs,) wind speed, m s-1, or None.
    rain : (n_obs,) precipitation, mm per step, or None.
    depths : (n_sensors,) depths of the observed sensors, m, increasing.
    T_obs : (n_obs, n_sensors) observed temperatures, degC.
    bottom_depth : depth of the Dirichlet boundary sensor, m (deeper than every observed one).
    T_bottom : (n_obs,) temperature at ``bottom_depth``, degC.
    sigma : measurement noise standard deviation, degC.
    source : where the data came from (CSV path).
    fill_report : gaps filled by interpolation, as ``(column, first_row, last_row)`` tuples.
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

    @property
    def n_obs(self) -> int:
        return int(self.t.size)

    @property
    def n_sensors(self) -> int:
        return int(self.depths.size)

    @property
    def sensor_labels(self) -> list[str]:
        """Labels such as ``'0cm'`` for each observed sensor."""
        return [f"{d * 100:g}cm" for d in self.depths]

    def initial_profile(self, x: np.ndarray) -> np.ndarray:
        """Initial temperature at depths ``x`` (m): linear interpolation of every sensor at t = 0."""
        z = np.append(self.depths, self.bottom_depth)
        T = np.append(self.T_obs[0], self.T_bottom[0])
        return np.interp(x, z, T)

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
            T_bottom=self.T_bottom[rows],
        )

    def data_hash(self) -> str:
        """SHA-256 over the numerical content, so a stored run can refuse changed data."""
        h = hashlib.sha256()
        for arr in (self.t, self.T_air, self.q_net, self.depths, self.T_obs, self.T_bottom):
            h.update(np.ascontiguousarray(arr, dtype=np.float64).tobytes())
        for arr in (self.wind, self.rain):
            h.update(b"none" if arr is None else np.ascontiguousarray(arr, float).tobytes())
        h.update(repr((float(self.bottom_depth), float(self.sigma))).encode())
        return h.hexdigest()
