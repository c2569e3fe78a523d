"""A dew point estimated from the air temperature where a record has no humidity (FAO-56 eq. 48;
data/humidity.py): the running 24 h minimum of a known daily wave, its offset, the refusal
where humidity is measured, and the Penman–Monteith law reading it."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from pavement_mcmc.data import ConfigError, DataError, load_case
from pavement_mcmc.data.humidity import dew_from_tmin
from pavement_mcmc.physics import get_extension
from pavement_mcmc.physics.catalogue.penman import has_humidity, humidity, saturation
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin

DAY = 86400.0


def test_the_dew_point_is_the_minimum_within_twelve_hours():
    t = np.arange(0.0, 3 * DAY + 1, 1800.0)
    # a daily wave whose minimum falls to 4 degC on day 1 and 6 degC on day 2 (at 06:00)
    depth = np.where(t < 1.5 * DAY, 6.0, 4.0)
    T = 10.0 - depth * np.cos(2 * np.pi * (t - 0.25 * DAY) / DAY)
    d = dew_from_tmin(t, T)
    at = {h: d[int(h * 2)] for h in (18, 30, 54)}  # hours from the start
    assert at[18] == pytest.approx(10 - 6.0)  # 06:00 of day 1 is 12 h back: its minimum
    assert at[30] == pytest.approx(10 - 6.0)  # 06:00 of day 1 and 06:00 of day 2 both within
    assert at[54] == pytest.approx(10 - 4.0)  # only day 2's shallower minimum within 12 h
    assert np.all(d <= T + 1e-12)  # never above the air
    np.testing.assert_allclose(dew_from_tmin(t, T, below=2.5), d - 2.5)
    T_gap = T.copy()
    T_gap[12] = np.nan  # 06:00 of day 0, the minimum: skipped, the next-coldest row counts
    assert dew_from_tmin(t, T_gap)[12] == pytest.approx(np.nanmin(T_gap[:37]))
    T_gap[:60] = np.nan  # no air temperature within 12 h of the first 36 rows: NaN, no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d = dew_from_tmin(t, T_gap)
    assert np.isnan(d[:36]).all() and np.isfinite(d[36:]).all()


def _dry_twin(tmp_path, extra: str = "dew_below_tmin = 0.0\n", spec=None):
    twin = forecast_twins((), (5,), hours=48.0, spec=spec)[0]
    case = write_twin(twin, tmp_path / "twin")
    case.write_text(case.read_text().replace("[data]\n", "[data]\n" + extra, 1))
    return case


def test_a_case_estimates_its_dew_point_and_the_law_reads_it(tmp_path):
    m = load_case(_dry_twin(tmp_path)).measurements
    assert "RH" not in m.extras and has_humidity(m)
    np.testing.assert_allclose(m.extras["T_dew"], dew_from_tmin(m.t, m.T_air))
    rh = humidity(m)
    np.testing.assert_allclose(rh, 100 * saturation(m.extras["T_dew"])[0] / saturation(m.T_air)[0])
    assert rh.max() == pytest.approx(100.0) and rh.min() < 70.0  # saturated at dawn, dry by day
    names = [p.name for p in get_extension("energy_balance_pm_window").parameters(m)]
    assert "eb_rs" in names


def test_the_dew_point_does_not_depend_on_the_window(tmp_path):
    """A time's dew point is the record's 24 h minimum around it, whichever window reads it (it
    was the window's: 15 of 49 rows up to 3.6 K off between a day's window and two days')."""
    case = _dry_twin(tmp_path)
    whole = load_case(case).measurements
    for window in ([0, 24], [0, 48], [12, 36], [20, 47.5]):
        m = load_case(case, {"data": {"window_hours": window}}).measurements
        first = int(round(window[0] * 2))  # 30 min rows
        np.testing.assert_allclose(m.extras["T_dew"], whole.extras["T_dew"][first:first + m.n_obs])
    np.testing.assert_allclose(whole.extras["T_dew"], dew_from_tmin(whole.t, whole.T_air))


def test_a_junk_air_temperature_outside_the_window_is_left_out_with_a_warning(tmp_path):
    """The running minimum reads 12 h past the window, where the case's reader checks nothing:
    a -9999 there became the dew point (RH up to 2e9 %) and a word refused the case."""
    case = _dry_twin(tmp_path)
    csv = case.parent / "measurements.csv"
    lines = csv.read_text().splitlines()
    clean = load_case(case, {"data": {"window_hours": [24, 47.5]}}).measurements
    for junk in ("-9999", "ERR"):
        row = lines[45].split(",")  # 22 h: 2 h before the window
        row[1] = junk
        csv.write_text("\n".join(lines[:45] + [",".join(row)] + lines[46:]) + "\n")
        with pytest.warns(UserWarning, match="1 air temperatures outside"):
            m = load_case(case, {"data": {"window_hours": [24, 47.5]}}).measurements
        assert np.all(m.extras["T_dew"] > -60) and np.all(humidity(m) <= 100.0 + 1e-9)
        assert np.max(np.abs(m.extras["T_dew"] - clean.extras["T_dew"])) < 1.0


def test_renames_of_the_extras_file_do_not_stop_the_record_readers(tmp_path):
    """A case whose [data.columns] renames a column of its extras CSV (the desert's
    "G_minus_SG" = "G_5cm"): the whole-record readers took the rename for the case CSV's and
    refused it ("named in the column mapping is not in the file"), so neither dew_below_tmin
    nor the record's times (batch, rolling) worked on it."""
    from pavement_mcmc.data.case import record_times

    case = _dry_twin(tmp_path)
    rows = (case.parent / "measurements.csv").read_text().splitlines()
    (case.parent / "extras.csv").write_text("time,IRraw\n" + "".join(
        f"{r.split(',')[0]},{15.0 + 0.01 * i:.2f}\n" for i, r in enumerate(rows[1:])))
    case.write_text(case.read_text().replace(
        "[data]\n", '[data]\nextras = "extras.csv"\ncolumns = { IRraw = "T_surf_IR" }\n', 1))
    m = load_case(case).measurements
    assert "T_surf_IR" in m.extras and has_humidity(m)
    assert len(record_times(case)) == len(rows) - 1


def test_a_measured_humidity_is_not_replaced_by_the_estimate(tmp_path):
    with pytest.raises(DataError, match="measures it .RH."):
        load_case(_dry_twin(tmp_path, spec={"vapour_kPa": 1.0}))
    case = _dry_twin(tmp_path / "dew")
    csv = case.parent / "measurements.csv"
    lines = csv.read_text().splitlines()
    csv.write_text("\n".join([lines[0] + ",T_dew"] + [r + ",5.0" for r in lines[1:]]) + "\n")
    with pytest.raises(DataError, match="measures it .T_dew."):
        load_case(case)
    with pytest.raises(ConfigError, match="dew_below_tmin"):
        load_case(_dry_twin(tmp_path, extra="dew_below_tmin = -2.0\n"))


def test_a_measured_dew_point_is_read_when_there_is_no_rh():
    class Meas:
        T_air = np.array([5.0, 15.0, 25.0])
        extras = {"T_dew": np.array([5.0, 5.0, 5.0])}

    # FAO-56 Annex 2 table 2.3: e_s 0.872, 1.705, 3.168 kPa at 5, 15, 25 degC
    np.testing.assert_allclose(humidity(Meas), [100.0, 51.1, 27.5], atol=0.1)
    Meas.extras = {**Meas.extras, "RH": np.array([90.0, 80.0, 70.0])}
    np.testing.assert_array_equal(humidity(Meas), [90.0, 80.0, 70.0])  # RH first
    Meas.extras = {"T_dew": np.array([5.0, np.nan, 5.0])}
    assert not has_humidity(Meas)


def test_a_humid_twin_without_rh_is_recovered_through_its_estimated_dew_point(tmp_path):
    """A twin whose latent heat follows Penman–Monteith on a fixed vapour pressure of 1.4 kPa
    (the simulator's), written without its RH column: the law on the dew point estimated from
    T_min recovers the soil and the resistance, Priestley–Taylor on the same record does not."""
    from pavement_mcmc.criticism import refit
    from pavement_mcmc.criticism.point import case_problem
    from pavement_mcmc.synthetic.io import drop_columns

    twin = forecast_twins(("wind_convection",), (1,), hours=72.0,
                          spec={"vapour_kPa": 1.4, "surface_resistance": 150.0})[0]
    case = write_twin(twin, tmp_path / twin.name)
    drop_columns(case.parent / "measurements.csv", ("RH",))
    with pytest.raises(ConfigError, match="humidity"):  # no humidity, no estimate: refused
        case_problem(f"{case}+energy_balance_pm_window")
    case.write_text(case.read_text().replace("[data]\n", "[data]\ndew_below_tmin = 0.0\n", 1))
    v = refit(case_problem(f"{case}+energy_balance_pm_window")[0]).values()
    assert v["eb_rs"] == pytest.approx(150.0, rel=0.2)
    assert v["kappa"] == pytest.approx(twin.spec.kappa, rel=0.1)
    assert v["C"] == pytest.approx(twin.spec.C, rel=0.25)
    pt = refit(case_problem(f"{case}+energy_balance_window")[0]).values()
    assert abs(pt["C"] / twin.spec.C - 1) > 0.5
