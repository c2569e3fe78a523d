"""The twin corpus: enough clean twins, every category populated, inversion settings that never
copy the simulator's, and case files the package's loader accepts."""

from __future__ import annotations

import json
import tomllib
import warnings
from collections import Counter

import numpy as np
import pytest

from pavement_mcmc.data import load_case
from pavement_mcmc.data.toml_writer import to_toml
from pavement_mcmc.synthetic import (
    EFFECTS,
    NEW_CATALOGUE_EFFECTS,
    OFF_CATALOGUE_EFFECTS,
    resolved_grid,
)
from pavement_mcmc.synthetic.corpus import (
    CATEGORIES,
    Twin,
    all_twins,
    case_document,
    catalogue_twins,
    clean_twins,
    field_twins,
    get_twin,
    off_catalogue_twins,
    write_twin,
)

TWINS = all_twins()


def test_corpus_composition():
    counts = Counter(t.category for t in TWINS)
    assert set(counts) == set(CATEGORIES)
    assert counts["clean"] >= 24
    assert len({t.name for t in TWINS}) == len(TWINS)
    assert len({(t.spec.seed, t.spec.effects.__repr__()) for t in clean_twins()}) == counts["clean"]
    # catalogue: every catalogue effect (today's and the two planned), >= 2 seeds each
    per_effect = Counter(t.hidden for t in catalogue_twins())
    assert set(per_effect) == {(e,) for e in EFFECTS + NEW_CATALOGUE_EFFECTS}
    assert min(per_effect.values()) >= 2
    per_effect = Counter(t.hidden for t in off_catalogue_twins())
    assert set(per_effect) == {(e,) for e in OFF_CATALOGUE_EFFECTS} and min(per_effect.values()) >= 2
    for t in field_twins():
        assert t.spec.flux_depths_cm == (5.0,) and t.spec.bottom_cm == 50.0
        assert set(t.hidden) <= {"evapotranspiration", "surface_layer"}
    assert any(set(t.hidden) == {"evapotranspiration", "surface_layer"} for t in field_twins())


def test_clean_twins_span_the_settings():
    clean = clean_twins()
    assert all(t.hidden == () and t.spec.effects == {} for t in clean)
    h_kinds = Counter(json.dumps(t.inversion["model"]["h"], sort_keys=True) for t in clean)
    assert len(h_kinds) == 3 and min(h_kinds.values()) >= 6  # Case A, hourly, Case C
    assert len({t.spec.h_knots for t in clean}) >= 4
    with_input = [t for t in clean if t.inversion["data"].get("input_sigma")]
    assert 0 < len(with_input) < len(clean)
    assert all(t.inversion["data"]["input_sigma"] == t.spec.sigma for t in with_input)
    sds = {t.inversion["parameters"]["kappa"]["prior"]["sd"] for t in clean}
    assert min(sds) <= 0.07 and max(sds) >= 0.5  # tight-ish and loose
    case_c = [t for t in clean if t.inversion["model"]["h"]["kind"] == "per_interval"]
    assert all(t.inversion["model"]["h"]["smooth"] and "gamma" in t.inversion["parameters"] for t in case_c)


@pytest.mark.parametrize("twin", TWINS, ids=lambda t: t.name)
def test_inversion_never_shares_the_simulator_grid_or_truth(twin):
    dz, dt = resolved_grid(twin.spec)
    grid = twin.inversion["grid"]
    assert grid["dx"] >= 5 * dz and grid["dt"] >= 2 * dt
    for name, truth in (("kappa", twin.spec.kappa), ("C", twin.spec.C)):
        mean = twin.inversion["parameters"][name]["prior"]["mean"]
        assert abs(mean - truth) >= 0.02 * truth, f"{name} prior centred on the truth"


def test_toml_writer_round_trips():
    for twin in TWINS:
        doc = case_document(twin)
        assert tomllib.loads(to_toml(doc)) == json.loads(json.dumps(doc))


def test_twin_refuses_inconsistent_labels():
    twin = get_twin("catalogue-two_layer-s11")
    with pytest.raises(ValueError, match="hidden="):
        Twin(twin.name, twin.spec, twin.inversion, "catalogue", hidden=())
    with pytest.raises(ValueError, match="valid: clean, catalogue"):
        Twin(twin.name, twin.spec, twin.inversion, "dirty", hidden=twin.hidden)
    with pytest.raises(ValueError, match="unknown twin 'nope'; valid: clean-"):
        get_twin("nope")


def test_every_twin_writes_a_loadable_case(tmp_path):
    """All twins, simulated and written (~0.3 s each), load with the package's case loader;
    the data, the truth and the settings arrive as the twin says."""
    for twin in TWINS:
        path = write_twin(twin, tmp_path / twin.name)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            cfg = load_case(path)
        ignored = [str(w.message) for w in caught if "not in the contract" in str(w.message)]
        assert not ignored, ignored  # G_<d>cm plate columns are part of the contract
        meas = cfg.measurements
        assert meas.n_plates == len(twin.spec.flux_depths_cm)
        n_rows = int(round(twin.spec.hours * 60 / twin.spec.step_minutes)) + 1
        assert meas.T_obs.shape == (n_rows, len(twin.spec.depths_cm))
        np.testing.assert_allclose(meas.depths * 100, twin.spec.depths_cm)
        assert meas.bottom_depth * 100 == pytest.approx(twin.spec.bottom_cm)
        assert cfg.name == twin.name and cfg.model["h"] == twin.inversion["model"]["h"]
        assert cfg.grid["dx"] == twin.inversion["grid"]["dx"]
        assert sorted(cfg.truth["effects"]) == sorted(twin.hidden)
        assert cfg.truth["kappa"] == twin.spec.kappa and cfg.truth["C"] == twin.spec.C
        if "surface_layer" in twin.hidden:
            assert cfg.truth["effects"]["surface_layer"]["R_surface"] == pytest.approx(0.25)
        if "evapotranspiration" in twin.hidden:
            assert len(cfg.truth["q_et_obs"]) == n_rows and max(cfg.truth["q_et_obs"]) > 50
        if twin.spec.flux_depths_cm:
            assert len(cfg.truth["flux_true_obs"]["G_5cm"]) == n_rows
