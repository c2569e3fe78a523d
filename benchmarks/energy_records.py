"""The surface energy balance on the two real records: base fit against the fit with
``energy_balance``, at the MAP (posterior/map.py through criticism.fitting.refit).

    nice -n 5 python benchmarks/energy_records.py [grass|desert ...]
    nice -n 5 python benchmarks/energy_records.py daily grass|desert [--out F]
    nice -n 5 python benchmarks/energy_records.py gain [grass|desert ...]
    nice -n 5 python benchmarks/energy_records.py rolling [grass|desert|grass_layered|desert_layered]

For each record (runs/grass*.toml: 72 h from 2020-04-05 00Z; runs/desert*.toml: 72 h from
2025-07-11 07Z) and each model it prints the in-sample RMSE (degC and in sigma), kappa, C,
kappa/C, the plate factor, the added physics' parameters (and which sit at a bound), the implied
midday LE/Rn, H/Rn, G/Rn and Bowen ratio, and the **next-day forecast RMSE**: the case read with
its window extended by 24 h, the fitted parameters put in, the 96 h solved from the window's
initial profile with the measured forcing and bottom temperature, the RMSE taken over the 24 h
after the window. Rule for the future of what the fit has no law for: a per-interval h(t)
repeats the last fitted day's h at the same clock time (diurnal persistence); a daily
Priestley-Taylor coefficient keeps the last day's value.

``gain``: the forecast gain F of the criticism's claim rule (criticism/forecast.py: the first
48 h refitted, the last 24 h of the 72 h window predicted from the forcing; F = (n/phi)
log(MSE_base / MSE_candidate), claimed above 15) of each energy-balance model of :data:`GAIN`
against the base model of the window, with the in-sample RMSE.

``rolling``: ``pavement-mcmc rolling`` (criticism/rolling.py) of the base and the energy-balance
case over the record (grass: 15 windows from 2020-03-29 00Z; desert: 27 from 2025-07-01 07Z):
72 h fitted, the next day forecast from the forcing (a per-interval h by its clock-hour mean);
``*_layered``: both cases with ``two_layer`` (desert_energy.toml has it already).

``daily``: the energy-balance case of a record (:data:`DAILY`) fitted by MAP on every daily
window (the 18 grass days from 2020-03-29 00Z; the 30 July desert days, 2025-07-01 07Z ...
07-30, local midnights), one JSON line per day (kappa, C, kappa/C, RMSE, the added physics'
values and which sit at a bound), then the spread of kappa/C, kappa and C about their medians
(the share of days within +-20 %). A file given by ``--out`` is resumed (days in it are
skipped).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from pavement_mcmc.criticism.fitting import refit
from pavement_mcmc.data import load_case, merge_overrides
from pavement_mcmc.physics.catalogue.energy import EnergyBalance, energy_partition
from pavement_mcmc.posterior import build_problem

REPO = Path(__file__).resolve().parents[1]
GRASS_IR = {"data": {"extras": "../../shared/data/goettingen_grass/extras.csv", "ir_sigma": 0.5}}
NO_PLATE = {"data": {"plates": False}}
#: the desert's infrared surface temperature observed over a footprint fraction (the
#: desert_energy.toml before `shading`)
DESERT_IR = {"data": {"extras": "../../shared/data/soilvue_utah/extras.csv", "ir_sigma": 0.5},
             "parameters": {"ir_view": {"vary": True}}}
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
               ("EB (window) + two_layer + IR, no LE (before shading)", "desert_energy.toml",
                ["energy_balance_window", "two_layer"], DESERT_IR),
               ("desert_energy.toml: EB (window) + two_layer + shading, no LE", "desert_energy.toml", None,
                {})],
}
DAY_H = 24.0
#: dry desert soil: the latent heat's coefficient went to its bound 0 on the 72 h window (one
#: coefficient for the window, or the third day's of three): LE is left out (eb_alpha fixed 0)
DRY = {"parameters": {"eb_alpha": {"value": 0.0, "vary": False}}}
#: ... and the coefficient(s) free again (runs/desert_energy.toml fixes them)
WET = {"parameters": {"eb_alpha": {"value": 0.5, "vary": True}}}
#: record -> (case TOML, extensions (None: as is), overrides, first window start h, days)
#: the site's geometry held at the 72 h window's posterior means (``pavement-mcmc fit
#: runs/desert_energy.toml``, seed 1): the shadow's hours and the top layer's depth do not change
#: from day to day; the shadow's share, the H coefficient and the soil's properties stay free
SITE = {"parameters": {"shade_start": {"value": 4.741, "vary": False},
                       "shade_length": {"value": 15.43, "vary": False},
                       "d_layer": {"value": 0.126, "vary": False}}}
DAILY = {"grass": ("grass_energy.toml", None, {}, 0.0, 18),
         "desert": ("desert_energy.toml", None, {}, 2928.0, 30),
         "desert_one_layer": ("desert_energy.toml", ["energy_balance_window"], DRY, 2928.0, 30),
         "desert_no_ir": ("desert.toml", ["energy_balance_window"], DRY, 2928.0, 30),
         "desert_alpha": ("desert_energy.toml", ["energy_balance_window"], WET, 2928.0, 30),
         "desert_site": ("desert_energy.toml", None, SITE, 2928.0, 30)}


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
    base_names = {"kappa", "C", "gamma", "plate_G5cm", "ir_offset", "ir_view", "ir_lead"}
    own = [n for n in pb.space.free if n not in base_names and pb.space[n].group != "h"]
    out["added"] = {n: v[n] for n in own}
    out["ir"] = {n: v[n] for n in ("ir_offset", "ir_view", "ir_lead") if n in pb.space.free}
    out["at_bound"] = [n for n in own if min(v[n] - lo[pb.space.free.index(n)],
                                             hi[pb.space.free.index(n)] - v[n])
                       < 1e-3 * (hi[pb.space.free.index(n)] - lo[pb.space.free.index(n)])]
    if any(isinstance(e, EnergyBalance) for e in pb.model.extensions):
        part = energy_partition(pb.model, {k: np.array([x]) for k, x in v.items()})
        out["midday"] = {k: float(x[0]) for k, x in part.midday().items()}
    w0, w1 = cfg.data["window_hours"]
    fcfg = load_case(toml, merge_overrides(overrides or {},
                                           {"data": {"window_hours": [w0, w1 + DAY_H]}}))
    fpb = build_problem(fcfg, extensions=exts)
    pred = fpb.model.predict(forecast_values(fpb, pb, v))[0]
    later = fpb.meas.t > pb.meas.t[-1] + 1.0
    out["forecast_residuals"] = pred[later] - fpb.meas.T_obs[later]
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


#: record -> (label, case TOML, extensions (None: as is), overrides) of ``gain``; the first row
#: is the base model
GAIN = {"grass": [("base (per-interval h)", "grass.toml", None, {}),
                  ("energy_balance_window (what diagnose tries)", "grass.toml",
                   ["energy_balance_window"], {}),
                  ("energy_balance_window + surface_layer", "grass.toml",
                   ["energy_balance_window", "surface_layer"], {}),
                  ("energy_balance_window + canopy, no IR", "grass.toml",
                   ["energy_balance_window", "canopy"], {}),
                  ("energy_balance + canopy + IR (grass_energy.toml)", "grass_energy.toml", None, {}),
                  ("energy_balance_window + canopy + IR", "grass_energy.toml",
                   ["energy_balance_window", "canopy"], {})],
        "desert": [("base (per-interval h)", "desert.toml", None, {}),
                   ("energy_balance_window (what diagnose tries)", "desert.toml",
                    ["energy_balance_window"], {}),
                   ("energy_balance_window + two_layer, no LE, no IR", "desert.toml",
                    ["energy_balance_window", "two_layer"], DRY),
                   ("energy_balance_window + two_layer + IR, no LE (before shading)",
                    "desert_energy.toml", ["energy_balance_window", "two_layer"], DESERT_IR),
                   ("energy_balance_window + two_layer + shading, no LE (desert_energy.toml)",
                    "desert_energy.toml", None, {}),
                   ("energy_balance + two_layer (daily alpha), no IR", "desert_energy.toml",
                    ["energy_balance", "two_layer"], WET)]}


def gain(record: str) -> None:
    """Forecast gains of :data:`GAIN`'s models against the first (module doc)."""
    from pavement_mcmc.criticism.forecast import forecast, forecast_gain

    fb = None
    for label, name, exts, overrides in GAIN[record]:
        pb = build_problem(load_case(REPO / "runs" / name, overrides or None), extensions=exts)
        fit = refit(pb, max_nfev=200)
        fc = forecast(pb, fit.values(), max_nfev=200)
        fb = fb or fc
        v = fit.values()
        lo, hi = pb.space.bounds()
        at = [n for j, n in enumerate(pb.space.free)
              if min(v[n] - lo[j], hi[j] - v[n]) < 1e-3 * (hi[j] - lo[j])]
        phi = (1 + fb.rho) / (1 - fb.rho)
        print(f"{record} {label:60s} in-sample {fit.rmse:.3f} C  forecast {fc.rmse:.3f} C "
              f"({fc.rmse_sigma:.2f} s)  F {forecast_gain(fb, fc):+.1f}  kappa {v['kappa']:.3g} "
              f"C {v['C'] / 1e6:.3g} MJ" + (f"  at a bound: {at}" if at else "")
              + (f"  [base: n {fb.n}, lag-1 {fb.rho:.3f}, n/phi {fb.n / phi:.1f}]"
                 if fc is fb else ""), flush=True)


