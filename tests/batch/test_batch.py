"""Batch fits on Dask (issue 13): worker-count independence, a worker killed mid-unit, a batch
killed and run again. Three 6 h windows of the reference case, two h pieces each, a small ESS
target (about 1 s a unit)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.batch import (
    TABLE,
    Failure,
    map_units,
    parse_duration,
    read_table,
    run_batch,
    unit_seed,
    window_units,
)
from pavement_mcmc.data import ConfigError

REPO = Path(__file__).resolve().parents[2]
SMALL = {"model": {"h": {"kind": "uniform", "n": 2}},
         "sampler": {"ess_target": 100, "max_steps": 2000, "n_walkers": 8}}
KEYS = ["caseA@0-6h", "caseA@6-12h", "caseA@12-18h"]


def _units():
    return window_units(REPO / "runs" / "caseA.toml", windows=[(0, 6), (6, 12), (12, 18)],
                        overrides=SMALL)


def _failed_units(out: Path) -> str:
    """The units whose row says failed, with the reason (what a differing table hides)."""
    import json

    rows = [json.loads(p.read_text()) for p in sorted(out.glob("*/unit.json"))]
    return "; ".join(f"{r['key']}: {r['reason']}" for r in rows if r["status"] == "failed")


def _counts(counter: Path) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for line in counter.read_text().splitlines() if counter.exists() else []:
        key, pid = line.split()
        out.setdefault(key, []).append(pid)
    return out


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The undisturbed batch on two workers."""
    out = tmp_path_factory.mktemp("batch_ref")
    rows = run_batch(_units(), out, seed=5, n_workers=2)
    return out, rows


def test_units_seeds_and_durations():
    units = _units()
    assert [u.key for u in units] == KEYS
    assert units[1].start_time == "2004-06-06T06:00:00Z"
    cut = window_units(REPO / "runs" / "caseA.toml", "8h", "6h")
    assert [u.window_hours for u in cut] == [(0, 8), (6, 14), (12, 20), (18, 26)]
    assert parse_duration("24h") == 24 and parse_duration("90m") == 1.5 and parse_duration("1d") == 24
    with pytest.raises(ConfigError):
        parse_duration("-3h")
    assert unit_seed(5, "a") == unit_seed(5, "a") != unit_seed(5, "b") != unit_seed(6, "b")


def test_one_and_two_workers_give_the_same_table_bit_for_bit(reference, tmp_path):
    ref, rows = reference
    assert all(r["status"] in ("ok", "not converged") for r in rows), rows
    assert all(r["kappa_lo"] < r["kappa"] < r["kappa_hi"] and r["h_mean"] > 0 for r in rows)
    assert (ref / KEYS[0] / "chain.h5").is_file() and (ref / KEYS[0] / "summary.md").is_file()
    run_batch(list(reversed(_units())), tmp_path, seed=5, n_workers=1)  # other order, one worker
    one = {r["key"]: r for r in read_table(tmp_path / TABLE)}
    two = {r["key"]: r for r in read_table(ref / TABLE)}
    assert one.keys() == two.keys()
    for k in one:  # float repr in the CSV: equal text = equal bits
        assert {c: str(v) for c, v in one[k].items()} == {c: str(v) for c, v in two[k].items()}


def test_a_worker_killed_mid_unit_is_retried_and_changes_nothing(reference, tmp_path):
    from distributed import Client, LocalCluster

    ref, _ = reference
    counter = tmp_path / "starts.txt"
    target = tmp_path / "out" / "caseA@6-12h"
    done = {}
    with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None,
                      silence_logs=50) as cluster, Client(cluster) as client:
        th = threading.Thread(target=lambda: done.setdefault("rows", run_batch(
            _units(), tmp_path / "out", seed=5, client=client, counter=counter)))
        th.start()
        t0 = time.time()
        while "caseA@6-12h" not in _counts(counter) or not (target / "chain.h5").exists():
            assert time.time() - t0 < 60, "the unit never started"
            time.sleep(0.05)
        time.sleep(0.1)  # mid-sampling: some blocks are saved, more are coming
        os.kill(int(_counts(counter)["caseA@6-12h"][0]), signal.SIGKILL)
        th.join(timeout=120)
    starts = _counts(counter)["caseA@6-12h"]
    assert len(starts) == 2 and starts[0] != starts[1], starts  # run again on a new process
    assert (tmp_path / "out" / TABLE).read_bytes() == (ref / TABLE).read_bytes(), \
        _failed_units(tmp_path / "out")


