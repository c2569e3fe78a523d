"""Grass-like twins seen by an infrared thermometer over a partial canopy, and their case: the
test of the IR stream's view (:mod:`pavement_mcmc.posterior.surface_ir`) and
``benchmarks/ir_view_twins.py``.

72 h of the field geometry (:data:`~.corpus.FIELD`: sensors 2-20 cm, bottom 50 cm, a 5 cm
plate; moist loam, spring weather), h from the wind (``wind_convection``), latent heat in the
Priestley-Taylor form on max(R_n, 0) (``et_available = "net"``, as the inversion's law), and a
resolved thatch with its own heat capacity (``surface_layer``: 1.5 cm, R 0.25 m2 K W-1,
4.5 kJ m-2 K-1), not the inversion's lumped skin node. The thermometer reads ``view`` of the
thatch's top and the rest of the soil surface under it, + 1 degC, + N(0, 0.3 degC)
(``SyntheticSpec.ir_view``). The case: ``energy_balance_window`` + ``canopy``, the IR at sd
0.3 with ``ir_view`` free, loose loam-like priors on kappa and C.
"""

from __future__ import annotations

from pathlib import Path

from .corpus import FIELD
from .io import write_case
from .simulate import SyntheticSpec

__all__ = ["HELD", "IR_NOISE", "IR_OFFSET", "ir_view_case"]

IR_OFFSET, IR_NOISE = 1.0, 0.3
#: overrides that hold the case's view at 1 (the footprint all canopy)
HELD = {"parameters": {"ir_view": {"vary": False, "value": 1.0}}}


def ir_view_case(directory: str | Path, view: float, seed: int) -> tuple[Path, SyntheticSpec]:
    """Write the twin of ``view`` and ``seed`` and its ``case.toml`` into ``directory``; the
    TOML's path and the twin's spec (its truth)."""
    directory = Path(directory)
    spec = SyntheticSpec(seed=seed, sigma=0.1, hours=72.0, et_available="net",
                         effects={"wind_convection": {}, "evapotranspiration": {},
                                  "surface_layer": {}},
                         ir_view=view, ir_offset=IR_OFFSET, ir_noise=IR_NOISE, **FIELD)
    csv = write_case(spec, directory)
    toml = directory / "case.toml"
    toml.write_text(f'[data]\ncsv = "{csv.name}"\nsigma = 0.1\nplates = true\n'
                    f'ir_sigma = {IR_NOISE}\n'
                    '[model]\nextensions = ["energy_balance_window", "canopy"]\n'
                    '[parameters.kappa]\nvalue = 1.0\n'
                    'prior = { dist = "truncnormal", mean = 1.0, sd = 0.5 }\n'
                    '[parameters.C]\nvalue = 2.0e6\n'
                    'prior = { dist = "truncnormal", mean = 2.0e6, sd = 0.7e6 }\n'
                    '[parameters.ir_view]\nvary = true\n')
    return toml, spec
