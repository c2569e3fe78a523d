"""The surface energy balance on the two real records: base fit against the fit with
``energy_balance``, at the MAP (posterior/map.py through criticism.fitting.refit).

    nice -n 5 /work/main/.venv/bin/python benchmarks/energy_records.py [grass|desert ...]

For each record (runs/grass*.toml: 72 h from 2020-04-05 00Z; runs/desert*.toml: 72 h from
2025-07-11 07Z) and each model it prints the in-sample RMSE (degC and in sigma), kappa, C,
kappa/C, the plate factor, the added physics' parameters (and which sit at a bound), the implied
midday LE/Rn, H/Rn, G/Rn and Bowen ratio, and the **next-day forecast RMSE**: the case read with
its window extended by 24 h, the fitted parameters put in, the 96 h solved from the window's
initial profile with the measured forcing and bottom temperature, the RMSE taken over the 24 h
after the window. Rule for the future of what the fit has no law for: a per-interval h(t)
repeats the last fitted day's h at the same clock time (diurnal persistence); a daily
Priestley-Taylor coefficient keeps the last day's value.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from pavement_mcmc.criticism.fitting import refit
from pavement_mcmc.data import load_case, merge_overrides
from pavement_mcmc.physics.catalogue.energy import energy_partition
from pavement_mcmc.posterior import build_problem

REPO = Path(__file__).resolve().parents[1]
GRASS_IR = {"data": {"extras": "../../shared/data/goettingen_grass/extras.csv", "ir_sigma": 0.5}}
NO_PLATE = {"data": {"plates": False}}
#: record -> (label, case TOML, extensions instead of the TOML's (None: as is), overrides).
#: The rows without the IR stream take the base TOMLs (no extras) with the energy balance named.
CASES = {
    "grass": [("base (per-interval h)", "grass.toml", None, {}),
              ("energy_balance + surface_layer, no IR", "grass.toml",
               ["energy_balance", "surface_layer"], {}),
              ("energy_balance + surface_layer + IR", "grass.toml",
               ["energy_balance", "surface_layer"], GRASS_IR),
              ("energy_balance + canopy + IR", "grass_energy.toml", None, {}),
              ("  same, plate not observed", "grass_energy.toml", None, NO_PLATE),
              ("energy_balance + two_layer + canopy + IR, no plate", "grass_energy.toml",
               ["energy_balance", "two_layer", "canopy"], NO_PLATE)],
    "desert": [("base (per-interval h)", "desert.toml", None, {}),
               ("base + two_layer", "desert.toml", ["two_layer"], {}),
               ("energy_balance + two_layer, no IR", "desert.toml",
                ["energy_balance", "two_layer"], {}),
               ("energy_balance + two_layer + IR (ir_view)", "desert_energy.toml", None, {})],
}
DAY_H = 24.0


def forecast_values(problem, fit_problem, values: dict[str, float]) -> dict[str, np.ndarray]:
    """Parameter sets of ``problem`` (window + 1 day) from the fit's values (see module doc)."""
    p = {k: np.array([v]) for k, v in problem.space.value_dict().items()}
    p.update({k: np.array([v]) for k, v in values.items() if k in p})
    fb, b = fit_problem.model, problem.model
    if not b.replaces_h:  # per-interval h: the last fitted day repeated at the same clock time
        t_fit = fb.meas.t
        h_fit = fb.h_basis.evaluate({k: np.array([v]) for k, v in values.items()})[0]
        mid = 0.5 * (b.meas.t[1:] + b.meas.t[:-1])
        src = np.where(mid <= t_fit[-1], mid, mid - DAY_H * 3600.0)
        h_new = np.interp(src, 0.5 * (t_fit[1:] + t_fit[:-1]), h_fit)
        for j, n in enumerate(b.h_basis.names):
            p[n] = np.array([h_new[j]])
    alphas = sorted((n for n in p if n.startswith("eb_alpha_")), key=lambda n: int(n[9:]))
    for n in alphas:
        if n not in values:
            p[n] = np.array([values[max((a for a in alphas if a in values),
                                        key=lambda a: int(a[9:]))]])
    return p