def test_a_killed_batch_run_again_skips_finished_units(reference, tmp_path):
    ref, _ = reference
    counter = tmp_path / "starts.txt"
    out = tmp_path / "out"
    code = (f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); "
            "from test_batch import _units; from pavement_mcmc.batch import run_batch; "
            f"run_batch(_units(), {str(out)!r}, seed=5, n_workers=1, counter={str(counter)!r})")
    proc = subprocess.Popen([sys.executable, "-c", code], start_new_session=True,
                            stderr=subprocess.DEVNULL)
    t0 = time.time()
    while len(list(out.glob("*/unit.json"))) < 1:
        assert time.time() - t0 < 90 and proc.poll() is None, "no unit finished"
        time.sleep(0.05)
    time.sleep(0.3)
    os.killpg(proc.pid, signal.SIGKILL)  # the batch and its workers
    proc.wait()
    finished = {p.parent.name: p.stat().st_mtime_ns for p in out.glob("*/unit.json")}
    assert finished and not (out / TABLE).exists()
    run_batch(_units(), out, seed=5, n_workers=2, counter=counter)
    counts = _counts(counter)
    for key, mtime in finished.items():
        assert len(counts[key]) == 1 and (out / key / "unit.json").stat().st_mtime_ns == mtime
    assert (out / TABLE).read_bytes() == (ref / TABLE).read_bytes(), _failed_units(out)


def _square(x, fail_on=None):
    if x == fail_on:
        raise RuntimeError(f"bad unit {x}")
    return x * x


def test_map_units_keeps_order_and_records_failures():
    seen = []
    out = map_units(_square, [3, 1, 2], n_workers=1, retries=0, fail_on=2,
                    on_done=lambda i, r: seen.append(i))
    assert out[:2] == [9, 1] and isinstance(out[2], Failure) and "bad unit 2" in out[2].reason
    assert sorted(seen) == [0, 1, 2]


def test_cli_batch_lists_a_bad_window_and_runs_the_others(tmp_path, capsys):
    from pavement_mcmc.cli import main

    out = tmp_path / "b"
    code = main(["batch", str(REPO / "runs" / "caseA.toml"), "--windows", "0-6", "20-60", "--out",
                 str(out), "--workers", "1", "--no-progress", "--seed", "5",
                 "--set", "model.h.kind=uniform", "model.h.n=2", "sampler.ess_target=100",
                 "sampler.max_steps=2000", "sampler.n_walkers=8"])
    text = capsys.readouterr().out
    assert code == 1 and "FAILED caseA@20-60h" in text, text
    rows = read_table(out / TABLE)
    assert rows[0]["status"] in ("ok", "not converged") and rows[1]["status"] == "failed"
    assert (out / "batch.png").stat().st_size > 10_000 and (out / "caseA@0-6h" / "chain.h5").is_file()


def test_drift_measures_trend_and_scatter_in_units_of_the_intervals():
    from pavement_mcmc.batch import drift

    rows = [{"status": "ok", "start_h": 24.0 * i, "end_h": 24.0 * i + 24, "x": 1.0 + 0.1 * i,
             "x_lo": 0.9 + 0.1 * i, "x_hi": 1.1 + 0.1 * i} for i in range(5)]
    d = drift(rows, "x")
    assert d.n == 5 and d.slope == pytest.approx(0.1) and d.half_width == pytest.approx(0.1)
    assert d.chi2_dof == pytest.approx(np.sum(((np.arange(5) - 2) * 0.1 / (0.2 / 3.92)) ** 2) / 4)


