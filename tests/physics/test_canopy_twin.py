"""``canopy`` + ``energy_balance`` + the IR stream recover a twin from
:mod:`pavement_mcmc.synthetic` whose thatch is a resolved layer (1.5 cm, kappa 0.06 W m-1 K-1,
C 0.3 MJ m-3 K-1: R = 0.25 m2 K W-1, 4.5 kJ m-2 K-1) on the simulator's fine grid, with the
radiative emission in its surface balance, where the inversion has one lumped skin node (no
inverse crime); the IR reading is the twin's skin (its column's top node) plus an offset."""

from __future__ import annotations

import numpy as np
import pytest

from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem, find_map
from pavement_mcmc.synthetic import SyntheticSpec, simulate
from pavement_mcmc.synthetic.corpus import FIELD
from pavement_mcmc.synthetic.io import write_case

OFFSET, IR_SD = 0.8, 0.2
THATCH = {"layer_thickness": 0.015, "layer_kappa": 0.06, "layer_C": 0.3e6}

CASE = f"""
[data]
csv = "measurements.csv"
sigma = 0.1
observed_cm = [2, 5, 10, 20]
bottom_cm = 50
extras = "extras.csv"
ir_sigma = {IR_SD}
[model]
extensions = ["energy_balance", "canopy"]
[grid]
kind = "stretched"
dx_top = 0.001
growth = 1.08
[parameters.kappa]
prior = {{ dist = "truncnormal", mean = 1.4, sd = 0.4 }}
[parameters.C]
prior = {{ dist = "truncnormal", mean = 2.3e6, sd = 0.5e6 }}
"""


@pytest.fixture(scope="module")
def twin(tmp_path_factory):
    d = tmp_path_factory.mktemp("canopy-twin")
    spec = SyntheticSpec(**{**FIELD, "flux_depths_cm": ()}, sigma=0.1, hours=48.0, seed=11,
                         effects={"wind_convection": {"h_a": 4.0, "h_b": 3.0},
                                  "evapotranspiration": {"et_alpha": 0.9},
                                  "surface_layer": THATCH},
                         et_available="net")
    write_case(spec, d)
    cols, truth = simulate(spec)
    rng = np.random.default_rng(5)
    ir = truth.profiles[:, 0] + OFFSET + IR_SD * rng.standard_normal(truth.t.size)
    (d / "extras.csv").write_text("time,T_surf_IR\n" + "".join(
        f"{s},{v:.3f}\n" for s, v in zip(cols["time"], ir, strict=True)))
    (d / "case.toml").write_text(CASE)
    return build_problem(load_case(d / "case.toml")), truth


def test_canopy_twin_recovered_at_the_map(twin):
    pb, truth = twin
    lap = find_map(pb.posterior, pb.space.start_vector())
    est = dict(zip(lap.names, lap.theta, strict=True))
    assert est["kappa"] == pytest.approx(truth.kappa, rel=0.1)
    assert est["C"] == pytest.approx(truth.C, rel=0.1)
    R = THATCH["layer_thickness"] / THATCH["layer_kappa"]
    assert est["R_canopy"] == pytest.approx(R, rel=0.25)
    # a resolved layer's heat capacity sits on both its faces (half each in a pi network): the
    # lumped skin carries a share of it, here about a third
    c = THATCH["layer_thickness"] * THATCH["layer_C"]
    assert c / 4 < est["c_canopy"] < c
    assert est["ir_offset"] == pytest.approx(OFFSET, abs=0.5)
    assert np.sqrt(np.mean(lap.rmse[:4] ** 2)) < 1.3 * truth.sigma
