r"""Criticism against a flux tower: the measured sensible and latent heat ``H`` and ``LE``.

A record from a flux site (``[data] preset = "ameriflux"``, or ``H`` / ``LE`` columns in the
case CSV or the ``[data] extras`` CSV, W m-2, leaving the surface) holds an independent
measurement of the energy the surface balance partitions. Neither is fitted; both are scored:

- **An energy-balance fit** (``energy_balance``) implies H and LE
  (:func:`~pavement_mcmc.physics.catalogue.energy.energy_partition`): :func:`tower_check`
  gives each flux's RMSE and bias against the tower and its midday share of the net radiation,
  implied and measured.
- **Any fit** sends a heat flux G into the ground: the tower leaves :math:`R_n - H - LE` for it
  (:func:`tower_ground_share`, used by :mod:`.energy`).

A tower does not close the balance: its H + LE is typically 70-90 % of :math:`R_n - G` (eddy
covariance misses large eddies and storage). So the midday share a tower measures is read as
a range, from its raw value to the value with the balance closed at the tower's own Bowen ratio
(``closed``: raw / closure, as FLUXNET's ``LE_CORR``), widened by :data:`TOL` of the net
radiation for the tower's random error. An implied share inside the range agrees with the
tower. ``closure`` is :math:`(H + LE) / (R_n - G)` summed over the midday rows (R_n above half
its maximum), with the fit's G: since the fit's own H + LE is :math:`R_n - G`, it is the
tower's turbulent flux over the fit's, so it is held to :data:`CLOSURE` before the range is
drawn (else the closed shares would be the fit's own total split at the tower's Bowen ratio,
and a fit that sends too much or too little into the ground would always agree). A flux with
no measurement at midday is left out.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: the turbulent fluxes a tower measures (roles of ``Measurements.extras``)
FLUXES = ("H", "LE")
#: a midday share agrees with the tower's within this fraction of R_n beyond its closure range
TOL = 0.1
#: the closures a tower is read with: the fit's implied closure is held to this range
CLOSURE = (0.7, 1.0)


def tower_fluxes(meas) -> dict[str, np.ndarray]:
    """The tower's ``H`` and ``LE`` in ``meas.extras`` (those present with any value)."""
    return {k: np.asarray(meas.extras[k], float) for k in FLUXES
            if k in meas.extras and np.isfinite(meas.extras[k]).any()}


def midday_rows(Rn: np.ndarray) -> np.ndarray:
    """Rows where the net radiation exceeds half its maximum."""
    return Rn > 0.5 * max(float(np.nanmax(Rn)), 1e-9)


def tower_ground_share(meas, G=None):
    r"""The share of the net radiation at midday the tower leaves for the ground,
    :math:`\sum (R_n - H - LE) / \sum R_n` over the midday rows where both are measured (an
    upper bound of the true share when the tower misses turbulent flux); None without both.
    With a fit's ground flux ``G`` (n_obs,): ``(tower's share, the fit's \sum G / \sum R_n over
    the same rows)``, or None."""
    fx = tower_fluxes(meas)
    if set(fx) != set(FLUXES):
        return None
    Rn = np.asarray(meas.q_net, float)
    rows = midday_rows(Rn) & np.isfinite(fx["H"]) & np.isfinite(fx["LE"])
    if not rows.any():
        return None
    tower = float(np.sum(Rn[rows] - fx["H"][rows] - fx["LE"][rows]) / np.sum(Rn[rows]))
    if G is None:
        return tower
    return tower, float(np.sum(np.asarray(G, float)[rows]) / np.sum(Rn[rows]))


