"""Field records: heat-flux plate columns, a measured top boundary, the real grass record."""

from __future__ import annotations

import numpy as np
import pytest

from pavement_mcmc.data import DataError, read_csv_case


def _csv(tmp_path, header, rows):
    p = tmp_path / "m.csv"
    p.write_text(",".join(header) + "\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n")
    return p


def _rows(n=6, g=None):
    out = []
    for i in range(n):
        r = [f"2020-04-05T{i:02d}:00:00Z", 10 + i, 100 * i, 9.0 + 0.1 * i, 8.5, 8.0, 7.0]
        if g is not None:
            r.append(g(i))
        out.append(r)
    return out


HEAD = ["time", "T_air", "q_net", "T_2cm", "T_5cm", "T_10cm", "T_50cm"]


def test_plate_columns_are_a_second_kind_of_observation(tmp_path):
    m = read_csv_case(_csv(tmp_path, HEAD + ["G_5cm"], _rows(g=lambda i: -10 + 5 * i)), sigma=0.1)
    np.testing.assert_allclose(m.flux_depths, [0.05])
    np.testing.assert_allclose(m.G_obs[:, 0], [-10, -5, 0, 5, 10, 15])
    assert m.plate_labels == ["G5cm"] and m.n_sensors == 3
    plain = read_csv_case(_csv(tmp_path, HEAD, _rows()), sigma=0.1)
    assert plain.G_obs is None and plain.data_hash() != m.data_hash()


def test_a_plate_below_the_bottom_or_out_of_range_is_refused(tmp_path):
    with pytest.raises(DataError, match=r"column 'G_60cm'.*not above the bottom boundary at 50 cm"):
        read_csv_case(_csv(tmp_path, HEAD + ["G_60cm"], _rows(g=lambda i: 1.0)), sigma=0.1)
    with pytest.raises(DataError, match=r"column 'G_5cm', data row 3.*value 5000 outside"):
        read_csv_case(_csv(tmp_path, HEAD + ["G_5cm"], _rows(g=lambda i: 5000 if i == 2 else 1)), sigma=0.1)


def test_measured_top_shifts_the_depths_and_keeps_the_labels(tmp_path):
    m = read_csv_case(_csv(tmp_path, HEAD + ["G_5cm"], _rows(g=lambda i: 1.0)), sigma=0.1)
    top = m.with_measured_top()
    np.testing.assert_allclose(top.depths, [0.03, 0.08])
    assert top.sensor_labels == ["5cm", "10cm"] and top.plate_labels == ["G5cm"]
    assert top.bottom_depth == pytest.approx(0.48) and top.depth_offset == pytest.approx(0.02)
    np.testing.assert_array_equal(top.T_top, m.T_obs[:, 0])
    x = np.array([0.0, 0.03, 0.48])
    np.testing.assert_allclose(top.initial_profile(x), [m.T_obs[0, 0], m.T_obs[0, 1], m.T_bottom[0]])
    assert top.data_hash() != m.data_hash()


def test_the_real_record_reads_with_its_plate(grass_csv):
    m = read_csv_case(grass_csv, sigma=0.1, window_hours=[168, 240])
    assert m.n_obs == 145 and m.plate_labels == ["G5cm"]
    np.testing.assert_allclose(m.depths * 100, [2, 5, 10, 20])
    assert m.bottom_depth == pytest.approx(0.5)


def test_run_summary_and_fit_output_state_the_plausibility(tiny_run):
    from pavement_mcmc.runs import load_run
    from pavement_mcmc.runs.tables import plausibility

    text = (tiny_run / "summary.md").read_text()
    assert "## Physical plausibility of the posterior means" in text
    problem, _ = load_run(tiny_run)
    found = plausibility(problem, [{"parameter": "kappa", "mean": 17.3},
                                   {"parameter": "C", "mean": 40.8e6}])
    assert [f.level for f in found] == ["alarm", "alarm"]
    assert plausibility(problem, [{"parameter": "kappa", "mean": 1.3},
                                  {"parameter": "C", "mean": 1.9e6}]) == []


