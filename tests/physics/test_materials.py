"""Physical plausibility of estimates: notes against a declared material, alarms against every ground."""

import pytest

from pavement_mcmc.physics.materials import ANY_GROUND, C_WATER, MATERIALS, check_values, material


def test_the_grass_record_fits_of_issue_12_raise_alarms():
    """kappa 17.3, C 40.8 MJ (the base fit of a real grass record) are impossible for any ground."""
    f = check_values(kappa=17.3, C=40.8e6)
    assert {(x.level, x.quantity) for x in f} == {("alarm", "kappa"), ("alarm", "C")}
    assert "40.8 MJ m-3 K-1" in f[1].text()


def test_a_moist_loam_is_quiet_and_a_declared_material_gives_notes():
    assert check_values(kappa=1.2, C=2.6e6, declared="loam") == []
    notes = check_values(kappa=2.4, C=2.6e6, declared="loam")
    assert [(x.level, x.quantity) for x in notes] == [("note", "kappa"), ("note", "kappa/C")]
    assert check_values(kappa=2.4, C=2.6e6) == []  # possible for some ground (moist sand)


def test_water_caps_the_heat_capacity_and_h_has_a_ceiling():
    assert ANY_GROUND.C[1] == C_WATER
    assert check_values(C=4.3e6)[0].level == "alarm"
    assert check_values(h=[0.5, 465.0])[0].level == "alarm"
    assert check_values(h=[0.5, 40.0])[0].level == "note"
    assert check_values(h=[5.0, 40.0]) == []


def test_every_material_is_inside_any_ground_and_names_are_checked():
    for m in MATERIALS.values():
        for q in ("kappa", "C", "diffusivity"):
            lo, hi = getattr(m, q)
            assert ANY_GROUND.__getattribute__(q)[0] <= lo < hi <= getattr(ANY_GROUND, q)[1], (m.name, q)
    with pytest.raises(ValueError, match="unknown material 'lome'; valid: asphalt"):
        material("lome")
