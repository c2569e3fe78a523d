"""A corpus of named, reproducible twin datasets with the inversion settings to use on them.

Each :class:`Twin` pairs a :class:`~pavement_mcmc.synthetic.SyntheticSpec` (the independent
simulator: 0.25 mm / 5 s or 1 mm / 30 s, smooth PCHIP h(t), full surface energy balance) with
case-TOML settings for the inversion that deliberately differ from it (no inverse crime): a
5 mm grid and 60-180 s steps, its own h(t) discretisation (3 pieces, hourly pieces or one h
per interval with a smoothness prior) and Gaussian priors on kappa and C that are not centred
on the truth. Nothing is cached: :func:`write_twin` simulates (0.1-0.7 s per twin).

Categories:

- ``clean`` (:func:`clean_twins`): no hidden effect; seeds x h(t) shapes x h forms x priors x
  input noise. What a correct model should fit to within the noise.
- ``catalogue`` (:func:`catalogue_twins`): one effect the extension catalogue models (or will:
  ``surface_layer``, ``evapotranspiration``) at its default strength; a diagnosis should name it.
  ``radiation_factor`` is exactly confounded with a common scale of kappa, C and h: only the
  kappa / C priors can reveal it.
- ``off_catalogue`` (:func:`off_catalogue_twins`): an effect no extension models; a diagnosis
  should say "none of these" rather than name a wrong entry.
- ``field`` (:func:`field_twins`): grass-site geometry (2-50 cm, 30 min, 3-7 days, spring
  weather) with evapotranspiration and / or thatch and a 5 cm heat-flux plate.

>>> twin = get_twin("clean-paper-caseA-tight")
>>> case_toml = write_twin(twin, "twins/" + twin.name)   # then pavement_mcmc.data.load_case
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..data.toml_writer import to_toml
from .effects import EFFECTS, NEW_CATALOGUE_EFFECTS, OFF_CATALOGUE_EFFECTS, resolve_effects
from .io import write_case
from .settings import spec_overrides
from .simulate import PAPER_H_KNOTS, SyntheticSpec

__all__ = [
    "CATEGORIES",
    "Twin",
    "all_twins",
    "case_document",
    "catalogue_twins",
    "clean_twins",
    "field_twins",
    "forecast_twins",
    "get_twin",
    "off_catalogue_twins",
    "with_seed",
    "write_twin",
]

CATEGORIES = ("clean", "catalogue", "off_catalogue", "field")
"""Valid :attr:`Twin.category` values."""

SIGMA = 0.2
"""Temperature noise of every twin, degC."""

H_SHAPES = {
    "paper": PAPER_H_KNOTS,
    "flat": (10.0, 10.5, 9.5, 10.0, 10.5),
    "afternoon": (6.0, 9.0, 18.0, 12.0, 7.0),
    "wiggly": (12.0, 7.0, 15.0, 8.0, 13.0, 9.0, 14.0),
}
"""True h(t) knots (W m-2 K-1, evenly spaced over the window, PCHIP) of the clean twins."""

H_FORMS = {
    "caseA": {"kind": "pieces", "edges_hours": [0.0, 6.0, 18.0, 28.0]},
    "hourly": {"kind": "uniform", "n": 28},
    "caseC": {"kind": "per_interval", "smooth": True},
}
"""The inversion's h(t) discretisations for the 28 h twins (paper Case A, 1 h pieces, Case C)."""

INVERSION_GRID = {"dx": 0.005, "dt": 60.0, "scheme": "cn"}
"""The inversion's grid for the 0-5 cm twins (20 times coarser in space than the simulator)."""

FIELD_GRID = {"dx": 0.005, "dt": 180.0, "scheme": "cn"}
"""The inversion's grid for the field twins (0-50 cm, 30 min rows)."""

FIELD = {
    "kappa": 1.2,
    "C": 2.6e6,
    "step_minutes": 30.0,
    "depths_cm": (2.0, 5.0, 10.0, 20.0),
    "bottom_cm": 50.0,
    "column_cm": 100.0,
    "climate": "spring",
    "time0": "2020-04-01T00:00:00Z",
    "flux_depths_cm": (5.0,),
}
"""Grass-site geometry and ground of the field twins (moist loam under grass, early April)."""

_FIELD_H_DIURNAL = (8.0, 9.0, 14.0, 11.0)  # at 00, 06, 12, 18 h: breezier afternoons
_FIELD_H_DAY = (1.0, 1.15, 0.9, 1.05, 0.95, 1.1, 1.0, 0.9)  # day-to-day changes