def test_sensitivity_leaves_the_plate_factor_out_of_the_temperature_matrix(tmp_path):
    """A plate's calibration factor does not enter the temperatures: in the temperature
    sensitivity matrix it was a zero column ('no information', condition number inf on the
    grass record). It is left out, and the output says why."""
    import json

    from pavement_mcmc.analysis.sensitivity import default_names
    from pavement_mcmc.cli import main
    from pavement_mcmc.data import load_case
    from pavement_mcmc.posterior import build_problem
    from pavement_mcmc.synthetic.corpus import get_twin, write_twin

    case = write_twin(get_twin("field-none-s204"), tmp_path / "twin")
    text = case.read_text()
    text = text.replace('h = { kind = "per_interval", smooth = true }', 'h = { kind = "uniform", n = 4 }')
    text = text.replace("bottom_cm = 50.0", "bottom_cm = 50.0\nwindow_hours = [0, 24]")
    text = text.replace("dx = 0.005\ndt = 180.0\n", 'kind = "stretched"\n')
    text = text.replace('[parameters.gamma]\nprior = { dist = "rayleigh", scale = 2.22 }\n', "")
    case.write_text(text)
    pb = build_problem(load_case(case))
    assert "plate_G5cm" in pb.space.free
    assert "plate_G5cm" not in default_names(pb.space, pb.model)
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["sensitivity", str(case), "--json", "--out", str(tmp_path / "s")]) == 0
    out = json.loads(buf.getvalue())
    assert "plate_G5cm" not in out["max_abs"] and "kappa" in out["max_abs"]
    assert np.isfinite(out["identifiability"]["condition_number"])
    assert not any("plate_G5cm" in v for v in out["identifiability"]["verdict"])


HEAD_SOIL = ["time", "T_2cm", "T_5cm", "T_10cm", "T_50cm"]


def _soil_only(rows):
    return [[r[0], *r[3:]] for r in rows]


def test_a_measured_top_case_needs_no_air_temperature_or_radiation(tmp_path):
    """With the shallowest sensor as the top boundary the air temperature and net radiation do
    not enter the model: a soil-only record reads (forcing all NaN), a record whose forcing has
    a gap at the window's edge reads (the gap NaN), values present are still checked, and
    without a measured top both are refused as before."""
    soil = _csv(tmp_path, HEAD_SOIL, _soil_only(_rows()))
    with pytest.raises(DataError, match=r"column 'T_air': required column is missing"):
        read_csv_case(soil, sigma=0.1)
    m = read_csv_case(soil, sigma=0.1, forcing_optional=True)
    assert np.isnan(m.T_air).all() and np.isnan(m.q_net).all() and m.n_sensors == 3

    rows = _rows()
    rows[0][1] = rows[0][2] = ""  # the first row's air temperature and radiation missing
    gap = _csv(tmp_path, HEAD, rows)
    with pytest.raises(DataError, match=r"column 'T_air'.*edge of the time window"):
        read_csv_case(gap, sigma=0.1)
    m = read_csv_case(gap, sigma=0.1, forcing_optional=True)
    assert np.isnan(m.T_air[0]) and np.isfinite(m.T_air[1:]).all() and np.isnan(m.q_net[0])

    rows = _rows()
    rows[3][2] = 5000  # an impossible net radiation is still refused
    with pytest.raises(DataError, match=r"column 'q_net', data row 4.*outside"):
        read_csv_case(_csv(tmp_path, HEAD, rows), sigma=0.1, forcing_optional=True)


def test_a_forcing_gap_changes_nothing_in_a_measured_top_fit(tmp_path):
    """The case loader reads the forcing as optional when ``model.top = "measured"``; the
    posterior of a record with its air temperature and radiation blanked over a stretch is the
    posterior of the intact record, value for value (the gap cannot leak into the solver)."""
    from pavement_mcmc.data import load_case
    from pavement_mcmc.posterior import build_problem

    rows = [[f"2020-04-05T{i // 2:02d}:{30 * (i % 2):02d}:00Z", 10 + i, 50 * i,
             9.0 + 0.3 * np.sin(i / 3), 8.5 + 0.1 * np.sin(i / 3 - 0.5), 8.0, 7.0] for i in range(24)]
    blank = [r.copy() for r in rows]
    for r in blank[5:12]:
        r[1] = r[2] = ""
    lp = []
    for name, rr in (("intact", rows), ("blank", blank)):
        d = tmp_path / name
        d.mkdir()
        _csv(d, HEAD, rr)
        (d / "case.toml").write_text('[data]\ncsv = "m.csv"\nsigma = 0.1\n[model]\ntop = "measured"\n')
        pb = build_problem(load_case(d / "case.toml"))
        theta = np.array([[1.0, 2.0e6], [0.6, 1.5e6]])
        lp.append(pb.posterior.log_prob(theta))
    assert np.isfinite(lp[0]).all()
    np.testing.assert_array_equal(lp[0], lp[1])