def daily(record: str, out: Path | None = None) -> list[dict]:
    """MAP fits of :data:`DAILY`'s case on every day (module doc); rows by day."""
    name, exts, overrides, h0, n_days = DAILY[record]
    rows = [json.loads(x) for x in out.read_text().splitlines()] if out and out.exists() else []
    done = {r["start_h"] for r in rows}
    for d in range(n_days):
        a = h0 + DAY_H * d
        if a in done:
            continue
        t0 = time.perf_counter()
        cfg = load_case(REPO / "runs" / name,
                        merge_overrides(overrides, {"data": {"window_hours": [a, a + DAY_H]}}))
        pb = build_problem(cfg, extensions=exts)
        fit = refit(pb, max_nfev=200)
        v = fit.values()
        lo, hi = pb.space.bounds()
        at = [n for j, n in enumerate(pb.space.free)
              if min(v[n] - lo[j], hi[j] - v[n]) < 1e-3 * (hi[j] - lo[j])]
        row = {"start_h": a, "time0": pb.meas.time0, "rmse": fit.rmse, "kappa": v["kappa"],
               "C": v["C"], "diffusivity": v["kappa"] / v["C"], "at_bound": at,
               "values": {k: x for k, x in v.items() if k in pb.space.free},
               "seconds": time.perf_counter() - t0}
        rows.append(row)
        if out is not None:
            with out.open("a") as fh:
                fh.write(json.dumps(row) + "\n")
        print(f"{record} {pb.meas.time0[:10]} RMSE {fit.rmse:.3f} kappa {v['kappa']:.3g} C "
              f"{v['C'] / 1e6:.3g} MJ k/C {v['kappa'] / v['C'] * 1e6:.3g} mm2/s"
              + (f" at a bound: {at}" if at else ""), flush=True)
    return sorted(rows, key=lambda r: r["start_h"])


