"""``canopy`` as a candidate: a heat-storing layer over the soil with the sensor depths counted
from the soil surface under it (physics/catalogue/canopy.py, ``Grid.with_skin``). Twins of the
forecast campaign (40 h, 30 min rows, input noise, the last 10 h held out; Case C form, loose
priors), the surface_layer twins' layer: 1.5 cm of thatch, R 0.25 m2 K W-1, 4.5 kJ m-2 K-1.

Before the skin node (the canopy's skin on the grid's top node, the soil 1 mm below it and the
sensors read from the skin) the same twin gave R_canopy at its lower bound 0.005 and F = -84 to
-17 over seeds 3700-3709 (benchmarks/canopy_pilot.py, docs/VALIDATION.md section 4)."""

from __future__ import annotations

import pytest

from pavement_mcmc.criticism.calibration import found
from pavement_mcmc.criticism.entries import FORECAST_THRESHOLD
from pavement_mcmc.data import load_case
from pavement_mcmc.physics import candidate_names
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin


def test_canopy_finds_the_layer_of_a_surface_layer_twin(extension_forecast):
    """The layer's resistance is recovered (measured 0.19 against the true 0.25) with a heat
    capacity of the thatch's order (3.6 kJ against 4.5), and the forecast gains past the
    claim margin (measured F 32)."""
    F, fc, _, _ = extension_forecast(("surface_layer",), 3700, "canopy")
    v = fc.fits[-1].values()
    assert F > FORECAST_THRESHOLD, (F, v)
    assert 0.12 < v["R_canopy"] < 0.4, v
    assert 1.5e3 < v["c_canopy"] < 1.2e4, v


def test_canopy_on_a_clean_twin_has_no_layer_and_no_gain(extension_forecast):
    """No layer: the resistance goes to its lower bound and the forecast does not gain
    (measured F 1.5)."""
    F, fc, _, _ = extension_forecast((), 3600, "canopy")
    v = fc.fits[-1].values()
    assert F < FORECAST_THRESHOLD, (F, v)
    assert v["R_canopy"] < 0.05, v


def test_canopy_is_a_candidate_and_names_the_layer():
    """The criticism tries canopy by default, and a canopy claim on a twin whose layer stores
    heat counts as finding it (the calibration's rates)."""
    assert "canopy" in candidate_names()
    assert found("canopy", "surface_layer") and found("surface_layer", "surface_layer")
    assert not found("canopy", "evapotranspiration") and not found(None, "surface_layer")


@pytest.mark.parametrize("other", ["surface_layer"])
def test_one_layer_over_the_soil(tmp_path, other):
    """canopy and surface_layer are both a layer between the air and the soil: a model takes
    one (a clear error, not a column with two skins)."""
    twin = forecast_twins((), (3600,), hours=40.0, input_sigma=True)[0]
    case = write_twin(twin, tmp_path / twin.name)
    with pytest.raises(ValueError, match="two layers between the air and the soil"):
        build_problem(load_case(case, additions={"model": {"extensions": ["canopy", other]}}))