@dataclass
class TowerCheck:
    """An energy-balance fit's H and LE against the tower (module doc).

    Attributes
    ----------
    fluxes : per flux (``"H"``, ``"LE"``): ``rmse`` and ``bias`` (implied - measured, W m-2,
        rows with a measurement), ``implied`` and ``measured`` midday shares of R_n, the tower's
        share with its balance closed (``closed``), ``agrees``.
    closure : the tower's (H + LE) / (R_n - G) at midday, G the fit's (None without both).
    """

    fluxes: dict = field(default_factory=dict)
    closure: float | None = None

    @property
    def agrees(self) -> bool:
        return all(v["agrees"] for v in self.fluxes.values())

    def to_dict(self) -> dict:
        return {"fluxes": self.fluxes, "closure": self.closure, "agrees": self.agrees}

    def text(self) -> str:
        """One line a micrometeorologist reads."""
        parts = []
        for k, v in self.fluxes.items():
            rng = sorted((v["measured"], v["closed"]))
            parts.append(f"{k}/Rn {v['implied']:.2f} against the tower's {rng[0]:.2f}"
                         + (f"-{rng[1]:.2f}" if rng[1] - rng[0] >= 0.005 else "")
                         + f" ({'agrees' if v['agrees'] else 'DISAGREES'}; RMSE "
                         f"{v['rmse']:.0f} W m-2, bias {v['bias']:+.0f})")
        clo = ("" if self.closure is None else
               f"; the tower closes {100 * self.closure:.0f} % of Rn - G (the fit's G)"
               + ("" if CLOSURE[0] <= self.closure <= CLOSURE[1] else
                  f", read at the nearer of {100 * CLOSURE[0]:.0f}-{100 * CLOSURE[1]:.0f} %"))
        return ("flux tower at midday (not fitted; agrees: within its closure range +-"
                f"{TOL:g} Rn): " + "; ".join(parts) + clo)


def tower_check(partition, meas) -> TowerCheck | None:
    """The implied H and LE of ``partition`` (a
    :class:`~pavement_mcmc.physics.catalogue.energy.Partition`, the median over its sets)
    against the tower's in ``meas``; None when the record has neither at midday."""
    fx = tower_fluxes(meas)
    if not fx:
        return None
    Rn = np.asarray(partition.Rn[0], float)
    implied = {k: np.median(getattr(partition, k), axis=0) for k in FLUXES}
    G = np.median(partition.G + (0.0 if partition.off is None else partition.off), axis=0)
    mid = midday_rows(Rn)
    closure = None
    if set(fx) == set(FLUXES):
        both = mid & np.isfinite(fx["H"]) & np.isfinite(fx["LE"])
        if both.any():
            closure = float(np.sum(fx["H"][both] + fx["LE"][both]) / np.sum(Rn[both] - G[both]))
    out = TowerCheck(closure=closure)
    held = None if closure is None else min(max(closure, CLOSURE[0]), CLOSURE[1])
    for k, meas_k in fx.items():
        ok = np.isfinite(meas_k)
        rows = mid & ok
        if not rows.any():  # nothing measured at midday: no share to compare
            continue
        d = implied[k][ok] - meas_k[ok]
        share_i = float(np.sum(implied[k][rows]) / np.sum(Rn[rows]))
        share_m = float(np.sum(meas_k[rows]) / np.sum(Rn[rows]))
        closed = share_m / held if held is not None else share_m
        lo, hi = min(share_m, closed) - TOL, max(share_m, closed) + TOL
        out.fluxes[k] = {"rmse": float(np.sqrt(np.mean(d**2))), "bias": float(np.mean(d)),
                         "implied": share_i, "measured": share_m, "closed": float(closed),
                         "agrees": bool(lo <= share_i <= hi)}
    return out if out.fluxes else None


def fit_tower(fit) -> dict | None:
    """:func:`tower_check` of a MAP refit (:class:`~.fitting.Fit`) of a model with an energy
    balance, as a dict (:meth:`TowerCheck.to_dict`); None without a tower."""
    from ..physics.catalogue.energy import energy_partition

    pb = fit.problem
    if not tower_fluxes(pb.meas):
        return None
    v = {**pb.space.value_dict(), **fit.values()}
    tc = tower_check(energy_partition(pb.model, {k: np.array([x]) for k, x in v.items()}), pb.meas)
    return None if tc is None else {**tc.to_dict(), "text": tc.text()}
