"""The AmeriFlux / FLUXNET preset: a flux-site file read as it is (data/fluxsite.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.data import ConfigError, DataError, load_case

HEADER = ("TIMESTAMP_START,TIMESTAMP_END,TA_1_1_1,NETRAD,WS,RH,P,TS_1_1_1,TS_1_2_1,TS_1_3_1,"
          "G_1_1_1,T_CANOPY,LE,H,FC")
N = 10


def _site(tmp_path: Path, header: str = HEADER) -> Path:
    """Half-hourly rows from 2021-07-01 00:00 local standard time (UTC-7)."""
    rows = []
    for i in range(N):
        start = f"2021070{1 + (i // 48)}{(i % 48) // 2:02d}{30 * (i % 2):02d}"
        j = i + 1
        end = f"2021070{1 + (j // 48)}{(j % 48) // 2:02d}{30 * (j % 2):02d}"
        le = "-9999" if i == 4 else f"{50 + i:.1f}"
        rows.append(f"{start},{end},{20 + 0.1 * i:.2f},{-50 + 10 * i:.1f},1.5,40,0,"
                    f"{25 + 0.1 * i:.2f},{24 + 0.05 * i:.2f},{23:.2f},{-20 + i:.1f},{18 + 0.2 * i:.2f},"
                    f"{le},{30 + i:.1f},-9999")
    path = tmp_path / "US-Xyz_HH.csv"
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def _toml(tmp_path: Path, data: str) -> Path:
    path = tmp_path / "site.toml"
    path.write_text('[data]\ncsv = "US-Xyz_HH.csv"\nsigma = 0.1\npreset = "ameriflux"\n' + data)
    return path


DEPTHS = "[data.depths_cm]\nTS_1_1_1 = 5\nTS_1_2_1 = 10\nTS_1_3_1 = 30\nG_1_1_1 = 8\n"


def test_ameriflux_file_read_as_it_is(tmp_path):
    _site(tmp_path)
    m = load_case(_toml(tmp_path, "utc_offset_hours = -7\nmax_gap_fill = 1\n" + DEPTHS)).measurements
    assert m.time0 == "2021-07-01T07:15:00Z"  # 00:00-00:30 MST, the middle, in UTC
    np.testing.assert_allclose(m.t, 1800.0 * np.arange(N))
    np.testing.assert_allclose(m.depths, [0.05, 0.10])
    assert m.bottom_depth == pytest.approx(0.30) and m.plate_labels == ["G8cm"]
    np.testing.assert_allclose(m.T_air, 20 + 0.1 * np.arange(N), atol=1e-9)
    np.testing.assert_allclose(m.q_net, -50 + 10 * np.arange(N))
    assert m.rain is not None and m.wind is not None
    assert set(m.extras) == {"RH", "T_surf_IR", "LE", "H"}
    assert m.extras["LE"][4] == pytest.approx(54.0)  # -9999 is missing, filled between 53 and 55
    assert m.fill_report == (("LE", 5, 5),)


def test_timestamp_end_and_a_rename_overrides_the_preset(tmp_path):
    _site(tmp_path)
    m = load_case(_toml(tmp_path, 'utc_offset_hours = -7\ntimestamp = "end"\nmax_gap_fill = 1\n'
                                  '[data.columns]\nT_CANOPY = "T_air"\n' + DEPTHS)).measurements
    assert m.time0 == "2021-07-01T07:30:00Z"
    np.testing.assert_allclose(m.T_air, 18 + 0.2 * np.arange(N), atol=1e-9)  # T_CANOPY now
    assert "T_surf_IR" not in m.extras


def test_preset_errors_are_clear(tmp_path):
    _site(tmp_path)
    with pytest.raises(DataError, match=r"needs utc_offset_hours"):
        load_case(_toml(tmp_path, DEPTHS))
    with pytest.raises(DataError, match=r"no soil temperature with a depth.*TS_1_1_1 = 5.*"
                                        r"TS_1_1_1, TS_1_2_1, TS_1_3_1"):
        load_case(_toml(tmp_path, "utc_offset_hours = -7\n"))
    with pytest.raises(DataError, match=r"depths_cm names TS_9_9_9, not in the file"):
        load_case(_toml(tmp_path, "utc_offset_hours = -7\n[data.depths_cm]\nTS_9_9_9 = 5\n"))
    _site(tmp_path, HEADER.replace("NETRAD", "TA_1_2_1"))
    with pytest.raises(DataError, match=r"'TA_1_1_1' and 'TA_1_2_1' both give 'T_air'"):
        load_case(_toml(tmp_path, "utc_offset_hours = -7\n" + DEPTHS))
    with pytest.raises(ConfigError, match=r"belong to a flux-site preset"):
        p = tmp_path / "plain.toml"
        p.write_text('[data]\ncsv = "US-Xyz_HH.csv"\nsigma = 0.1\nutc_offset_hours = -7\n')
        load_case(p)


def test_fluxnet_prefers_the_consolidated_columns(tmp_path):
    header = HEADER.replace("TA_1_1_1", "TA_F").replace("FC", "TA_F_MDS")
    _site(tmp_path, header)
    toml = _toml(tmp_path, "utc_offset_hours = -7\nmax_gap_fill = 1\n" + DEPTHS)
    toml.write_text(toml.read_text().replace('"ameriflux"', '"fluxnet"'))
    m = load_case(toml).measurements  # TA_F (20 + 0.1 i) taken, TA_F_MDS (-9999) left
    np.testing.assert_allclose(m.T_air, 20 + 0.1 * np.arange(N), atol=1e-9)


def test_minus_9999_is_missing_however_it_is_written(tmp_path):
    """A file re-saved by a spreadsheet or pandas writes the missing value as -9999.0: still
    missing, not a reading of -9999 W m-2 refused as out of range."""
    path = _site(tmp_path)
    path.write_text(path.read_text().replace(",-9999,", ",-9999.0,"))
    assert ",-9999.0," in path.read_text()
    m = load_case(_toml(tmp_path, "utc_offset_hours = -7\nmax_gap_fill = 1\n" + DEPTHS)).measurements
    assert m.extras["LE"][4] == pytest.approx(54.0)
    assert m.fill_report == (("LE", 5, 5),)


@pytest.mark.parametrize("offset", ["30", "nan", "-15"])
def test_an_impossible_utc_offset_is_a_clear_error(tmp_path, offset):
    _site(tmp_path)
    with pytest.raises(DataError, match=r"utc_offset_hours = .*between -12 and \+14"):
        load_case(_toml(tmp_path, f"utc_offset_hours = {offset}\nmax_gap_fill = 1\n" + DEPTHS))


def test_the_whole_records_times_of_a_preset_case_and_of_a_renamed_time_column(tmp_path):
    """record_times (batch windows, ``pavement-mcmc rolling``) looked for a column named
    ``time``: a flux-site file has TIMESTAMP_START/END, a renamed one another name, and both
    were refused ("no 'time' column to cut windows from")."""
    from pavement_mcmc.batch import window_units
    from pavement_mcmc.data import record_times

    _site(tmp_path)
    case = _toml(tmp_path, "utc_offset_hours = -7\nmax_gap_fill = 1\nwindow_hours = [0, 2]\n"
                 + DEPTHS)
    times = record_times(case)
    assert len(times) == N and times[0] == "2021-07-01T07:15:00Z"
    assert times[-1] == "2021-07-01T11:45:00Z"  # the window does not cut the record
    assert [u.window_hours for u in window_units(case, "2h", "2h")] == [(0.0, 2.0), (2.0, 4.0)]
    plain = tmp_path / "plain.csv"
    plain.write_text("stamp,T_air,q_net,T_0cm,T_5cm\n" + "".join(
        f"2021-07-01T{h:02d}:00:00Z,20,100,21,20\n" for h in range(6)))
    renamed = tmp_path / "renamed.toml"
    renamed.write_text('[data]\ncsv = "plain.csv"\nsigma = 0.1\n[data.columns]\nstamp = "time"\n')
    assert record_times(renamed) == [f"2021-07-01T{h:02d}:00:00Z" for h in range(6)]
