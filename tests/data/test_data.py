"""Tests for pavement_mcmc.data: reading and validating case CSVs."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.data import DataError, read_csv_case

REFERENCE = Path(__file__).resolve().parents[2] / "data" / "reference_case" / "measurements.csv"

HEADER = "time,T_air,q_net,wind,rain,T_0cm,T_1cm,T_2cm,T_5cm"


def _row(i: int, minutes: float = 15.0, temp: float = 15.0) -> list[str]:
    total = int(i * minutes)
    stamp = f"2004-06-06T{total // 60:02d}:{total % 60:02d}:00Z"
    t = temp + 0.1 * i
    return [stamp, f"{t:.2f}", f"{-80 + i:.1f}", "1.5", "0.0"] + [
        f"{t + k:.2f}" for k in (0.0, 0.5, 1.0, 2.0)
    ]


def write_csv(tmp_path: Path, rows: list[list[str]], header: str = HEADER, name="case.csv"):
    path = tmp_path / name
    text = header + "\n" + "".join(",".join(r) + "\n" for r in rows)
    path.write_text(text)
    return path


def good_rows(n: int = 8) -> list[list[str]]:
    return [_row(i) for i in range(n)]


def expect_error(path: Path, *parts: str, **kwargs) -> str:
    """Read `path`, expect a DataError naming the file and each of `parts`; return the message."""
    kwargs.setdefault("sigma", 0.25)
    with pytest.raises(DataError) as info:
        read_csv_case(path, **kwargs)
    msg = str(info.value)
    assert str(path) in msg, msg
    for part in parts:
        assert part in msg, f"{part!r} not in {msg!r}"
    return msg


# --------------------------------------------------------------------------- good input


def test_reference_case_reads():
    m = read_csv_case(REFERENCE, sigma=0.25, window_hours=(0, 28), observed=[0, 1, 2, 3, 4])
    # 28 h at 15 min, both ends included: 113 data rows (the file has 114 lines with the header)
    assert m.n_obs == 113
    assert m.n_sensors == 5
    np.testing.assert_allclose(m.depths, [0.0, 0.01, 0.02, 0.03, 0.04])
    assert m.bottom_depth == pytest.approx(0.05)
    assert m.t[0] == 0.0 and m.t[1] == 900.0 and m.t[-1] == 28 * 3600.0
    assert m.time0 == "2004-06-06T00:00:00Z"
    assert m.T_obs.shape == (113, 5) and m.T_bottom.shape == (113,)
    assert m.T_obs[0, 0] == 13.99 and m.T_bottom[0] == 17.01 and m.T_air[0] == 14.18
    assert m.wind is not None and m.rain is not None
    assert m.sigma == 0.25 and m.fill_report == ()
    assert not m.T_obs.flags.writeable


def test_reference_defaults_match_explicit():
    a = read_csv_case(REFERENCE, sigma=0.25)
    b = read_csv_case(REFERENCE, sigma=0.25, observed=[4, 0, 1, 3, 2], bottom=5)
    assert a.data_hash() == b.data_hash()


def test_optional_columns_absent(tmp_path):
    rows = [[r[0], r[1], r[2], *r[5:]] for r in good_rows()]
    m = read_csv_case(write_csv(tmp_path, rows, "time,T_air,q_net,T_0cm,T_1cm,T_2cm,T_5cm"), sigma=1)
    assert m.wind is None and m.rain is None and m.n_sensors == 3


def test_decimal_depths(tmp_path):
    path = write_csv(tmp_path, good_rows(), "time,T_air,q_net,wind,rain,T_0cm,T_1cm,T_2.5cm,T_5cm")
    m = read_csv_case(path, sigma=0.25, observed=[2.5, 0])
    np.testing.assert_allclose(m.depths, [0.0, 0.025])


def test_irregular_times_and_offsets(tmp_path):
    stamps = [
        "2004-06-06T00:00:00Z",
        "2004-06-06T00:07:00+00:00",
        "2004-06-06 00:30:00",  # naive: taken as UTC
        "2004-06-06T03:00:00+02:00",  # 01:00 UTC
    ]
    rows = good_rows(4)
    for r, s in zip(rows, stamps, strict=True):
        r[0] = s
    m = read_csv_case(write_csv(tmp_path, rows), sigma=0.25)
    np.testing.assert_allclose(m.t, [0.0, 420.0, 1800.0, 3600.0])


def test_column_mapping(tmp_path):
    header = "stamp,Tair_C,Rn,wind,rain,TC0,TC1,TC2,TC5"
    path = write_csv(tmp_path, good_rows(), header)
    cols = {"stamp": "time", "Tair_C": "T_air", "Rn": "q_net"}
    cols |= {"TC0": "T_0cm", "TC1": "T_1cm", "TC2": "T_2cm", "TC5": "T_5cm"}
    m = read_csv_case(path, sigma=0.25, columns=cols)
    ref = read_csv_case(write_csv(tmp_path, good_rows(), name="ref.csv"), sigma=0.25)
    assert m.data_hash() == ref.data_hash()


def test_window_selection(tmp_path):
    path = write_csv(tmp_path, good_rows(12))
    m = read_csv_case(path, sigma=0.25, window_hours=(0.5, 1.5))
    assert m.n_obs == 5
    np.testing.assert_allclose(m.t, np.arange(5) * 900.0)
    assert m.time0 == "2004-06-06T00:30:00Z"
    assert m.T_air[0] == pytest.approx(15.2)


def test_gap_fill_within_limit(tmp_path):
    rows = good_rows(8)
    rows[2][1] = ""
    rows[3][1] = "NaN"
    rows[5][6] = "NA"
    m = read_csv_case(write_csv(tmp_path, rows), sigma=0.25, max_gap_fill=2)
    np.testing.assert_allclose(m.T_air[2:4], [15.2, 15.3])
    np.testing.assert_allclose(m.T_obs[5, 1], 16.0)
    assert m.fill_report == (("T_air", 3, 4), ("T_1cm", 6, 6))


def test_gap_fill_irregular_is_linear_in_time(tmp_path):
    rows = good_rows(4)
    rows[1][0] = "2004-06-06T00:05:00Z"  # 5 min after, then 25 min gap to 00:30
    rows[1][1] = ""
    m = read_csv_case(write_csv(tmp_path, rows), sigma=0.25, max_gap_fill=1)
    assert m.T_air[1] == pytest.approx(15.0 + (15.2 - 15.0) * 5 / 30)


def test_large_time_gap_warns(tmp_path):
    rows = good_rows(6)
    rows[5][0] = "2004-06-06T09:00:00Z"
    with pytest.warns(UserWarning, match=r"large time gap.*data row 5 .*data row 6"):
        read_csv_case(write_csv(tmp_path, rows), sigma=0.25)


def test_unknown_columns_warn(tmp_path):
    rows = [r + ["55"] for r in good_rows()]
    with pytest.warns(UserWarning, match="VWC"):
        read_csv_case(write_csv(tmp_path, rows, HEADER + ",VWC"), sigma=0.25)


def test_extras_columns_of_the_case_csv_are_read(tmp_path):
    """RH (and T_surf_IR, SW_in, ...) in the case CSV itself land in ``extras``, no warning."""
    rows = [r + ["55"] for r in good_rows()]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = read_csv_case(write_csv(tmp_path, rows, HEADER + ",RH"), sigma=0.25)
    np.testing.assert_array_equal(m.extras["RH"], 55.0)
    rows = [r + ["0.55"] for r in good_rows()]
    with pytest.raises(DataError, match=r"column 'RH'.*looks like a fraction"):
        read_csv_case(write_csv(tmp_path, rows, HEADER + ",RH"), sigma=0.25)


def test_no_warning_on_clean_file():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_csv_case(REFERENCE, sigma=0.25)


# --------------------------------------------------------------------------- bad input


def test_missing_file(tmp_path):
    expect_error(tmp_path / "nope.csv", "not found")


def test_empty_file(tmp_path):
    path = tmp_path / "empty.csv"
    path.write_text("")
    expect_error(path, "empty")


def test_header_only(tmp_path):
    expect_error(write_csv(tmp_path, []), "no data rows")


def test_missing_column_suggests(tmp_path):
    header = HEADER.replace("T_air", "Tair")
    msg = expect_error(write_csv(tmp_path, good_rows(), header), "'T_air'", "did you mean 'Tair'")
    assert "Columns in the file" in msg


def test_mapping_names_absent_column(tmp_path):
    path = write_csv(tmp_path, good_rows())
    expect_error(path, "'Tair_C'", "not in the file", columns={"Tair_C": "T_air"})


def test_mapping_backwards_hint(tmp_path):
    header = HEADER.replace("T_air", "Tair")
    path = write_csv(tmp_path, good_rows(), header)
    expect_error(path, "file column -> role", "{'Tair': 'T_air'}", columns={"T_air": "Tair"})


def test_mapping_to_unknown_role(tmp_path):
    path = write_csv(tmp_path, good_rows())
    expect_error(path, "'wind'", "not a role", columns={"wind": "windspeed"})


def test_mapping_clash(tmp_path):
    rows = [r + [r[1]] for r in good_rows()]
    path = write_csv(tmp_path, rows, HEADER + ",Tair")
    expect_error(path, "'Tair'", "'T_air'", "both provide", columns={"Tair": "T_air"})


def test_duplicate_column_names(tmp_path):
    rows = [r + ["1"] for r in good_rows()]
    expect_error(write_csv(tmp_path, rows, HEADER + ",T_1cm"), "'T_1cm'", "duplicate", "line 1")


def test_wrong_field_count(tmp_path):
    rows = good_rows()
    rows[3] = rows[3][:-1]
    expect_error(write_csv(tmp_path, rows), "data row 4 (line 5)", "fields")


def test_non_numeric_cell(tmp_path):
    rows = good_rows()
    rows[4][6] = "12;3"
    expect_error(write_csv(tmp_path, rows), "'T_1cm'", "data row 5 (line 6)", "non-numeric")


def test_infinite_cell(tmp_path):
    rows = good_rows()
    rows[2][2] = "inf"
    expect_error(write_csv(tmp_path, rows), "'q_net'", "data row 3", "non-finite")


def test_empty_cell_without_fill(tmp_path):
    rows = good_rows()
    rows[3][5] = ""
    expect_error(write_csv(tmp_path, rows), "'T_0cm'", "data row 4 (line 5)", "max_gap_fill = 0")


def test_gap_longer_than_limit(tmp_path):
    rows = good_rows()
    for i in (2, 3, 4):
        rows[i][2] = ""
    msg = expect_error(write_csv(tmp_path, rows), "'q_net'", "data row 3", "data row 5", max_gap_fill=2)
    assert "3 consecutive" in msg


def test_gap_at_edge(tmp_path):
    rows = good_rows()
    rows[-1][1] = "nan"
    expect_error(write_csv(tmp_path, rows), "'T_air'", "data row 8", "edge", max_gap_fill=5)


def test_bad_time(tmp_path):
    rows = good_rows()
    rows[2][0] = "06/06/2004 00:30"
    expect_error(write_csv(tmp_path, rows), "'time'", "data row 3 (line 4)", "cannot parse time")


def test_duplicate_time(tmp_path):
    rows = good_rows()
    rows[3][0] = rows[2][0]
    expect_error(write_csv(tmp_path, rows), "'time'", "data row 4", "repeats")


def test_decreasing_time(tmp_path):
    rows = good_rows()
    rows[3][0], rows[4][0] = rows[4][0], rows[3][0]
    expect_error(write_csv(tmp_path, rows), "'time'", "data row 5", "strictly increasing")


def test_window_outside_data(tmp_path):
    path = write_csv(tmp_path, good_rows())
    expect_error(path, "'time'", "outside the data", "data row 1", window_hours=(0, 30))


def test_window_too_few_rows(tmp_path):
    path = write_csv(tmp_path, good_rows())
    expect_error(path, "'time'", "2 rows", "at least 3", window_hours=(0.5, 0.75))


def test_window_reversed(tmp_path):
    expect_error(write_csv(tmp_path, good_rows()), "start < end", window_hours=(1, 0.5))


def test_observed_not_above_bottom(tmp_path):
    path = write_csv(tmp_path, good_rows())
    expect_error(path, "'T_2cm'", "not shallower", observed=[0, 2], bottom=2)


def test_observed_without_column(tmp_path):
    path = write_csv(tmp_path, good_rows())
    expect_error(path, "'T_3cm'", "no column", "0, 1, 2, 5", observed=[0, 3])


def test_bottom_without_column(tmp_path):
    expect_error(write_csv(tmp_path, good_rows()), "'T_10cm'", "bottom", bottom=10)


def test_no_observed_sensor(tmp_path):
    rows = [r[:5] + [r[8]] for r in good_rows()]
    path = write_csv(tmp_path, rows, "time,T_air,q_net,wind,rain,T_5cm")
    expect_error(path, "no observed sensor")
    expect_error(path, "no observed sensor", "empty", observed=[])


def test_no_sensor_columns(tmp_path):
    rows = [r[:5] for r in good_rows()]
    expect_error(write_csv(tmp_path, rows, "time,T_air,q_net,wind,rain"), "T_<depth>cm")


def test_kelvin(tmp_path):
    rows = good_rows()
    for r in rows:
        r[7] = f"{float(r[7]) + 273.15:.2f}"
    expect_error(write_csv(tmp_path, rows), "'T_2cm'", "data row 1", "looks like kelvin, convert to °C")


def test_implausible_temperature(tmp_path):
    rows = good_rows()
    rows[6][1] = "-99.9"
    expect_error(write_csv(tmp_path, rows), "'T_air'", "data row 7 (line 8)", "implausible")


def test_implausible_radiation(tmp_path):
    rows = good_rows()
    rows[1][2] = "-9999"
    expect_error(write_csv(tmp_path, rows), "'q_net'", "data row 2", "-9999")


@pytest.mark.parametrize(("col", "name"), [(3, "wind"), (4, "rain")])
def test_negative_wind_or_rain(tmp_path, col, name):
    rows = good_rows()
    rows[5][col] = "-0.5"
    expect_error(write_csv(tmp_path, rows), f"'{name}'", "data row 6", f"negative {name}")


@pytest.mark.parametrize("sigma", [0.0, -0.25, float("nan"), "0.25"])
def test_bad_sigma(tmp_path, sigma):
    expect_error(write_csv(tmp_path, good_rows()), "sigma", sigma=sigma)


def test_bad_max_gap_fill(tmp_path):
    expect_error(write_csv(tmp_path, good_rows()), "max_gap_fill", max_gap_fill=-1)


def test_error_message_shape(tmp_path):
    rows = good_rows()
    rows[4][6] = "abc"
    msg = expect_error(write_csv(tmp_path, rows))
    assert re.fullmatch(r".+case\.csv, column 'T_1cm', data row 5 \(line 6\): .+", msg)