def field_h_knots(hours: float) -> tuple[float, ...]:
    """True h(t) knots of a field twin every 6 h, W m-2 K-1: a diurnal cycle (8-14) times a
    day-to-day factor (0.9-1.15)."""
    n = int(round(hours / 6.0)) + 1
    return tuple(round(_FIELD_H_DIURNAL[k % 4] * _FIELD_H_DAY[(k // 4) % 8], 3) for k in range(n))


@dataclass(frozen=True)
class Twin:
    """One named twin dataset and the inversion settings meant for it.

    Attributes
    ----------
    name : unique name (also a good folder name).
    spec : what the simulator generates.
    inversion : case-TOML sections ``data`` (sigma, input_sigma?, observed_cm, bottom_cm),
        ``model`` (h, extensions), ``parameters`` (priors), ``grid`` and ``sampler``; the
        data file names are added by :func:`write_twin`.
    category : one of :data:`CATEGORIES`.
    hidden : names of the hidden effects (the answer a diagnosis should give; empty: none).
    description : one line for the case file.
    """

    name: str
    spec: SyntheticSpec
    inversion: dict
    category: str
    hidden: tuple[str, ...] = ()
    description: str = ""

    def __post_init__(self):
        if self.category not in CATEGORIES:
            raise ValueError(
                f"twin {self.name!r}: category {self.category!r}; valid: {', '.join(CATEGORIES)}"
            )
        if tuple(self.spec.effects) != tuple(self.hidden):
            raise ValueError(
                f"twin {self.name!r}: hidden={self.hidden} but spec.effects={list(self.spec.effects)}"
            )


def _priors(kind: str, kappa: float, C: float, sign: int = 1) -> dict:
    """kappa and C priors: "loose" (1.5 +- 0.5 W m-1 K-1, 1.5e6 +- 0.5e6 J m-3 K-1) or "tight"
    (+-5 % of the truth, centred 3 % off it in the direction ``sign``)."""
    if kind == "loose":
        return {
            "kappa": {"prior": {"dist": "truncnormal", "mean": 1.5, "sd": 0.5}},
            "C": {"prior": {"dist": "truncnormal", "mean": 1.5e6, "sd": 0.5e6}},
        }
    if kind == "field":  # loam-like literature values, not centred on the truth
        return {
            "kappa": {"prior": {"dist": "truncnormal", "mean": 1.4, "sd": 0.4}},
            "C": {"prior": {"dist": "truncnormal", "mean": 2.3e6, "sd": 0.5e6}},
        }
    off = 1.0 + 0.03 * sign
    return {
        "kappa": {
            "prior": {"dist": "truncnormal", "mean": round(off * kappa, 6), "sd": round(0.05 * kappa, 6)}
        },
        "C": {"prior": {"dist": "truncnormal", "mean": round(off * C, 1), "sd": round(0.05 * C, 1)}},
    }


def _h_settings(h: dict) -> tuple[dict, dict]:
    """(parameters for h, sampler) that go with an h discretisation (as in runs/case*.toml)."""
    if h["kind"] == "per_interval" and h.get("smooth", True):
        params = {
            "h": {"value": 10.0, "prior": {"dist": "flat"}},
            "gamma": {"prior": {"dist": "rayleigh", "scale": 2.22}},
        }
        sampler = {"kind": "hmc", "n_walkers": 16, "seed": 1, "ess_target": 1000, "max_seconds": 1800}
        return params, sampler
    params = {"h": {"lower": 0.0, "prior": {"dist": "truncnormal", "mean": 10.0, "sd": 5.0}}}
    return params, {"kind": "fast", "seed": 1, "ess_target": 1000, "max_seconds": 600}


def _inversion(spec: SyntheticSpec, h: dict, priors: dict, grid: dict, input_sigma: bool) -> dict:
    h_params, sampler = _h_settings(h)
    data = {"sigma": spec.sigma}
    if input_sigma:
        data["input_sigma"] = spec.sigma
    data["observed_cm"] = [float(d) for d in spec.depths_cm]
    data["bottom_cm"] = float(spec.bottom_cm)
    return {
        "data": data,
        "model": {"h": copy.deepcopy(h), "extensions": []},
        "parameters": {**priors, **h_params},
        "grid": dict(grid),
        "sampler": sampler,
    }


def clean_twins() -> list[Twin]:
    """24 twins without hidden effects on the paper's geometry (0-4 cm observed, 5 cm bottom,
    15 min, 28 h, kappa 1.31, C 0.99e6): 4 h(t) shapes x 3 h forms x 2 prior widths, the
    bottom / initial noise integrated out (``input_sigma = sigma``) in half of them, balanced
    over every shape, form and prior; each twin has its own seed (101...)."""
    twins = []
    for i_shape, (shape, knots) in enumerate(H_SHAPES.items()):
        for i_form, (form, h) in enumerate(H_FORMS.items()):
            for i_prior, prior in enumerate(("loose", "tight")):
                k = len(twins)
                input_sigma = (i_shape + i_form + i_prior) % 2 == 0
                spec = SyntheticSpec(seed=101 + k, sigma=SIGMA, h_knots=knots)
                priors = _priors(prior, spec.kappa, spec.C, sign=1 if k % 2 == 0 else -1)
                name = f"clean-{shape}-{form}-{prior}" + ("-insig" if input_sigma else "")
                twins.append(
                    Twin(
                        name=name,
                        spec=spec,
                        inversion=_inversion(spec, h, priors, INVERSION_GRID, input_sigma),
                        category="clean",
                        description=f"no hidden effect; true h: {shape}; model h: {form}; {prior} priors",
                    )
                )
    return twins


def _one_effect_twins(effects: tuple[str, ...], seeds: tuple[int, ...], category: str) -> list[Twin]:
    """One default-strength effect per twin on the paper's geometry, diagnosed with the detection
    matrix's settings: hourly h pieces, kappa / C priors +-5 % centred 3 % off the truth."""
    twins = []
    for effect in effects:
        for j, seed in enumerate(seeds):
            spec = SyntheticSpec(seed=seed, sigma=SIGMA, effects={effect: {}})
            priors = _priors("tight", spec.kappa, spec.C, sign=1 if j % 2 == 0 else -1)
            twins.append(
                Twin(
                    name=f"{category.replace('_', '-')}-{effect}-s{seed}",
                    spec=spec,
                    inversion=_inversion(spec, H_FORMS["hourly"], priors, INVERSION_GRID, False),
                    category=category,
                    hidden=(effect,),
                    description=f"hidden effect: {effect} at its default strength",
                )
            )
    return twins


def catalogue_twins() -> list[Twin]:
    """Each catalogue effect (the seven of :data:`EFFECTS`, plus ``surface_layer`` and
    ``evapotranspiration``) at default strength, seeds 11 and 12 (and 13 for the two new ones)."""
    return _one_effect_twins(EFFECTS, (11, 12), "catalogue") + _one_effect_twins(
        NEW_CATALOGUE_EFFECTS, (11, 12, 13), "catalogue"
    )


def off_catalogue_twins() -> list[Twin]:
    """``sensor_lag``, ``shading`` and ``buried_source`` at default strength, seeds 21-23."""
    return _one_effect_twins(OFF_CATALOGUE_EFFECTS, (21, 22, 23), "off_catalogue")


def field_twins() -> list[Twin]:
    """Grass-site twins (:data:`FIELD` geometry, spring weather, a 5 cm plate): 72 h with ET and
    thatch, ET only, thatch only, none (a control), and 7 days with ET and thatch whose plate
    reads 20 % low. The inversion: one h per 30 min interval with a smoothness prior (2 h pieces
    for the 7 days), loam-like priors, no input noise (``input_sigma`` on ~145 h values makes
    the inversion's problem set-up take minutes; noise on the 50 cm bottom reaches the 2-20 cm
    sensors strongly damped)."""
    both = {"evapotranspiration": {}, "surface_layer": {}}
    variants = [
        ("field-et-thatch-s201", 201, 72.0, both, 1.0),
        ("field-et-s202", 202, 72.0, {"evapotranspiration": {}}, 1.0),
        ("field-thatch-s203", 203, 72.0, {"surface_layer": {}}, 1.0),
        ("field-none-s204", 204, 72.0, {}, 1.0),
        ("field-et-thatch-7d-s205", 205, 168.0, both, 0.8),
    ]
    twins = []
    for name, seed, hours, effects, plate_factor in variants:
        knots = field_h_knots(hours)
        spec = SyntheticSpec(
            seed=seed,
            sigma=SIGMA,
            hours=hours,
            h_knots=knots,
            effects=effects,
            plate_factor=plate_factor,
            **FIELD,
        )
        if hours <= 72:
            h = {"kind": "per_interval", "smooth": True}
        else:
            h = {"kind": "uniform", "n": int(hours / 2)}
        priors = _priors("field", spec.kappa, spec.C)
        twins.append(
            Twin(
                name=name,
                spec=spec,
                inversion=_inversion(spec, h, priors, FIELD_GRID, False),
                category="field",
                hidden=tuple(effects),
                description=f"grass-site twin, {hours:g} h; hidden: {', '.join(effects) or 'none'}",
            )
        )
    return twins


_FC_H_DIURNAL = (8.0, 7.0, 9.0, 14.0, 16.0, 11.0)  # at 00, 04, ... 20 h: breezier afternoons
FORECAST_GRID = {"dx": 0.005, "dt": 120.0, "scheme": "cn"}
"""The inversion's grid for the forecast twins (30 min rows)."""
_FC_FIXED = ("seed", "sigma", "hours", "step_minutes", "h_knots", "effects", "rain")


def forecast_h_knots(hours: float, seed: int) -> tuple[float, ...]:
    """True h(t) knots every 4 h, W m-2 K-1: a diurnal cycle (7-16) times a day-to-day factor
    (0.85-1.15, drawn from ``seed``): tomorrow's h is like today's, not equal to it."""
    rng = np.random.default_rng(seed)
    days = rng.uniform(0.85, 1.15, int(hours // 24) + 2)
    n = int(round(hours / 4.0)) + 1
    return tuple(round(_FC_H_DIURNAL[k % 6] * days[k // 6], 3) for k in range(n))


def forecast_twins(effects: tuple[str, ...] = (), seeds=(501,), *, hours: float = 40.0,
                   input_sigma: bool = False, category: str | None = None,
                   params: dict[str, dict] | None = None,
                   spec: dict | None = None) -> list[Twin]:
    """Twins for the forecast rule of the criticism: ``hours`` of 30 min rows (the last quarter
    is held out), a diurnal h(t) that changes from day to day (:func:`forecast_h_knots`), a
    shower in the fitted and in the held-out part; the inversion in Case C form (one h per
    interval, smoothness prior), loose ("wide") kappa / C priors, ``input_sigma`` optional.
    One twin per effect (none: ``()`` gives clean twins) and seed; ``params`` overrides an
    effect's default parameters (``{"conductivity_temperature": {"kappa_beta": -0.015}}``),
    and ``spec`` other :class:`SyntheticSpec` settings (``{"et_available": "net"}``); the
    twin's name then ends in them."""
    twins = []
    params = params or {}
    spec = spec_overrides(spec, _FC_FIXED)
    for effect in effects or (None,):
        for seed in seeds:
            eff = {effect: dict(params.get(effect, {}))} if effect else {}
            tag = "".join(f"-{k}{v:.12g}" for k, v in eff.get(effect, {}).items())
            tag += "".join(f"-{k}-{v}" for k, v in spec.items())
            rain = ((9.0, 1.0, 4.0), (hours - 8.0, 1.0, 4.0))
            sp = SyntheticSpec(seed=seed, sigma=SIGMA, hours=hours, step_minutes=30.0,
                               h_knots=forecast_h_knots(hours, seed), effects=eff, rain=rain,
                               **spec)
            # an unknown or bad parameter raises here, not when the twin is simulated
            resolve_effects(eff, sp.kappa, sp.C, sp.depths_cm, sp.bottom_cm)
            cat = category or ("clean" if effect is None else
                               "off_catalogue" if effect in OFF_CATALOGUE_EFFECTS else "catalogue")
            inv = _inversion(sp, H_FORMS["caseC"], _priors("loose", sp.kappa, sp.C),
                             FORECAST_GRID, input_sigma)
            twins.append(Twin(name=f"forecast-{effect or 'clean'}-s{seed}{tag}", spec=sp, inversion=inv,
                              category=cat, hidden=(effect,) if effect else (),
                              description=f"forecast twin; hidden: {effect or 'none'}{tag}"))
    return twins


def all_twins() -> list[Twin]:
    """Every twin of the corpus, clean first."""
    return clean_twins() + catalogue_twins() + off_catalogue_twins() + field_twins()


def get_twin(name: str) -> Twin:
    """The twin called ``name``; ValueError listing the valid names if there is none."""
    twins = {t.name: t for t in all_twins()}
    if name not in twins:
        raise ValueError(f"unknown twin {name!r}; valid: {', '.join(twins)}")
    return twins[name]


def case_document(twin: Twin, csv: str = "measurements.csv", truth: str = "truth.json") -> dict:
    """The case TOML of a twin as a dict: name, description, its inversion settings and the
    data file names (relative to the case file)."""
    doc = {"name": twin.name, "description": twin.description or twin.name}
    inversion = copy.deepcopy(twin.inversion)
    inversion["data"] = {"csv": csv, "truth": truth, **inversion.get("data", {})}
    doc.update(inversion)
    return doc


def write_twin(twin: Twin, directory: str | Path) -> Path:
    """Simulate a twin and write ``measurements.csv``, ``truth.json`` and ``case.toml``.

    Parameters
    ----------
    twin : the twin.
    directory : output folder (created if needed).

    Returns
    -------
    Path of ``case.toml`` (load it with :func:`pavement_mcmc.data.load_case`; heat-flux plate
    columns ``G_<d>cm`` are outside the current CSV contract and are ignored with a warning).
    """
    directory = Path(directory)
    write_case(twin.spec, directory, name=twin.name)
    path = directory / "case.toml"
    header = f"# Twin {twin.name!r} ({twin.category}); hidden effects: {', '.join(twin.hidden) or 'none'}\n"
    path.write_text(header + to_toml(case_document(twin)))
    return path


def with_seed(twin: Twin, seed: int) -> Twin:
    """The same twin with another seed (weather, noise) and a name that says so."""
    return replace(twin, name=f"{twin.name}-seed{seed}", spec=replace(twin.spec, seed=seed))
