"""When does the grass radiometer see the surface warm? MAP fits of runs/grass_energy.toml (the IR
reading its skin node itself, ``[data] ir_storage_free = false``, as the case was before) with
the infrared surface temperature (``T_surf_IR``) shifted in time against every other column, and
with the air temperature corrected for the sun on the radiometer's body (the record's ``T_air``
is that body's temperature, 1-3 K warm in strong sun: ``T_air - b SW_in``).

For each shift (minutes; positive: the IR reading is moved later, so the model's skin is
compared with what the radiometer saw that long before) the in-sample RMSE of the buried
sensors, the IR RMSE, kappa, C, the plate's factor and the next-day forecast RMSE
(benchmarks/energy_records.py), then the IR residual (model minus radiometer, degC) in two-hour
bins of UTC for the record as it is and for the best shift, with a free lead, and for the case
as it is (the storage-free reading), the record not moved; and a free lead against the node's
relaxation time c_canopy / K. Shifted copies of the shared CSVs
go to a temporary folder and are deleted (the data are read from ../shared, never copied into
the project).

    PYTHONPATH=. python benchmarks/grass_ir_timing.py
"""

from __future__ import annotations

import csv
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from energy_records import REPO, run  # noqa: E402

from pavement_mcmc.criticism.fitting import refit  # noqa: E402
from pavement_mcmc.data import load_case  # noqa: E402
from pavement_mcmc.posterior import build_problem  # noqa: E402
from pavement_mcmc.posterior.surface_ir import SurfaceIR  # noqa: E402

TOML = REPO / "runs" / "grass_energy.toml"
#: the IR reading the skin node itself (no lead), and with a free lead
NODE = {"data": {"ir_storage_free": False}}
FREE_LEAD = {"data": {"ir_storage_free": False}, "parameters": {"ir_lead": {"vary": True}}}
DATA = REPO.parent / "shared" / "data" / "goettingen_grass"
ROW_MIN = 30  # the record's step


def _rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _write(path: Path, rows: list[dict]) -> Path:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return path


def shifted_extras(tmp: Path, rows: int) -> Path:
    """extras.csv with T_surf_IR moved ``rows`` rows later (the first rows keep their own)."""
    ex = _rows(DATA / "extras.csv")
    ir = [r["T_surf_IR"] for r in ex]
    out = [dict(r, T_surf_IR=ir[i - rows] if 0 <= i - rows < len(ir) else ir[i])
           for i, r in enumerate(ex)]
    return _write(tmp / f"extras_{rows:+d}.csv", out)


def sun_corrected(tmp: Path, b: float) -> Path:
    """measurements.csv with T_air - b SW_in (b in K per kW m-2)."""
    sw = {r["time"]: float(r["SW_in"]) for r in _rows(DATA / "extras.csv")}
    out = [dict(r, T_air=f"{float(r['T_air']) - b * max(sw[r['time']], 0.0) / 1000.0:.3f}")
           for r in _rows(DATA / "measurements.csv")]
    return _write(tmp / f"measurements_b{b:g}.csv", out)


def ir_by_hour(overrides: dict) -> np.ndarray:
    """The fit's IR residual, model minus radiometer, mean over the window in 2 h UTC bins."""
    pb = build_problem(load_case(TOML, overrides))
    fit = refit(pb, max_nfev=200)
    p = {k: np.array([v]) for k, v in fit.values().items()}
    model = pb.model
    ir = next(o for o in pb.posterior.streams if isinstance(o, SurfaceIR))
    coeffs = model.coefficients(p)
    pred = ir.predict(model, model.solve(p), coeffs, p)[0, :, 0]
    obs = np.asarray(model.meas.extras["T_surf_IR"], float)
    hours = (model.meas.t / 3600.0 + float(load_case(TOML).data["window_hours"][0])) % 24.0
    r = (pred - obs)[1:]  # the rows the likelihood compares (the first is the initial state)
    hours = hours[1:]
    return np.array([np.nanmean(r[(hours >= h) & (hours < h + 2)]) for h in range(0, 24, 2)])


def main() -> None:
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        print(f"{'IR moved':>9} {'in-sample':>9} {'IR':>6} {'kappa':>6} {'C MJ':>5} {'plate':>5} "
              f"{'forecast':>8}  (degC; W m-1 K-1; MJ m-3 K-1)")
        best = (np.inf, 0)
        for k in (-2, -1, 0, 1, 2, 3):
            r = run(TOML, None, {"data": {"extras": str(shifted_extras(tmp, k)),
                                          "ir_storage_free": False}})
            best = min(best, (r["rmse_ir"], k))
            print(f"{k * ROW_MIN:>+6d} min {r['rmse']:>9.3f} {r['rmse_ir']:>6.3f} {r['kappa']:>6.3f} "
                  f"{r['C'] / 1e6:>5.2f} {r['plate']:>5.2f} {r['forecast_rmse']:>8.3f}")
        for b in (1.0, 2.0, 3.0):
            r = run(TOML, None, {"data": {"csv": str(sun_corrected(tmp, b)), "ir_storage_free": False}})
            print(f"T_air - {b:g} K per kW m-2 SW_in: in-sample {r['rmse']:.3f}, IR {r['rmse_ir']:.3f}, "
                  f"kappa {r['kappa']:.3f}, C {r['C'] / 1e6:.2f}, plate {r['plate']:.2f}, "
                  f"forecast {r['forecast_rmse']:.3f}")
        print("IR residual, model minus radiometer, 2 h bins of UTC from 00 h:")
        for k in sorted({0, best[1]}):
            res = ir_by_hour({"data": {"extras": str(shifted_extras(tmp, k)), "ir_storage_free": False}})
            print(f"  IR moved {k * ROW_MIN:+d} min, no lead: " + " ".join(f"{x:+.1f}" for x in res))
        print("  a free lead, IR as recorded: " + " ".join(f"{x:+.1f}" for x in ir_by_hour(FREE_LEAD)))
        print("  the case (storage-free), IR as recorded: "
              + " ".join(f"{x:+.1f}" for x in ir_by_hour({})))
        from ir_lead_twins import relaxation_min

        pb = build_problem(load_case(TOML, FREE_LEAD))
        v = refit(pb, max_nfev=200).values()
        print(f"a free lead {v['ir_lead']:.1f} min; its canopy node's relaxation time c_canopy/K "
              f"{relaxation_min(pb.model.meas, v):.1f} min (c_canopy {v['c_canopy']:.0f} J m-2 K-1)")


if __name__ == "__main__":
    main()