#: record -> (base TOML, energy-balance TOML, first window start h, number of windows) of
#: ``rolling``: 72 h windows a day apart, each forecasting the day after it
#: ``*_layered``: the base given the law case's layer, so the count credits the surface alone
ROLLING = {"grass": ("grass.toml", "grass_energy.toml", 0.0, 15),
           "desert": ("desert.toml", "desert_energy.toml", 2928.0, 27),
           "grass_layered": ("grass.toml+two_layer", "grass_energy.toml+two_layer", 0.0, 15),
           "desert_layered": ("desert.toml+two_layer", "desert_energy.toml", 2928.0, 27)}


def rolling(record: str) -> None:
    """Next-day forecasts of the base and the energy-balance case from 72 h windows a day
    apart, as ``pavement-mcmc rolling`` makes them (criticism/rolling.py)."""
    from pavement_mcmc.criticism.rolling import rolling_forecast

    base_name, eb_name, h0, n = ROLLING[record]
    res = rolling_forecast(REPO / "runs" / base_name, REPO / "runs" / eb_name, start_h=h0, days=n)
    print(res.text(), flush=True)


def spread(rows: list[dict], key: str) -> dict:
    """Median of ``key`` over the days, its range relative to the median, and the share of
    days within +-20 % of it."""
    x = np.array([r[key] for r in rows], float)
    med = float(np.median(x))
    rel = x / med - 1.0
    return {"median": med, "min_rel": float(rel.min()), "max_rel": float(rel.max()),
            "within_20": int(np.sum(np.abs(rel) <= 0.2)), "n": int(x.size)}


def main_daily(args: list[str]) -> None:
    record = args[0]
    out = Path(args[args.index("--out") + 1]) if "--out" in args else None
    rows = daily(record, out)
    for key in ("diffusivity", "kappa", "C"):
        s = spread(rows, key)
        print(f"{record} {key}: median {s['median']:.4g}, {100 * s['min_rel']:+.0f} % .. "
              f"{100 * s['max_rel']:+.0f} %, {s['within_20']} of {s['n']} days within +-20 %")
    bound = sum(bool(r["at_bound"]) for r in rows)
    print(f"{record}: {bound} of {len(rows)} days with a parameter at a bound")


if __name__ == "__main__":
    if sys.argv[1:2] == ["daily"]:
        main_daily(sys.argv[2:])
    elif sys.argv[1:2] == ["rolling"]:
        for rec in sys.argv[2:] or list(ROLLING):
            rolling(rec)
    elif sys.argv[1:2] == ["gain"]:
        for rec in sys.argv[2:] or list(GAIN):
            gain(rec)
    else:
        main(sys.argv[1:] or list(CASES))
