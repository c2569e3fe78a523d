r""""None of these": what the misfit follows when no catalogue entry explains it.

When the best candidate leaves the misfit well above the noise (refit RMSE above
:data:`~.entries.RMSE_NONE` sigma or residuals far from white) or when the only candidates that
help are fitted at a bound of their own parameters, the honest answer is that the missing effect
is not in the catalogue. This module says where the leftover residual lives and what it follows:

- the sensor with the largest RMSE and its neighbours (the one above and the one below);
- at each of them, the correlations r (and z with Bartlett's effective sample size, as in
  :mod:`.residuals`; a smooth leftover has few effective values, so the signal it follows is
  chosen by |r|) of the residual with the forcing and derived signals: the positive part of
  the net radiation ``q_net+``, ``T_air - T_s``, ``dT_s/dt``, wind, the sensor's own temperature
  and the time of day;
- and which hook of :class:`~pavement_mcmc.physics.Extension` an effect that follows the
  strongest of them would override, with a ten-line template.

Numbers only; the command line renders :meth:`Unexplained.text`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .residuals import ResidualReport

#: signals shown for the sensor and its neighbours, in this order
FOLLOWED = ("q_net+", "T_air-T_s", "dT_s/dt", "wind", "T_sensor", "tod_sin", "tod_cos", "q_net")

#: a leftover "follows" a signal when |r| reaches this (ranked by |r|, z shown beside it)
R_FOLLOWS = 0.3

#: the hook an effect that follows a signal would override, and why
HOOKS = {
    "q_net+": ("surface", "a daytime term of the surface energy balance (coeffs.q)"),
    "q_net": ("surface", "a term of the surface energy balance proportional to radiation (coeffs.q)"),
    "tod_sin": ("surface", "a flux with a daily rhythm at the surface (coeffs.q or coeffs.h)"),
    "tod_cos": ("surface", "a flux with a daily rhythm at the surface (coeffs.q or coeffs.h)"),
    "T_air-T_s": ("surface", "the exchange with the air (coeffs.h)"),
    "wind": ("surface", "a wind-dependent exchange (coeffs.h)"),
    "dT_s/dt": ("observe", "a sensor that responds late or smooths (the predicted series)"),
    "T_sensor": ("material", "a property that depends on temperature (coeffs.kappa, coeffs.C)"),
}

TEMPLATE = '''class MyEffect(Extension):          # pavement_mcmc.physics.Extension
    name = "my_effect"
    hint = "{why}"
    def parameters(self, meas):
        return [Parameter("a_my", 0.0, -10.0, 10.0, prior=Normal(0.0, 1.0))]
    def {hook}(self, {args}model):
        ...                             # {what}
# then: pavement-mcmc fit CASE.toml --add mymodule:MyEffect'''

_ARGS = {"surface": "coeffs, p, ", "material": "coeffs, p, ", "observe": "pred, T_nodes, p, "}


@dataclass
class Unexplained:
    """Where the leftover residual lives and what it follows.

    Attributes
    ----------
    why : the reasons no catalogue entry explains it (plain words).
    of : the fit analysed (``"base"`` or the best candidate's name).
    rmse_sigma : its overall RMSE in sigma; ``rho`` its pooled lag-1 autocorrelation.
    sensor : the label of the sensor with the largest RMSE; ``neighbours`` those next to it.
    sensor_rmse, sensor_mean : RMSE and mean residual per analysed sensor label, degC.
    correlations : sensor label -> signal -> (r, z).
    follows : the strongest (signal, r, z) at :attr:`sensor`.
    hook, template : the :class:`~pavement_mcmc.physics.Extension` hook to write and a template.
    hours, hours_share : clock hours (UTC) that hold most of the leftover's mean square at
        :attr:`sensor` (at most 8 of 24, together at least half) and that share; empty if the
        leftover is spread over the day.
    """

    why: list[str]
    of: str
    rmse_sigma: float
    rho: float
    sensor: str
    neighbours: list[str]
    sensor_rmse: dict[str, float]
    sensor_mean: dict[str, float]
    correlations: dict[str, dict[str, tuple[float, float]]]
    follows: tuple[str, float, float] | None
    hook: str
    template: str
    at_bound: dict[str, list[str]] = field(default_factory=dict)
    hours: list[int] = field(default_factory=list)
    hours_share: float = 0.0

    @property
    def steady(self) -> bool:
        """The leftover at :attr:`sensor` is mostly its mean (a steady offset)."""
        return abs(self.sensor_mean[self.sensor]) > 0.6 * self.sensor_rmse[self.sensor]

    def to_dict(self) -> dict:
        d = dict(self.__dict__)
        d["steady"] = self.steady
        d["correlations"] = {s: {k: {"r": r, "z": z} for k, (r, z) in c.items()}
                             for s, c in self.correlations.items()}
        return d

    def text(self) -> str:
        lines = ["None of these: no catalogue entry explains the misfit (" + "; ".join(self.why) + ")."]
        lines.append(f"What is left ({self.of} fit, RMSE {self.rmse_sigma:.2f} σ, lag-1 {self.rho:.2f}) "
                     f"is largest at {self.sensor}"
                     + (f" (neighbours {', '.join(self.neighbours)})" if self.neighbours else "") + ":")
        sensors = [self.sensor, *self.neighbours]
        lines.append(f"  {'signal':<12}" + "".join(f"{s:>16}" for s in sensors))
        for sig in FOLLOWED:
            if sig not in self.correlations[self.sensor]:
                continue
            row = "".join(_cell(*self.correlations[s][sig]) for s in sensors)
            lines.append(f"  {sig:<12}{row}")
        lines.append("  " + "".join(f"{s}: RMSE {self.sensor_rmse[s]:.3f}, mean "
                                    f"{self.sensor_mean[s]:+.3f} °C  " for s in sensors))
        if self.steady:
            lines.append(f"At {self.sensor} the leftover is mostly a steady offset (mean "
                         f"{self.sensor_mean[self.sensor]:+.3f} °C): a steady source or sink of heat "
                         "at depth, or a boundary temperature that is off, rather than a forcing the "
                         "model mishandles.")
        if self.hours:
            lines.append(f"At {self.sensor} the leftover is concentrated at {_hours(self.hours)} h "
                         f"UTC ({100 * self.hours_share:.0f} % of its mean square in {len(self.hours)} "
                         "of 24 hours): something that happens at those hours every day (shade, "
                         "irrigation, a schedule), which smooth daily signals do not follow; "
                         "a shadow at fixed clock hours is the shipped `shading` (--add shading, "
                         "with a law for h such as energy_balance: a free h(t) absorbs it).")
        if self.follows is not None:
            sig, r, z = self.follows
            lines.append(f"At {self.sensor} the residual follows {sig} most (r = {r:+.2f}, z = {z:+.1f}): "
                         f"an extension overriding `{self.hook}` ({HOOKS[sig][1]}) would model it, e.g.")
        else:
            lines.append("It follows none of the forcings strongly; an extension could start from:")
        lines.append(self.template)
        return "\n".join(lines)


def _hours(h: list[int]) -> str:
    return ", ".join(f"{x:02d}-{(x + 1) % 24:02d}" for x in h)


def concentration(rep: ResidualReport, k: int, max_hours: int = 8) -> tuple[list[int], float]:
    """Clock hours holding most of sensor ``k``'s residual mean square (see :class:`Unexplained`)."""
    hod = np.mod(np.arctan2(rep.signals["tod_sin"], rep.signals["tod_cos"]) * 12 / np.pi, 24.0)
    b = np.floor(hod + 1e-9).astype(int) % 24
    r2 = rep.residuals[:, k] ** 2
    ms = np.array([r2[b == h].mean() if np.any(b == h) else 0.0 for h in range(24)])
    if ms.sum() <= 0:
        return [], 0.0
    hot = [h for h in range(24) if ms[h] > 2.0 * ms.mean()]
    share = float(ms[hot].sum() / ms.sum()) if hot else 0.0
    if not hot or len(hot) > max_hours or share < 0.5:
        return [], 0.0
    return hot, share


def _cell(r: float, z: float) -> str:
    return f"{f'r={r:+.2f} z={z:+.1f}':>16}"


def unexplained(rep: ResidualReport, why: list[str], of: str = "base",
                at_bound: dict[str, list[str]] | None = None) -> Unexplained:
    """The "none of these" analysis of the residual report ``rep`` (of the fit ``of``)."""
    rm = np.array([s.rmse for s in rep.sensors])
    k = int(np.argmax(rm))
    nb = [j for j in (k - 1, k + 1) if 0 <= j < len(rep.sensors)]
    sensors = [rep.sensors[j] for j in (k, *nb)]
    corr = {s.label: {sig: s.correlations[sig] for sig in FOLLOWED if sig in s.correlations}
            for s in sensors}
    top = corr[sensors[0].label]
    follows = None
    if top:  # by |r|: the z of a smooth leftover is small by construction (few effective values)
        sig = max(top, key=lambda n: abs(top[n][0]))
        if abs(top[sig][0]) >= R_FOLLOWS:
            follows = (sig, float(top[sig][0]), float(top[sig][1]))
    hook, what = HOOKS[follows[0]] if follows else ("surface", "an extra flux at the surface")
    template = TEMPLATE.format(why=f"residual follows {follows[0]}" if follows else "describe it",
                               hook=hook, args=_ARGS[hook], what=what)
    hours, share = concentration(rep, k)
    return Unexplained(
        hours=hours, hours_share=share, why=why, of=of, rmse_sigma=rep.rmse_sigma, rho=rep.rho,
        sensor=sensors[0].label,
        neighbours=[s.label for s in sensors[1:]], sensor_rmse={s.label: s.rmse for s in sensors},
        sensor_mean={s.label: s.bias for s in sensors},
        correlations=corr, follows=follows, hook=hook, template=template, at_bound=at_bound or {},
    )
