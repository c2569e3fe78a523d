"""Criticism of the surface energy balance on field twins (independent simulator: grass-like
ground, sensors at 2-20 cm, bottom 50 cm, a 5 cm heat-flux plate)."""

from __future__ import annotations

from pathlib import Path

import pytest

from pavement_mcmc.criticism import refit
from pavement_mcmc.criticism.energy import energy_balance
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.synthetic.corpus import get_twin, write_twin

FAST = {"grid": {"kind": "stretched"}, "model": {"h": {"kind": "uniform", "n": 12}},
        "data": {"window_hours": [0, 48]}}


def _case(tmp_path, name, **over):
    twin = get_twin(name)
    return twin, load_case(write_twin(twin, tmp_path / name), {**FAST, **over})


@pytest.mark.parametrize("name", ["field-thatch-s203", "field-none-s204"])
def test_measured_top_recovers_diffusivity_and_the_plate_kappa(tmp_path, name):
    """The shallowest sensor as boundary: no surface balance, kappa/C from the temperatures
    and kappa from the plate (true 1.2, 2.6 MJ), whatever happens at the surface."""
    twin, cfg = _case(tmp_path, name, model={"top": "measured"})
    pb = build_problem(cfg)
    assert pb.model.top_measured and pb.space.free == ["kappa", "C", "plate_G5cm"]
    assert "kappa comes from the heat-flux plate" in pb.model.boundary_note()
    v = refit(pb).values()
    assert v["kappa"] / v["C"] == pytest.approx(twin.spec.kappa / twin.spec.C, rel=0.1)
    assert v["kappa"] == pytest.approx(twin.spec.kappa, rel=0.15)


def test_a_thatch_layer_is_named_as_the_surface_boundary(tmp_path):
    """Twin with a thatch layer over the soil: the base fit's kappa and C are impossible and its
    flux at the plate several times the reading, while its kappa/C agrees with the measured-top
    fit: the verdict names the surface boundary."""
    _, cfg = _case(tmp_path, "field-thatch-s203")
    pb = build_problem(cfg)
    eb = energy_balance(pb, refit(pb).values())
    assert eb.surface_wrong, eb.text()
    assert "conduction is fine" in eb.verdict
    assert eb.kappa > 2.6 and eb.plates["G5cm"]["slope"] > 1.6
    assert any(f.level == "alarm" for f in eb.findings)


def test_a_clean_field_twin_is_consistent(tmp_path):
    _, cfg = _case(tmp_path, "field-none-s204")
    pb = build_problem(cfg)
    eb = energy_balance(pb, refit(pb).values())
    assert not eb.surface_wrong and "consistent" in eb.verdict, eb.text()
    assert eb.top["diffusivity"] == pytest.approx(eb.diffusivity, rel=0.1)


def _with_ir(path, more: str):
    """The twin's case observing an infrared surface temperature from an extras CSV beside it
    (in the file, as runs/grass_energy.toml has it, not an override), and ``more`` [data]."""
    rows = (path.parent / "measurements.csv").read_text().splitlines()
    time = [r.split(",")[0] for r in rows[1:]]
    (path.parent / "extras.csv").write_text(
        "time,T_surf_IR\n" + "".join(f"{t},{15.0 + 0.01 * i:.2f}\n" for i, t in enumerate(time)))
    path.write_text(path.read_text().replace(
        "[data]\n", '[data]\nextras = "extras.csv"\nir_sigma = 0.5\n' + more, 1))
    return path


def test_the_measured_top_fit_of_a_case_that_observes_the_infrared_surface(tmp_path):
    """A case with ``ir_sigma`` (the IR surface temperature observed): the energy check's
    measured-top fit has no surface, so it leaves the IR out; it raised "T_surf_IR needs the
    surface energy balance at the top" and `diagnose runs/grass_energy.toml` stopped there; with
    the stream's parameter set in ``[parameters]`` (``ir_view``, as the case sets it) it
    refused "unknown parameter 'ir_view'"."""
    path = _with_ir(write_twin(get_twin("field-none-s204"), tmp_path / "ir"), "")
    path.write_text(path.read_text() + "\n[parameters.ir_view]\nvary = true\n")  # the stream's own
    cfg = load_case(path, FAST)
    pb = build_problem(cfg)
    assert pb.posterior.stream("surface_ir") is not None
    eb = energy_balance(pb, refit(pb).values())
    assert eb.top is not None and 0.2e-6 < eb.top["diffusivity"] < 2e-6


