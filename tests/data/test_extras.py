"""Extras (T_surf_IR, RH, radiation components) from a second CSV merged on time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.data import ConfigError, DataError, load_case, read_csv_case
from pavement_mcmc.posterior import build_problem

HEADER = "time,T_air,q_net,T_0cm,T_2cm,T_5cm"
N = 12


def _stamp(minutes: int) -> str:
    return f"2004-06-06T{minutes // 60:02d}:{minutes % 60:02d}:00Z"


def _case_csv(tmp_path: Path) -> Path:
    rows = [f"{_stamp(30 * i)},{15 + 0.1 * i:.2f},{-80 + 10 * i:.1f},{15 + 0.2 * i:.2f},"
            f"{15.5 + 0.1 * i:.2f},{16.0 + 0.05 * i:.2f}" for i in range(N)]
    path = tmp_path / "case.csv"
    path.write_text(HEADER + "\n" + "\n".join(rows) + "\n")
    return path


def _extras_csv(tmp_path: Path, step: int = 15, shift: int = 0, n: int = 2 * N + 4,
                header: str = "time,T_surf_IR,SW_in,WS_2m") -> Path:
    """Rows every ``step`` minutes from ``shift``; T_surf_IR = 20 + minute / 60, SW_in = minute."""
    rows = []
    for i in range(n):
        m = shift + step * i
        rows.append(f"{_stamp(m)},{20 + m / 60:.4f},{m:.1f},1.0")
    path = tmp_path / "extras.csv"
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def test_merged_on_the_case_times(tmp_path):
    """A finer and longer extras file gives its values at the case's window times, read-only."""
    m = read_csv_case(_case_csv(tmp_path), sigma=0.1, extras=_extras_csv(tmp_path),
                      window_hours=(1.0, 4.0))
    minutes = 60 + m.t / 60
    np.testing.assert_allclose(m.extras["T_surf_IR"], 20 + minutes / 60, atol=1e-4)
    np.testing.assert_allclose(m.extras["SW_in"], minutes)
    assert set(m.extras) == {"T_surf_IR", "SW_in"}  # WS_2m is not an extras role
    with pytest.raises((TypeError, ValueError)):
        m.extras["SW_in"][0] = 1.0
    sub = m.select_rows([0, 2, 4])
    np.testing.assert_array_equal(sub.extras["SW_in"], m.extras["SW_in"][[0, 2, 4]])
    plain = read_csv_case(_case_csv(tmp_path), sigma=0.1, window_hours=(1.0, 4.0))
    assert plain.extras == {} and plain.data_hash() != m.data_hash()


def test_misaligned_times_refused(tmp_path):
    """A clock shift of 7 min: no extras row at the case's times -> the first missing time named."""
    with pytest.raises(DataError, match=r"extras\.csv, column 'time': no row at "
                                        r"2004-06-06T00:00:00Z.*12 of the window's 12 times"):
        read_csv_case(_case_csv(tmp_path), sigma=0.1, extras=_extras_csv(tmp_path, shift=7))


def test_extras_ending_early_refused(tmp_path):
    with pytest.raises(DataError, match=r"no row at 2004-06-06T05:00:00Z.*2 of the window"):
        read_csv_case(_case_csv(tmp_path), sigma=0.1, extras=_extras_csv(tmp_path, step=30, n=N - 2))


def test_extras_file_without_extras_columns_refused(tmp_path):
    path = _extras_csv(tmp_path, header="time,IR_skin,SW_down,WS_2m")
    with pytest.raises(DataError, match=r"no extras column in the file.*T_surf_IR"):
        read_csv_case(_case_csv(tmp_path), sigma=0.1, extras=path)
    m = read_csv_case(_case_csv(tmp_path), sigma=0.1, extras=path,  # a rename maps it
                      columns={"IR_skin": "T_surf_IR"})
    assert set(m.extras) == {"T_surf_IR"}


