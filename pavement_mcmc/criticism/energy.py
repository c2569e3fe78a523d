"""Criticism of the surface energy balance: is the energy the model pushes into the ground right?

A model whose top is the surface energy balance sends ``h (T_air - T_s) + q_net`` into the
ground. Over grass or wet ground most of the net radiation leaves as evapotranspiration
instead; a model without such a sink compensates with an absurd kappa and C while kappa/C stays
right. Three numbers tell the surface boundary apart from the conduction below it:

1. the fitted ground heat flux at the surface and its share of the net radiation at midday
   (over grass typically 5-20 %, bare soil 20-40 %, pavement 30-60 %), and whether the fit's
   kappa, C or h is physically impossible (an h beyond forced convection of air is the free
   h(t) standing in for a flux that is not convection);
2. a fit with the shallowest sensor as a measured top (no surface balance at all): its
   kappa/C is the conduction's own answer, and with a heat-flux plate its kappa too;
3. the fitted flux at each plate against the plate's readings;
4. with a flux tower's H and LE in the record, the share of the net radiation they leave for
   the ground, R_n - H - LE, at midday (:func:`.tower.tower_ground_share`): an upper bound of
   the true share, since towers miss part of the turbulent flux; a fit that pushes more than
   :data:`.tower.TOL` of R_n beyond it into the ground is wrong at the surface.

If the full fit's kappa/C agrees with the measured-top fit's but its kappa (or its flux at the
plate) does not, conduction is fine and the surface boundary is what is wrong.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace

import numpy as np

from ..data import load_case, merge_overrides
from ..physics.materials import check_values, declared_material
from ..posterior import build_problem
from ..posterior.surface_ir import PARAMETER_NAMES as IR_PARAMETERS
from .fitting import refit
from .ground import ground_extensions
from .tower import TOL, tower_ground_share

#: shares of the net radiation that reach the ground at midday, by surface (Oke 1987, ch. 2-4)
MIDDAY_SHARE = {"grass or crop": (0.05, 0.2), "bare soil": (0.2, 0.4), "pavement": (0.3, 0.6)}
#: the full and the measured-top fits agree on kappa/C within this relative difference
AGREE = 0.2


@dataclass
class EnergyBalance:
    """The surface energy balance of a fit (see the module docstring).

    Attributes
    ----------
    G_surface : (n_obs,) fitted heat flux into the ground at the top, W m-2.
    midday_share : median of ``G_surface / q_net`` where ``q_net`` exceeds half its maximum.
    diffusivity : kappa/C of the fit, m2 s-1; ``kappa`` its conductivity.
    top : kappa, C, kappa/C of the measured-top MAP fit (None when it could not be made).
    plates : per plate label: ``{"slope": the model's conductive flux at the plate regressed on
        the reading, "factor": the fitted calibration factor, "rmse": of the fitted reading}``.
    findings : the fit's estimates outside plausible ranges.
    verdict : plain words.
    tower_share : the share of R_n at midday a flux tower's H and LE leave for the ground
        (None without a tower); ``fit_share`` the fit's G over the same rows, as a ratio of sums
        like it (what the tower alarm compares).
    """

    G_surface: np.ndarray
    midday_share: float
    diffusivity: float
    kappa: float
    top: dict | None
    plates: dict = field(default_factory=dict)
    findings: list = field(default_factory=list)
    verdict: str = ""
    tower_share: float | None = None
    fit_share: float | None = None

    @property
    def surface_wrong(self) -> bool:
        """Conduction agrees with the measured-top fit, the energy into the ground does not."""
        return self.verdict.startswith("The surface boundary")

    def to_dict(self) -> dict:
        return {"midday_share": self.midday_share, "diffusivity": self.diffusivity,
                "kappa": self.kappa, "top": self.top, "plates": self.plates,
                "findings": [f.text() for f in self.findings], "verdict": self.verdict,
                "surface_wrong": self.surface_wrong, "tower_share": self.tower_share}

    def text(self) -> str:
        lines = [f"fitted ground heat flux at midday: {100 * self.midday_share:.0f} % of net "
                 "radiation (" + ", ".join(f"{k} {100 * a:.0f}-{100 * b:.0f} %"
                                           for k, (a, b) in MIDDAY_SHARE.items()) + ")"]
        lines.append(f"kappa/C of this fit {self.diffusivity * 1e6:.3g} mm2/s, kappa "
                     f"{self.kappa:.3g} W/m/K")
        if self.top is not None:
            lines.append(f"measured-top fit (shallowest sensor as boundary, no surface balance): "
                         f"kappa/C {self.top['diffusivity'] * 1e6:.3g} mm2/s"
                         + (f", kappa {self.top['kappa']:.3g} W/m/K (from the plate)"
                            if self.top.get("from_plate") else ""))
        for lab, v in self.plates.items():
            lines.append(f"plate {lab}: the model's conductive flux there = {v['slope']:.2f} x the "
                         f"reading (fitted calibration factor {v['factor']:.2f}; plates read within "
                         f"+-20-30 %), RMSE {v['rmse']:.1f} W m-2")
        if self.tower_share is not None:
            lines.append(f"flux tower: R_n - H - LE at midday {100 * self.tower_share:.0f} % of net "
                         "radiation (an upper bound: towers miss part of H and LE)")
        lines += [f.text() for f in self.findings]
        lines.append(self.verdict)
        return "\n".join(lines)


def energy_balance(problem, values: dict[str, float], *, top_fit: bool = True) -> EnergyBalance:
    """The energy balance of ``problem`` at the point ``values`` (see the module docstring).

    ``top_fit`` also fits the measured-top model by MAP (a few seconds: kappa, C and the plate
    factors); it needs at least two observed sensors and a surface-balance model.
    """
    model = problem.model
    space = problem.space
    vals = {**space.value_dict(), **{k: float(v) for k, v in values.items() if k in space}}
    p = {k: np.array([v]) for k, v in vals.items()}
    coeffs = model.coefficients(p)
    T_nodes = model.solve(p)
    G = model.surface_flux(T_nodes, coeffs)[0]
    q = np.asarray(model.meas.q_net, float)
    day = q > 0.5 * max(float(q.max()), 1e-9)
    share = float(np.median(G[day] / q[day])) if day.any() else float("nan")
    kappa, C = vals["kappa"], vals["C"]
    plates = {}
    if model.plates:
        Gp = model.observe_flux(T_nodes, coeffs, p)[0]
        for j, (lab, name) in enumerate(zip(model.meas.plate_labels, model.plate_names, strict=True)):
            obs = model.meas.G_obs[1:, j]
            fit = Gp[1:, j] / vals[name]  # the conduction's flux at the plate, factor taken out
            slope = float(fit @ obs / max(float(obs @ obs), 1e-12))
            plates[lab] = {"slope": slope, "factor": vals[name],
                           "rmse": float(np.sqrt(np.mean((Gp[1:, j] - obs) ** 2)))}
    top = None
    if top_fit and not model.top_measured and model.meas.n_sensors >= 2:
        top = _top_fit(problem)
    h = [vals[n] for n in space.free if space[n].group == "h"]
    declared = declared_material(problem)
    findings = check_values(kappa, C, h or None, declared)
    tower, fit_share = tower_ground_share(model.meas, G) or (None, None)
    eb = EnergyBalance(G, share, kappa / C, kappa, top, plates, findings, tower_share=tower,
                       fit_share=fit_share)
    eb.verdict = _verdict(eb)
    return eb


def _top_fit(problem) -> dict | None:
    """MAP of the same case with the shallowest sensor as a measured top boundary (the
    extensions that act below the surface kept)."""
    cfg = problem.cfg
    if not hasattr(cfg, "path"):
        return None
    try:
        top_cfg = load_case(cfg.path, merge_overrides(cfg.raw, {"model": {"top": "measured"}}))
    except (ValueError, OSError):
        return None
    raw = copy.deepcopy(top_cfg.raw)
    for key in ("ir_sigma", "ir_storage_free"):  # the IR sees the surface: none under a measured top
        raw["data"].pop(key, None)
    for name in IR_PARAMETERS:  # nor its parameters, which a case may set
        raw.get("parameters", {}).pop(name, None)
    top_cfg = replace(top_cfg, raw=raw)
    exts = ground_extensions(problem.model)
    pb = build_problem(top_cfg, extensions=exts)
    f = refit(pb).values()
    return {"kappa": f["kappa"], "C": f["C"], "diffusivity": f["kappa"] / f["C"],
            "from_plate": pb.model.plates}


def _verdict(eb: EnergyBalance) -> str:
    alarms = [f for f in eb.findings if f.level == "alarm" and f.quantity in ("kappa", "C")]
    h_alarm = [f for f in eb.findings if f.level == "alarm" and f.quantity == "h"]
    plate_off = [lab for lab, v in eb.plates.items() if not 0.6 <= v["slope"] <= 1.6]
    off = None if eb.top is None else eb.diffusivity / eb.top["diffusivity"] - 1.0
    kappa_off = (eb.top is not None and eb.top.get("from_plate")
                 and not 0.5 <= eb.kappa / eb.top["kappa"] <= 2.0)
    fit = eb.midday_share if eb.fit_share is None else eb.fit_share
    tower_off = eb.tower_share is not None and fit > eb.tower_share + TOL
    if alarms or plate_off or kappa_off or h_alarm or tower_off:
        why = []
        if tower_off:
            why.append(f"the fit pushes {100 * fit:.0f} % of the midday net radiation "
                       f"into the ground where the flux tower's H and LE leave at most "
                       f"{100 * eb.tower_share:.0f} %")
        if alarms:
            why.append("kappa or C is physically impossible")
        if h_alarm:
            why.append(f"the free h(t) reaches {h_alarm[0].value:.0f} W m-2 K-1, beyond forced "
                       "convection of air: it stands in for a flux that is not convection")
        if kappa_off:
            why.append(f"kappa {eb.kappa:.3g} against {eb.top['kappa']:.3g} from the measured top "
                       "and the plate")
        if plate_off:
            why.append(f"the model's flux at {', '.join(plate_off)} is "
                       + ", ".join(f"{eb.plates[lab]['slope']:.2g}" for lab in plate_off)
                       + " x the plate's reading")
        cond = ("conduction is fine (kappa/C agrees with the measured-top fit within "
                f"{100 * abs(off):.0f} %) but " if off is not None and abs(off) <= AGREE else
                "" if off is None else
                f"kappa/C also differs from the measured-top fit's by {100 * abs(off):.0f} % and ")
        only_plates = plate_off and not (alarms or h_alarm or kappa_off or tower_off)
        slopes = [eb.plates[lab]["slope"] for lab in plate_off]
        if only_plates and all(x <= 0.0 for x in slopes):
            end = (". The plates read against the model's flux: a plate's sign or polarity (a "
                   "flux positive upward, or its wires swapped).")
        elif only_plates and all(0.0 < x < 1.0 for x in slopes):
            end = (". The model takes less heat into the ground than the plates read: the "
                   "plates' depth or calibration, or a surface balance that lets too little in "
                   "(a sink or a surface resistance too strong, a heat source it misses).")
        else:
            end = (". The energy the model pushes into the ground is wrong: the surface energy "
                   "balance lacks a sink or a resistance (evapotranspiration, the partition of "
                   "the net radiation, a surface layer of grass, thatch or mulch).")
        return "The surface boundary is wrong: " + cond + "; ".join(why) + end
    if off is not None and abs(off) > AGREE:
        return ("Conduction itself disagrees: kappa/C differs from the measured-top fit's by "
                f"{100 * abs(off):.0f} % (layers, sensor depths or a temperature-dependent "
                "conductivity, below the surface).")
    if eb.top is None and not eb.plates and eb.tower_share is None:
        return ("Nothing here says the energy entering the ground is wrong: kappa, C and h are "
                "possible (no measured-top fit, plate or flux tower checked it).")
    checks = [name for name, done in (("the measured-top fit", eb.top is not None),
                                       ("the plates", bool(eb.plates)),
                                       ("the flux tower", eb.tower_share is not None)) if done]
    return "The energy entering the ground is consistent with " + " and ".join(checks) + "."
