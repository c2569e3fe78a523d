"""Settings of a twin family given by name (synthetic.settings, forecast_twins' ``spec`` and
``params``, the forecast campaign's ``--spec`` / ``--param``): read as their type, checked."""

from __future__ import annotations

import pytest

from pavement_mcmc.criticism.campaign import forecast_campaign_twins
from pavement_mcmc.synthetic.corpus import forecast_twins
from pavement_mcmc.synthetic.settings import spec_overrides


def test_text_settings_take_the_setting_s_type():
    """A command line gives text: "False" must switch a flag off (it is a true string), "0.5"
    must be a number; the twin's name carries the value it was simulated with."""
    (tw,) = forecast_twins((), (3700,), spec={"forcing_noise": "False", "dz_mm": "0.5",
                                             "et_available": "net"})
    assert tw.spec.forcing_noise is False and tw.spec.dz_mm == 0.5
    assert tw.spec.et_available == "net"
    assert tw.name == "forecast-clean-s3700-forcing_noise-False-dz_mm-0.5-et_available-net"
    assert spec_overrides({"emission": "true", "plate_factor": 2}) == {"emission": True,
                                                                      "plate_factor": 2.0}


@pytest.mark.parametrize("spec, words", [
    ({"forcing_nois": "False"}, "unknown spec setting 'forcing_nois'"),
    ({"hours": 10.0}, "set by the twin family"),
    ({"dz_mm": "half"}, "dz_mm='half'"),
    ({"forcing_noise": 0.0}, "expected a bool"),
])
def test_bad_spec_settings_are_refused_by_name(spec, words):
    with pytest.raises(ValueError, match=words):
        forecast_twins((), (3700,), spec=spec)


def test_parameters_of_an_effect_that_is_not_hidden_or_not_its_own_are_refused():
    """A misspelt effect in ``params`` left the twins at the default strength without a word;
    a misspelt parameter surfaced only when the twin was simulated."""
    with pytest.raises(ValueError, match="conductivity_temprature"):
        forecast_campaign_twins(1, 1, 0, effects=["conductivity_temperature"],
                                params={"conductivity_temprature": {"kappa_beta": -0.015}})
    with pytest.raises(ValueError, match="kappa_bta"):
        forecast_twins(("conductivity_temperature",), (3700,),
                       params={"conductivity_temperature": {"kappa_bta": -0.015}})
    (tw,) = forecast_twins(("conductivity_temperature",), (3700,),
                           params={"conductivity_temperature": {"kappa_beta": -0.015}})
    assert tw.spec.effects == {"conductivity_temperature": {"kappa_beta": -0.015}}
    assert tw.name == "forecast-conductivity_temperature-s3700-kappa_beta-0.015"
