"""Physical plausibility: ranges of kappa, C and kappa/C of ground materials and of h.

An estimate outside the range of the material a case declares (``[model] material = "loam"``)
is a *note*; outside every ground material (e.g. C above the 4.18 MJ m-3 K-1 of water, which no
ground exceeds) it is an *alarm*: the model is then compensating for something it lacks, and
the criticism treats it as evidence of misspecification.

Ranges (kappa W m-1 K-1, C MJ m-3 K-1, kappa/C mm2 s-1), rounded outward from:

- [O87] Oke, T. R. (1987), *Boundary Layer Climates*, 2nd ed., Table 2.1 (thermal properties of
  natural materials: sandy and clay soils dry to saturated, peat, snow, water, asphalt,
  concrete);
- [H98] Hillel, D. (1998), *Environmental Soil Physics*, ch. 12 (soil heat capacity from its
  constituents, conductivity against water content);
- [F81] Farouki, O. T. (1981), *Thermal properties of soils*, CRREL Monograph 81-1;
- [I07] Incropera, DeWitt, Bergman & Lavine (2007), *Fundamentals of Heat and Mass Transfer*,
  6th ed., Table 1.1 (convection coefficients) and Table A.3 (asphalt, concrete);
- and the project's DESIGN.md summary of them.

The kappa/C bounds are the quotient bounds of each material, narrowed where the sources give the
diffusivity directly (moist loam and clay 0.3-0.8 mm2 s-1 [O87, H98]).
"""

from __future__ import annotations

from dataclasses import dataclass

#: the largest volumetric heat capacity of any ground: water, 4.18 MJ m-3 K-1
C_WATER = 4.18e6


@dataclass(frozen=True)
class Material:
    """Plausible ranges of one ground material (SI units: W m-1 K-1, J m-3 K-1, m2 s-1)."""

    name: str
    kappa: tuple[float, float]
    C: tuple[float, float]
    diffusivity: tuple[float, float]
    source: str


MATERIALS: dict[str, Material] = {m.name: m for m in (
    Material("asphalt", (0.7, 2.0), (1.6e6, 2.4e6), (0.3e-6, 1.0e-6), "O87, I07"),
    Material("concrete", (1.0, 2.5), (1.8e6, 2.6e6), (0.4e-6, 1.3e-6), "O87, I07"),
    Material("dry sand", (0.2, 0.4), (1.2e6, 1.5e6), (0.13e-6, 0.33e-6), "O87, F81"),
    Material("moist sand", (1.0, 4.0), (2.0e6, 3.0e6), (0.4e-6, 1.6e-6), "O87, F81 (saturated quartz sand)"),
    Material("loam", (0.8, 1.8), (2.0e6, 3.2e6), (0.25e-6, 0.8e-6), "O87, H98"),
    Material("clay", (0.8, 1.6), (2.2e6, 3.4e6), (0.25e-6, 0.7e-6), "O87, H98"),
    Material("peat", (0.1, 0.5), (0.6e6, 3.8e6), (0.05e-6, 0.3e-6), "O87, F81"),
)}

#: the materials the paper's literature values (kappa 2.27, C 2.10 MJ, h 10) stand for
PAVEMENTS = ("asphalt", "concrete")

#: the union of every ground material above: outside it no ground has such a value
ANY_GROUND = Material(
    "any ground",
    (min(m.kappa[0] for m in MATERIALS.values()), max(m.kappa[1] for m in MATERIALS.values())),
    (min(m.C[0] for m in MATERIALS.values()), C_WATER),
    (min(m.diffusivity[0] for m in MATERIALS.values()),
     max(m.diffusivity[1] for m in MATERIALS.values())),
    "union of the materials; C capped at water's 4.18 MJ m-3 K-1",
)

#: surface heat transfer coefficient h, W m-2 K-1: free convection of air ~2-25, forced
#: convection of air 25-250 [I07]; outdoors over ground and pavement 2-60 is usual. Values up
#: to H_ALARM are physically possible (strong wind); above it h stands in for something else.
H_USUAL = (2.0, 60.0)
H_ALARM = 250.0


@dataclass(frozen=True)
class Finding:
    """One estimate outside a plausible range.

    ``level`` is ``"note"`` (outside the declared material's range, or h unusual) or ``"alarm"``
    (outside every ground material, or h beyond forced convection).
    """

    level: str
    quantity: str
    value: float
    lo: float
    hi: float
    against: str

    def value_text(self) -> str:
        """The estimate with its unit, e.g. ``kappa = 12.7 W m-1 K-1``."""
        scale, unit = _UNITS[self.quantity]
        return f"{self.quantity} = {self.value * scale:.3g} {unit}"

    def text(self) -> str:
        scale, unit = _UNITS[self.quantity]
        return (f"{self.level.upper()}: {self.quantity} = {self.value * scale:.3g} {unit} is outside "
                f"{self.lo * scale:.3g}-{self.hi * scale:.3g} {unit} ({self.against})")


_UNITS = {"kappa": (1.0, "W m-1 K-1"), "C": (1e-6, "MJ m-3 K-1"),
          "kappa/C": (1e6, "mm2 s-1"), "h": (1.0, "W m-2 K-1")}


def material(name: str | None) -> Material | None:
    """The named material (None for None); ``ValueError`` listing the valid names otherwise."""
    if name is None:
        return None
    if name not in MATERIALS:
        raise ValueError(f"unknown material {name!r}; valid: {', '.join(MATERIALS)}")
    return MATERIALS[name]


def declared_material(problem) -> str | None:
    """The material a problem's case declares (``[model] material``), None if it declares none
    or has no case config."""
    model = getattr(problem.cfg, "model", None)
    return None if model is None else model.get("material")


def paper_values_apply(problem) -> bool:
    """Whether the paper's literature values (a pavement's) describe this case's ground: it is
    a pavement, or declares no material."""
    return declared_material(problem) in (None, *PAVEMENTS)


def check_values(kappa: float | None = None, C: float | None = None,
                 h: list[float] | None = None, declared: str | None = None) -> list[Finding]:
    """Findings for the ground's kappa and C (and their ratio) and for h values.

    Parameters
    ----------
    kappa, C : estimates (SI); None skips them.
    h : estimates of h (e.g. the posterior mean of every piece); alarms for values above
        :data:`H_ALARM`, notes for values outside :data:`H_USUAL`.
    declared : the case's material (``[model] material``), or None.
    """
    out: list[Finding] = []
    mat = material(declared)
    pairs = [("kappa", kappa), ("C", C)]
    if kappa is not None and C is not None and C > 0:
        pairs.append(("kappa/C", kappa / C))
    field = {"kappa": "kappa", "C": "C", "kappa/C": "diffusivity"}
    for qty, v in pairs:
        if v is None:
            continue
        lo, hi = getattr(ANY_GROUND, field[qty])
        if not lo <= v <= hi:
            out.append(Finding("alarm", qty, float(v), lo, hi, "every ground material"))
        elif mat is not None:
            lo, hi = getattr(mat, field[qty])
            if not lo <= v <= hi:
                out.append(Finding("note", qty, float(v), lo, hi, f"declared material {mat.name}"))
    if h is not None and len(h):
        hv = [float(x) for x in h]
        top = max(hv)
        if top > H_ALARM:
            out.append(Finding("alarm", "h", top, 0.0, H_ALARM, "beyond forced convection of air"))
        elif top > H_USUAL[1] or min(hv) < H_USUAL[0]:
            v = top if top > H_USUAL[1] else min(hv)
            out.append(Finding("note", "h", v, *H_USUAL, "usual outdoor range"))
    return out
