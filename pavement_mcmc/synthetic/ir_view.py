"""Grass-like twins seen by an infrared thermometer over a partial canopy, and their case: the
test of the IR stream's view (:mod:`pavement_mcmc.posterior.surface_ir`) and
``benchmarks/ir_view_twins.py``.

72 h of the field geometry (:data:`~.corpus.FIELD`: sensors 2-20 cm, bottom 50 cm, a 5 cm
plate; moist loam, spring weather), h from the wind (``wind_convection``), latent heat in the
Priestley-Taylor form on the simulator's R_n - G (the inversion's law takes max(R_n, 0)), and a
resolved thatch with its own heat capacity (``surface_layer``: 1.5 cm, R 0.25 m2 K W-1,
4.5 kJ m-2 K-1), not the inversion's lumped skin node. Two thermometers:

- :func:`ir_view_case`: it looks down into the thatch; ``view`` of its view is stopped in the
  layer (Beer's law, radiances averaged) and the rest reaches the soil surface below
  (``SyntheticSpec.ir_view``), + 1 degC, + N(0, 0.3 degC): a closed sward seen into its depth.
- :func:`tiled_case`: ``view`` of its footprint is the thatch's top and the rest a *bare*
  patch of the same soil under the same weather with its own energy balance (radiances
  averaged; the patch keeps the twin's latent heat, a moist bare soil): a sparse cover with
  sunlit gaps, which the inversion's form (a share of the skin and the rest the soil *under*
  the layer) does not describe. Its truth.json records the thatch's thermometer (view 1).

The case: ``energy_balance_window`` + ``canopy``, the IR at sd 0.5 (not the thermometer's 0.3)
with ``ir_view`` free, loose loam-like priors on kappa and C.
"""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np

from .corpus import FIELD
from .io import write_case
from .simulate import SyntheticSpec, simulate

__all__ = ["CASE_IR_SIGMA", "HELD", "IR_NOISE", "IR_OFFSET", "STORING_C", "ir_view_case",
           "storing_thatch_case", "tiled_case"]

IR_OFFSET, IR_NOISE = 1.0, 0.3
#: the IR sd the case declares (not the thermometer's)
CASE_IR_SIGMA = 0.5
#: volumetric heat capacity of :func:`storing_thatch_case`'s thatch, J m-3 K-1 (30 kJ m-2 K-1)
STORING_C = 2.0e6
#: overrides that hold the case's view at 1 (the footprint all canopy)
HELD = {"parameters": {"ir_view": {"vary": False, "value": 1.0}}}


def ir_view_case(directory: str | Path, view: float, seed: int,
                 thatch: dict | None = None, free: tuple = ("ir_view",)) -> tuple[Path, SyntheticSpec]:
    """Write the twin of ``view`` and ``seed`` and its ``case.toml`` into ``directory``; the
    TOML's path and the twin's spec (its truth). ``thatch``: the simulator's ``surface_layer``
    settings (default its own); ``free``: the stream parameters the case frees."""
    directory = Path(directory)
    spec = SyntheticSpec(seed=seed, sigma=0.1, hours=72.0,
                         effects={"wind_convection": {}, "evapotranspiration": {},
                                  "surface_layer": dict(thatch or {})},
                         ir_view=view, ir_offset=IR_OFFSET, ir_noise=IR_NOISE, **FIELD)
    csv_path = write_case(spec, directory)
    toml = directory / "case.toml"
    toml.write_text(f'[data]\ncsv = "{csv_path.name}"\nsigma = 0.1\nplates = true\n'
                    f'ir_sigma = {CASE_IR_SIGMA}\n'
                    '[model]\nextensions = ["energy_balance_window", "canopy"]\n'
                    '[parameters.kappa]\nvalue = 1.0\n'
                    'prior = { dist = "truncnormal", mean = 1.0, sd = 0.5 }\n'
                    '[parameters.C]\nvalue = 2.0e6\n'
                    'prior = { dist = "truncnormal", mean = 2.0e6, sd = 0.7e6 }\n'
                    + "".join(f"[parameters.{n}]\nvary = true\n" for n in free))
    return toml, spec


def storing_thatch_case(directory: str | Path, seed: int, layer_C: float = STORING_C,
                        free: tuple = ("ir_lead",)) -> tuple[Path, SyntheticSpec]:
    """As :func:`ir_view_case` with the thermometer reading the thatch's top (view 1), but a
    thatch that stores heat (``layer_C`` J m-3 K-1 over its 1.5 cm: 30 kJ m-2 K-1 by default,
    near the Göttingen grass's fitted canopy node; a wet soil's heat capacity with a dry
    litter's conductivity, an unusual material but a clear test): its top, which the
    thermometer sees, leads the bulk of the layer that the inversion lumps into one node. The
    case holds ``ir_view`` at 1 and frees the stream parameters in ``free``; the TOML's path
    and the twin's spec."""
    return ir_view_case(directory, 1.0, seed, thatch={"layer_C": float(layer_C)}, free=free)


def tiled_case(directory: str | Path, view: float, seed: int) -> tuple[Path, SyntheticSpec]:
    """As :func:`ir_view_case`, but the thermometer sees ``view`` of the thatch's top and the
    rest a bare patch beside it (module doc); the TOML's path and the thatch twin's spec."""
    directory = Path(directory)
    toml, spec = ir_view_case(directory, 1.0, seed)
    cols, thatch = simulate(spec)  # deterministic in the seed: the record just written
    bare = simulate(replace(spec, effects={k: v for k, v in spec.effects.items()
                                            if k != "surface_layer"}))[1]
    K = 273.15
    T = (view * (thatch.profiles[:, 0] + K) ** 4 + (1 - view) * (bare.profiles[:, 0] + K) ** 4)
    ir = T ** 0.25 - K + IR_OFFSET + IR_NOISE * np.random.default_rng(seed).standard_normal(T.size)
    path = directory / "measurements.csv"
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    j = rows[0].index("T_surf_IR")
    for i, row in enumerate(rows[1:]):
        row[j] = f"{ir[i]:.2f}"
    with path.open("w", newline="") as fh:
        csv.writer(fh, lineterminator="\n").writerows(rows)
    return toml, spec