def test_the_measured_top_fit_of_a_canopy_model_leaves_the_canopy_out(tmp_path):
    """A model with ``canopy`` (a skin node over the soil) and a plate: the energy check's
    measured-top fit has no skin, so it leaves the canopy out, as it leaves the surface hooks
    out. It raised "canopy puts a skin above the soil, but a measured top has none" once the
    skin became a node above the soil, and `diagnose runs/grass_energy.toml` stopped there.
    The measured-top fit of the thatch twin recovers its diffusivity (true 1.2 / 2.6 MJ)."""
    twin = get_twin("field-thatch-s203")
    cfg = load_case(write_twin(twin, tmp_path / "canopy"), FAST,
                    additions={"model": {"extensions": ["canopy"]}})
    pb = build_problem(cfg)
    assert [e.name for e in pb.model.extensions] == ["canopy"] and pb.model.plates
    eb = energy_balance(pb, refit(pb).values())
    assert eb.top is not None and eb.top["from_plate"]
    assert eb.top["diffusivity"] == pytest.approx(twin.spec.kappa / twin.spec.C, rel=0.1)


def test_the_measured_top_fit_of_a_storage_free_ir_case(tmp_path):
    """``[data] ir_storage_free`` (the IR reads a surface without storage above the canopy
    node, as runs/grass_energy.toml has it): the measured-top fit leaves the IR and the canopy
    out, and it left the flag in, so the check refused "ir_storage_free needs ir_sigma" and
    `diagnose` stopped there."""
    path = _with_ir(write_twin(get_twin("field-thatch-s203"), tmp_path / "sf"),
                    "ir_storage_free = true\n")
    cfg = load_case(path, FAST, additions={"model": {"extensions": ["energy_balance", "canopy"]}})
    pb = build_problem(cfg)
    assert pb.posterior.stream("surface_ir").storage_free
    eb = energy_balance(pb, refit(pb).values())
    assert eb.top is not None and 0.2e-6 < eb.top["diffusivity"] < 2e-6


def _eb(findings, top=None, plates=None):
    import numpy as np

    from pavement_mcmc.criticism.energy import EnergyBalance, _verdict

    eb = EnergyBalance(np.zeros(3), 0.1, 3.6e-7, 0.24, top, plates or {}, findings)
    eb.verdict = _verdict(eb)
    return eb


def test_an_impossible_h_names_the_surface_boundary():
    """A free h(t) beyond forced convection of air stands in for a flux that is not convection
    (the desert record's base fit: h 476 W m-2 K-1 with kappa and C possible). Before, only an
    impossible kappa or C or a plate named the surface boundary, and the verdict said the energy
    was "consistent with the measured-top fit and the plates" when neither had been checked."""
    from pavement_mcmc.physics.materials import H_ALARM, Finding

    h = Finding("alarm", "h", 476.0, 0.0, H_ALARM, "beyond forced convection of air")
    eb = _eb([h], top={"kappa": 0.3, "C": 0.9e6, "diffusivity": 3.4e-7, "from_plate": False})
    assert eb.surface_wrong and "476 W m-2 K-1" in eb.verdict and "conduction is fine" in eb.verdict
    quiet = _eb([])
    assert not quiet.surface_wrong and "measured-top fit and the plates" not in quiet.verdict
    assert "no measured-top fit, plate or flux tower" in quiet.verdict


def test_a_plate_that_reads_more_than_the_model_does_not_ask_for_a_sink():
    """The model's flux at the plate half its reading (the grass with the radiometer's weight
    free: 0.48) and nothing else wrong: the verdict said the balance "lacks a sink or a
    resistance", the wrong way round; a plate reading less than the model still asks for one."""
    top = {"kappa": 0.3, "C": 0.9e6, "diffusivity": 3.4e-7, "from_plate": True}  # agrees
    low = _eb([], top=top, plates={"G5cm": {"slope": 0.48, "factor": 1.06}})
    assert low.surface_wrong and "less heat into the ground than the plates read" in low.verdict
    assert "lacks a sink" not in low.verdict
    high = _eb([], top=top, plates={"G5cm": {"slope": 2.0, "factor": 0.5}})
    assert "lacks a sink or a resistance" in high.verdict
    backwards = _eb([], top=top, plates={"G5cm": {"slope": -1.0, "factor": 1.0}})
    assert "sign or polarity" in backwards.verdict and "less heat" not in backwards.verdict


DESERT = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "soilvue_utah" / "measurements.csv"


@pytest.mark.skipif(not DESERT.is_file(), reason=f"the shared desert record is not here ({DESERT})")
def test_the_desert_base_fit_names_the_surface_boundary_by_its_h():
    """runs/desert.toml (free h per hour, no plate): the MAP's kappa and C are possible but h
    passes forced convection at midday; the measured-top fit agrees on kappa/C."""
    from pavement_mcmc.criticism.diagnose import diagnose

    pb = build_problem(load_case(Path(__file__).resolve().parents[2] / "runs" / "desert.toml"))
    dx = diagnose(pb, refit(pb, max_nfev=200).values(), rank=False)
    assert not any(f.quantity in ("kappa", "C") and f.level == "alarm" for f in dx.findings)
    assert dx.energy.surface_wrong and dx.energy.top is not None, dx.energy.text()
