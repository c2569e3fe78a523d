"""The Penman-Monteith energy balance (physics/catalogue/penman.py) on twins whose latent heat
follows Penman-Monteith on the simulator's own h(t) and a fixed vapour pressure
(``SyntheticSpec.surface_resistance``; h from the wind, ``wind_convection``; 72 h, 30 min;
MAP fits): the recovered surface resistance, kappa and C against the truth, and the
Priestley-Taylor law's on the same twins, for resistances and vapour pressures given on the
command line (default: 50, 150, 400 s m-1 x 0.8, 1.4 kPa, seeds 1-3). With ``tmin`` the
Penman-Monteith law also runs on a copy of each twin without its RH column, the dew point
estimated from the daily minimum air temperature (``[data] dew_below_tmin = 0``, FAO-56,
data/humidity.py): the fallback of a record without humidity, against Priestley-Taylor;
``tmin=K`` sets ``dew_below_tmin = K`` instead (FAO-56's 2-4 K over arid ground).

    PYTHONPATH=. python benchmarks/penman_twins.py [first_seed n] [tmin | tmin=K]
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from pavement_mcmc.criticism import refit
from pavement_mcmc.criticism.point import case_problem
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin
from pavement_mcmc.synthetic.io import drop_columns


def without_rh(twin, below: float = 0.0) -> Path:
    """The twin written without its RH column, its dew point estimated from T_min (less
    ``below`` K)."""
    case = write_twin(twin, Path(tempfile.mkdtemp()) / twin.name)
    drop_columns(case.parent / "measurements.csv", ("RH",))
    case.write_text(case.read_text().replace("[data]\n", f"[data]\ndew_below_tmin = {below}\n", 1))
    return case


def main(first: int, n: int, tmin: float | None = None) -> None:
    tmp = Path(tempfile.mkdtemp())
    rows = []
    for r_s in (50.0, 150.0, 400.0):
        for vap in (0.8, 1.4):
            for seed in range(first, first + n):
                spec = {"vapour_kPa": vap, "surface_resistance": r_s}  # on R_n - G
                twin = forecast_twins(("wind_convection",), (seed,), hours=72.0, spec=spec)[0]
                case = write_twin(twin, tmp / twin.name)
                out = {}
                runs = [(case, "energy_balance_pm_window"), (case, "energy_balance_window")]
                if tmin is not None:
                    runs.append((without_rh(twin, tmin), "energy_balance_pm_window"))
                for k, (path, law) in enumerate(runs):
                    pb, _ = case_problem(f"{path}+{law}")
                    fit = refit(pb)
                    v = fit.values()
                    out[k] = (fit.rmse, v["kappa"] / twin.spec.kappa - 1, v["C"] / twin.spec.C - 1,
                                v.get("eb_rs", np.nan) / r_s - 1)
                pm, pt = out[0], out[1]
                rows.append((pm, pt, out.get(2)))
                print(f"r_s {r_s:g} s/m, e_a {vap:g} kPa, seed {seed}: PM RMSE {pm[0]:.3f}, "
                      f"r_s {100 * pm[3]:+.0f} %, kappa {100 * pm[1]:+.0f} %, C {100 * pm[2]:+.0f} % | "
                      f"PT RMSE {pt[0]:.3f}, kappa {100 * pt[1]:+.0f} %, C {100 * pt[2]:+.0f} %"
                      + (f" | PM-Tmin RMSE {out[2][0]:.3f}, r_s {100 * out[2][3]:+.0f} %, kappa "
                         f"{100 * out[2][1]:+.0f} %, C {100 * out[2][2]:+.0f} %" if tmin is not None else ""),
                      flush=True)
    pm = np.abs(np.array([r[0] for r in rows]))
    pt = np.array([r[1] for r in rows])

    def med_max(a):
        return f"{100 * np.median(a):.0f} % (max {100 * np.max(a):.0f} %)"

    ratio = pt[:, 0] / pm[:, 0]
    print(f"{len(rows)} twins: PM |r_s error| {med_max(pm[:, 3])}, |kappa| {med_max(pm[:, 1])}, "
          f"|C| {med_max(pm[:, 2])}; PT |kappa| {med_max(np.abs(pt[:, 1]))}, |C| "
          f"{med_max(np.abs(pt[:, 2]))}; PT RMSE / PM RMSE median {np.median(ratio):.2f} "
          f"(min {np.min(ratio):.2f})")
    if tmin is not None:
        tm = np.abs(np.array([r[2] for r in rows]))
        print(f"PM with the dew point from T_min (no RH): |kappa| {med_max(tm[:, 1])}, |C| "
              f"{med_max(tm[:, 2])}, |r_s| {med_max(tm[:, 3])}; RMSE / PM-with-RH RMSE median "
              f"{np.median(tm[:, 0] / pm[:, 0]):.2f}; PT RMSE / its RMSE median "
              f"{np.median(pt[:, 0] / tm[:, 0]):.2f}")

if __name__ == "__main__":
    args = [int(a) for a in sys.argv[1:] if a.isdigit()]
    below = [float(a.partition("=")[2] or 0.0) for a in sys.argv[1:] if a.startswith("tmin")]
    main(*(args or [1, 3]), tmin=below[0] if below else None)