def test_role_in_both_files_refused(tmp_path):
    case = _case_csv(tmp_path)
    lines = case.read_text().splitlines()
    case.write_text("\n".join([lines[0] + ",SW_in"] + [ln + ",5" for ln in lines[1:]]) + "\n")
    with pytest.raises(DataError, match=r"'SW_in' is also a column of .*case\.csv"):
        read_csv_case(case, sigma=0.1, extras=_extras_csv(tmp_path))


def _toml(tmp_path: Path, extra: str) -> Path:
    _case_csv(tmp_path)
    path = tmp_path / "case.toml"
    path.write_text(f'[data]\ncsv = "case.csv"\nsigma = 0.1\n{extra}\n')
    return path


def test_ir_sigma_without_the_column_is_a_config_error(tmp_path):
    _extras_csv(tmp_path, header="time,RH,SW_in,WS_2m")
    cfg = load_case(_toml(tmp_path, 'extras = "extras.csv"\nir_sigma = 0.5'))
    assert set(cfg.measurements.extras) == {"RH", "SW_in"}
    with pytest.raises(ConfigError, match=r"case\.toml: ir_sigma is set but the data have no "
                                          r"'T_surf_IR' column"):
        build_problem(cfg)


def test_extras_file_not_found(tmp_path):
    with pytest.raises(ConfigError, match=r"data\.extras = 'nope\.csv': file not found"):
        load_case(_toml(tmp_path, 'extras = "nope.csv"'))


def test_ir_stream_adds_its_offset_and_blob(tmp_path):
    _extras_csv(tmp_path)
    cfg = load_case(_toml(tmp_path, 'extras = "extras.csv"\nir_sigma = 0.5'))
    pb = build_problem(cfg)
    assert pb.space.free[-1] == "ir_offset"
    assert pb.posterior.blob_names[-1] == "rmse_IR"
    assert pb.posterior.n_whitened == 3 * (N - 1)  # T_0cm, T_2cm (T_5cm: the bottom), IR
    with pytest.raises(ConfigError, match="measured top"):
        build_problem(load_case(_toml(tmp_path, 'extras = "extras.csv"\nir_sigma = 0.5\n'
                                                '[model]\ntop = "measured"')))


def test_unfillable_gap_in_an_unused_extra_does_not_refuse_the_case(tmp_path):
    """Flux-site extras (LE, H, SW_out ...) have long gaps: a series nobody uses must not make
    the case unreadable. It keeps NaN where it cannot be filled; the IR stream, which uses
    T_surf_IR, refuses its gap clearly."""
    path = _extras_csv(tmp_path)
    lines = path.read_text().splitlines()
    for k in (1, 2, 3, 4, 5):  # 00:00-01:00: the window's first three times, an edge gap
        t, ir, sw, ws = lines[k].split(",")
        lines[k] = f"{t},,,{ws}"
    path.write_text("\n".join(lines) + "\n")
    m = read_csv_case(_case_csv(tmp_path), sigma=0.1, extras=path)
    assert np.isnan(m.extras["SW_in"][:3]).all() and np.isfinite(m.extras["SW_in"][3:]).all()
    np.testing.assert_allclose(m.extras["SW_in"][3:], m.t[3:] / 60)  # SW_in = minute
    with pytest.raises(ConfigError, match=r"T_surf_IR has 3 missing values.*window_hours"):
        build_problem(load_case(_toml(tmp_path, 'extras = "extras.csv"\nir_sigma = 0.5')))


def test_unfillable_gap_in_an_extra_of_the_case_csv_stays_nan(tmp_path):
    path = _case_csv(tmp_path)
    lines = path.read_text().splitlines()
    lines[0] += ",RH"
    lines[1:] = [ln + ("," if k >= N - 2 else ",55") for k, ln in enumerate(lines[1:])]
    path.write_text("\n".join(lines) + "\n")
    m = read_csv_case(path, sigma=0.1)
    assert np.isnan(m.extras["RH"][-2:]).all() and (m.extras["RH"][:-2] == 55).all()