@pytest.mark.skipif(not os.access("/proc/self/clear_refs", os.W_OK), reason="needs Linux >= 4.0")
def test_a_units_peak_memory_is_its_own_not_the_processs_lifetime_peak():
    """issue 25: the worker's peak since the unit started (VmHWM reset at its start); the old
    ru_maxrss counted every earlier unit and the process the worker was forked from."""
    import resource

    from pavement_mcmc.batch.unit import _peak_rss_mb, _reset_peak_rss

    big = np.ones(400 * 2**20 // 8)  # 400 MB, written, then freed: an earlier unit's peak
    del big
    lifetime = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    _reset_peak_rss()
    small = np.ones(50 * 2**20 // 8)  # this unit: 50 MB on top of what the process holds
    peak = _peak_rss_mb()
    del small
    assert peak < lifetime - 300, (peak, lifetime)
    assert peak >= 50


def _hog(x):
    big = np.ones(800 * 2**20 // 8)  # 800 MB: over the worker's limit
    time.sleep(10)
    return float(big.sum())


def test_a_units_cpu_time_is_recorded_apart_from_its_wall_time(tmp_path, monkeypatch):
    """batch_costs.csv's cpu_s counts the worker's CPU, not the wait for a core: a unit that
    sleeps 0.4 s and computes 0.2 s costs 0.6 s of wall time and about 0.2 s of CPU."""
    from pavement_mcmc.batch import unit as unit_mod

    def fake_sample(*args):
        time.sleep(0.4)
        t = time.process_time()
        while time.process_time() - t < 0.2:
            pass
        return True

    monkeypatch.setattr(unit_mod, "_sample_when_free", fake_sample)
    monkeypatch.setattr(unit_mod, "unit_row", lambda run_dir: {"status": "ok"})
    u = unit_mod.Unit("x@0-1h", str(tmp_path / "x.toml"), "x", (0.0, 1.0))
    rec = unit_mod.run_unit(u, tmp_path)
    assert rec["elapsed_s"] >= 0.6
    assert 0.19 <= rec["cpu_s"] < 0.45, rec


@pytest.mark.slow  # about 40 s: a worker started, killed and started again
def test_a_worker_out_of_memory_is_reported_for_its_unit_and_the_others_run():
    """issue 24: a worker killed for its memory (the nanny's limit here; the kernel's OOM
    killer alike) fails its own unit with a reason that says so, not the batch."""
    import dask
    from distributed import Client, LocalCluster

    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), \
            LocalCluster(n_workers=1, threads_per_worker=1, memory_limit="400MB",
                         dashboard_address=None, silence_logs=50) as cluster, Client(cluster) as c:
        out = map_units(_hog, [1], client=c, retries=0)
        ok = map_units(_square, [3], client=c, retries=0)
    assert isinstance(out[0], Failure) and "KilledWorker" in out[0].reason, out
    assert "out of memory?" in out[0].reason and ok == [9]


def test_a_unit_whose_run_failed_is_retried_not_read_back_as_sampled(tmp_path):
    """An error outside UNIT_ERRORS leaves result.json saying failed and no unit.json, and goes
    to Dask to be retried: the retry must sample again, not take the failed run for a sampled
    one and report its partial chain as 'not converged'."""
    from pavement_mcmc.batch.unit import run_unit
    from pavement_mcmc.runs import RunFolder

    unit = _units()[0]
    first = run_unit(unit, tmp_path, seed := 5)
    assert first["status"] == "ok", first
    folder = RunFolder(tmp_path / first["run_dir"])
    folder.unit.unlink()
    folder.write_result({"failed": True, "converged": False,
                         "reason": "failed: RuntimeError: worker lost its GPU"})
    row = run_unit(unit, tmp_path, seed)
    assert row["status"] == "ok" and "RuntimeError" not in row["reason"], row
    assert folder.state == "finished"
