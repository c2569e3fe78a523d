"""``make validate``: the shared real record (18 days over grass) fitted in daily windows with the
batch, measured 2 cm top and the 5 cm plate observed (``runs/grass_daily.toml``). Prints the
drift of kappa/C for the README; the record is read in place and the test skips without it."""

from __future__ import annotations

from pathlib import Path

import pytest

from pavement_mcmc.batch import TABLE, drift, read_table

REPO = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.slow


def test_grass_record_in_daily_windows(grass_csv, tmp_path):
    from pavement_mcmc.cli import main

    out = tmp_path / "grass_daily"
    code = main(["batch", str(REPO / "runs" / "grass_daily.toml"), "--window", "24h", "--step", "24h",
                 "--out", str(out), "--seed", "1", "--no-progress"])
    rows = read_table(out / TABLE)
    assert code in (0, 1) and len(rows) == 18
    assert all(r["status"] != "failed" for r in rows), [r["reason"] for r in rows]
    d = drift(rows, "diffusivity")
    print(d.text(1e6, "mm2/s"))
    print(drift(rows, "kappa").text(1.0, "W/m/K"))
    # the expected range of a moist loam (the record's README): 0.3-0.7 mm2/s, allow 0.15-1.0
    assert all(0.15e-6 < r["diffusivity"] < 1.0e-6 for r in rows)
    assert (out / "batch.png").is_file()