def test_a_plate_from_the_second_file_is_a_plate(tmp_path):
    """A flux series of the extras file renamed ``G_<d>cm`` becomes a heat-flux plate (the
    desert record's storage-corrected flux lives there); it must be complete in the window,
    and it may sit at the depth of a measured top sensor (its flux is the top's)."""
    ex = _extras_csv(tmp_path, header="time,T_surf_IR,Gflux,WS_2m")  # Gflux = minute
    m = read_csv_case(_case_csv(tmp_path), sigma=0.1, extras=ex, columns={"Gflux": "G_2cm"})
    assert m.plate_labels == ["G2cm"] and "G_2cm" not in m.extras
    np.testing.assert_allclose(m.flux_depths, [0.02])
    np.testing.assert_allclose(m.G_obs[:, 0], 30.0 * np.arange(N))  # the case's times, not every row
    top = m.with_measured_top()  # the 0 cm sensor is the top; the plate 2 cm below it
    np.testing.assert_allclose(top.flux_depths, [0.02])

    at_top = read_csv_case(_case_csv(tmp_path), sigma=0.1, extras=ex, columns={"Gflux": "G_0cm"},
                           observed=[0, 2])
    assert at_top.with_measured_top().flux_depths.tolist() == [0.0]

    lines = ex.read_text().splitlines()
    t, ir, _, ws = lines[7].split(",")
    lines[7] = f"{t},{ir},,{ws}"  # one reading missing at a case time (minute 90)
    ex.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"extras\.csv, column 'Gflux'.*missing value"):
        read_csv_case(_case_csv(tmp_path), sigma=0.1, extras=ex, columns={"Gflux": "G_2cm"})
    with pytest.raises(DataError, match=r"'G_2cm' is also a column"):
        _extras_csv(tmp_path, header="time,T_surf_IR,G_2cm,WS_2m")
        read_csv_case(_case_csv(tmp_path), sigma=0.1, extras=tmp_path / "extras.csv",
                      columns={"T_5cm": "G_2cm"})



def _swc_csv(tmp_path: Path, scale: float, name: str = "extras.csv") -> Path:
    """Rows every 15 min; SWC_5cm = scale x (0.05 + minute / 10000)."""
    rows = [f"{_stamp(15 * i)},{scale * (0.05 + 15 * i / 1e4):.5f}" for i in range(2 * N + 4)]
    path = tmp_path / name
    path.write_text("time,SWC_5cm\n" + "\n".join(rows) + "\n")
    return path


def test_soil_water_is_read_in_m3_per_m3_and_a_percentage_is_refused(tmp_path):
    """``SWC`` (renamed from a source's column) is merged like the other extras; the same
    series in % (the source's unit) is refused, naming the column and the unit."""
    m = read_csv_case(_case_csv(tmp_path), sigma=0.1, columns={"SWC_5cm": "SWC"},
                      extras=_swc_csv(tmp_path, 1.0), window_hours=(1.0, 4.0))
    np.testing.assert_allclose(m.extras["SWC"], 0.05 + (60 + m.t / 60) / 1e4, atol=1e-5)
    with pytest.raises(DataError, match=r"SWC_5cm.*looks like a percentage.*m3 m-3"):
        read_csv_case(_case_csv(tmp_path), sigma=0.1, columns={"SWC_5cm": "SWC"},
                      extras=_swc_csv(tmp_path, 100.0, "pct.csv"), window_hours=(1.0, 4.0))
    # a dry window of a file in %: 0.2-0.5 % reads as a plausible 0.2-0.5 m3 m-3; the rest of
    # the file (a wet spell of 30 %) shows the unit
    rows = [f"{_stamp(15 * i)},{0.2 + 0.01 * i if i < 20 else 30.0:.3f}" for i in range(2 * N + 4)]
    dry = tmp_path / "dry_pct.csv"
    dry.write_text("time,SWC_5cm\n" + "\n".join(rows) + "\n")
    with pytest.raises(DataError, match=r"SWC_5cm.*data row 21.*largest value in the file 30"):
        read_csv_case(_case_csv(tmp_path), sigma=0.1, columns={"SWC_5cm": "SWC"}, extras=dry,
                      window_hours=(1.0, 4.0))
