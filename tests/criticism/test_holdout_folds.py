"""The leave-one-sensor-out score fold by fold: the mean over folds is the reported score, and
``compare`` says which fold carries a run's change of it (one badly predicted sensor can carry
all of it, as the desert's 5 cm fold does with two_layer)."""

from __future__ import annotations

import numpy as np
import pytest

from pavement_mcmc.criticism.fitting import refit
from pavement_mcmc.criticism.holdout import HoldOut, leave_one_sensor_out
from pavement_mcmc.criticism.ledger import ledger
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem


def test_carried_by_names_the_fold_and_its_share():
    labs = ["2cm", "5cm", "10cm"]
    a = HoldOut(labs, np.ones(3), -1.0, np.array([-1.0, -1.0, -1.0]))
    b = HoldOut(labs, np.ones(3), -0.5, np.array([-0.9, -1.0, -0.6]))  # +0.1 and +0.4
    assert b.carried_by(a) == ("10cm", pytest.approx(0.8))
    worse = HoldOut(labs, np.ones(3), -1.5, np.array([-1.2, -2.2, -1.1]))
    assert worse.carried_by(a)[0] == "5cm"  # a fall is carried by the fold that fell most
    assert a.carried_by(a) is None
    assert HoldOut(labs, np.ones(3), -1.0).carried_by(a) is None  # a record without folds
    assert b.change_from(a) == "LOSO lpd +0.500, 80 % of it from the fold that holds out 10cm"


def test_a_fold_that_carries_more_than_the_change_is_given_beside_the_others():
    """The desert's two_layer (`compare runs/desert.toml runs/desert.toml+two_layer`): the 5 cm
    fold gains 37 per datum, 10 and 30 cm lose, the mean gains +0.49; "1889 % of it from the
    fold that holds out 5cm" read as an error. Both parts are given instead."""
    labs = ["5cm", "10cm", "20cm", "30cm"]
    a = HoldOut(labs, np.ones(4), -63.9, np.array([-192.0, -27.6, -20.0, -16.0]))
    b = HoldOut(labs, np.ones(4), -63.4, np.array([-155.0, -39.2, -4.6, -54.8]))
    text = b.change_from(a)
    assert "%" not in text and "the fold that holds out 5cm +9.250" in text, text
    assert "the other folds -8.750 together" in text, text


def test_loso_folds_average_to_the_score_and_show_in_compare():
    pb = build_problem(load_case("runs/hidden.toml"))
    base = refit(pb)
    h = leave_one_sensor_out(pb, base.values())
    assert h.lpd_sensors.shape == (pb.meas.n_sensors,)
    assert np.mean(h.lpd_sensors) == pytest.approx(h.lpd, rel=1e-12)
    assert h.to_dict()["lpd_per_datum_by_sensor"][h.labels[0]] == h.lpd_sensors[0]
    two = build_problem(load_case("runs/hidden.toml"), extensions=["two_layer"])
    fit2 = refit(two, {**base.values(), "kappa2": 0.8, "C2": 1.2e6, "d_layer": 0.02})
    text = ledger([("base", pb, base.values()), ("two_layer", two, fit2.values())]).text()
    assert "fold by fold" in text
    assert "two_layer against base: LOSO lpd" in text and "the fold that holds out " in text


def test_compare_of_a_single_sensor_run_has_no_holdout_column(tmp_path):
    """One observed sensor leaves no fold to refit: the ledger's leave-one-sensor-out entry is
    empty ('-' in the table) instead of an IndexError from the empty fold."""
    from dataclasses import replace

    from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin

    twin = forecast_twins((), (2701,), hours=24.0)[0]
    inv = {**twin.inversion, "data": {**twin.inversion["data"], "observed_cm": [2.0]}}
    pb = build_problem(load_case(write_twin(replace(twin, inversion=inv), tmp_path / "t")))
    led = ledger([("one", pb, refit(pb).values())])
    assert led.rows[0].holdout is None and "one" in led.text()