def run(toml: Path, exts: list[str] | None = None, overrides: dict | None = None) -> dict:
    t0 = time.perf_counter()
    cfg = load_case(toml, overrides or None)
    pb = build_problem(cfg, extensions=exts)
    fit = refit(pb, max_nfev=200)
    v = fit.values()
    blobs = dict(zip(pb.posterior.blob_names, pb.posterior.loglik_blobs(fit.theta[None])[1][0],
                     strict=True))
    out = {"rmse": fit.rmse, "sigma": pb.meas.sigma, "kappa": v["kappa"], "C": v["C"],
           "rmse_ir": blobs.get("rmse_IR"),
           "plate": v.get("plate_G5cm"), "p_eff": fit.p_eff, "seconds": 0.0}
    lo, hi = pb.space.bounds()
    base_names = {"kappa", "C", "gamma", "plate_G5cm", "ir_offset", "ir_view"}
    own = [n for n in pb.space.free if n not in base_names and pb.space[n].group != "h"]
    out["added"] = {n: v[n] for n in own}
    out["ir"] = {n: v[n] for n in ("ir_offset", "ir_view") if n in pb.space.free}
    out["at_bound"] = [n for n in own if min(v[n] - lo[pb.space.free.index(n)],
                                             hi[pb.space.free.index(n)] - v[n])
                       < 1e-3 * (hi[pb.space.free.index(n)] - lo[pb.space.free.index(n)])]
    if any(e.name == "energy_balance" for e in pb.model.extensions):
        part = energy_partition(pb.model, {k: np.array([x]) for k, x in v.items()})
        out["midday"] = {k: float(x[0]) for k, x in part.midday().items()}
    w0, w1 = cfg.data["window_hours"]
    fcfg = load_case(toml, merge_overrides(overrides or {},
                                           {"data": {"window_hours": [w0, w1 + DAY_H]}}))
    fpb = build_problem(fcfg, extensions=exts)
    pred = fpb.model.predict(forecast_values(fpb, pb, v))[0]
    later = fpb.meas.t > pb.meas.t[-1] + 1.0
    out["forecast_rmse"] = float(np.sqrt(np.mean((pred[later] - fpb.meas.T_obs[later]) ** 2)))
    out["forecast_rmse_sensor"] = np.sqrt(np.mean((pred[later] - fpb.meas.T_obs[later]) ** 2,
                                                  axis=0)).round(3).tolist()
    out["seconds"] = time.perf_counter() - t0
    return out


def main(records: list[str]) -> None:
    for rec in records:
        for label, name, exts, overrides in CASES[rec]:
            r = run(REPO / "runs" / name, exts, overrides)
            print(f"{rec:6s} {label:36s} RMSE {r['rmse']:.3f} C ({r['rmse'] / r['sigma']:.2f} s)"
                  f"  forecast {r['forecast_rmse']:.3f} C {r['forecast_rmse_sensor']}"
                  f"  kappa {r['kappa']:.3g}  C {r['C'] / 1e6:.3g} MJ  k/C "
                  f"{r['kappa'] / r['C'] * 1e6:.3g} mm2/s  plate {r['plate'] or float('nan'):.2f}  "
                  f"p_eff {r['p_eff']:.1f}  [{r['seconds']:.0f} s]")
            if r["rmse_ir"] is not None:
                print(f"       IR: RMSE {r['rmse_ir']:.2f} C, "
                      + ", ".join(f"{k} {x:.3g}" for k, x in r["ir"].items()))
            if r["added"]:
                print("       added: " + ", ".join(f"{k} {x:.3g}" for k, x in r["added"].items())
                      + (f"; at a bound: {r['at_bound']}" if r["at_bound"] else "; none at a bound"))
            if "midday" in r:
                print("       midday: " + ", ".join(f"{k} {x:.2f}" for k, x in r["midday"].items()))
            sys.stdout.flush()


if __name__ == "__main__":
    main(sys.argv[1:] or list(CASES))
