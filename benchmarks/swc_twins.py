"""The soil-water limited energy balance (``energy_balance_swc``, physics/catalogue/soil_water.py)
on twins whose top soil dries down through a 72 h window and whose latent heat follows the
Noilhan-Planton efficiency of the true water content on the simulator's own R_n - G
(``SyntheticSpec.swc_fc``, :func:`~pavement_mcmc.synthetic.soil_water.drying_settings`; h from
the wind, ``wind_convection``; 30 min rows; MAP fits), against the constant-coefficient
Priestley-Taylor balance (``energy_balance_window``, blind to the water content): kappa and C
errors, the fitted ``eb_alpha``, the implied daytime LE (rows with q_net > 300 W m-2) against
the truth, the in-sample RMSE, and the next-day forecast RMSE (trained on 0-48 h, 48-72 h held
out, :func:`~pavement_mcmc.criticism.forecast.forecast`). (a) the drying twin, (b) the same
twin with the water content recorded and no latent heat (``swc_alpha = 0``).

    PYTHONPATH=. python benchmarks/swc_twins.py [--seeds 8] [--first 1] [--fc 0.2]
        [--available net_minus_ground|net]
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np

from pavement_mcmc.criticism import refit
from pavement_mcmc.criticism.forecast import forecast
from pavement_mcmc.criticism.point import case_problem
from pavement_mcmc.physics.catalogue.energy import energy_partition
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin
from pavement_mcmc.synthetic.soil_water import drying_settings

LAWS = ("energy_balance_swc", "energy_balance_window")


def one_law(case: Path, law: str, theta_fc: float, spec, LE_true: np.ndarray) -> dict:
    """MAP fit, implied daytime LE and next-day forecast of one law on one written twin."""
    ov = {"parameters": {"eb_theta_fc": {"value": theta_fc}}} if law == LAWS[0] else None
    pb, _ = case_problem(f"{case}+{law}", ov)
    fit = refit(pb)
    v = fit.values()
    p = {k: np.array([x]) for k, x in {**pb.space.value_dict(), **v}.items()}
    LE = energy_partition(pb.model, p).LE[0]
    day = pb.meas.q_net > 300
    fc = forecast(pb, origins=[48.0], horizon=24.0)
    return {"kappa": v["kappa"] / spec.kappa - 1, "C": v["C"] / spec.C - 1,
            "alpha": v["eb_alpha"], "rmse": fit.rmse, "fc_rmse": fc.rmse,
            "LE_bias": float(np.mean(LE[day] - LE_true[day])),
            "LE_rms": float(np.sqrt(np.mean((LE[day] - LE_true[day]) ** 2))),
            "LE_true": float(np.mean(LE_true[day]))}


def run_twin(seed: int, alpha: float, args, tmp: Path) -> dict:
    spec = drying_settings(args.fc, alpha, et_available=args.available)
    twin = forecast_twins(("wind_convection",), (seed,), hours=72.0, spec=spec)[0]
    case = write_twin(twin, tmp / f"swc-a{alpha:g}-s{seed}")
    LE_true = np.array(json.loads((case.parent / "truth.json").read_text())["q_et_obs"])
    return {law: one_law(case, law, args.fc, twin.spec, LE_true) for law in LAWS}


HEAD = (f"{'seed':>6} | {'law':>4} | {'kappa %':>7} {'C %':>6} {'alpha':>5} | {'LE bias':>7} "
        f"{'LE rms':>6} {'LE true':>7} | {'RMSE':>5} {'fc RMSE':>7}")


def line(seed, law: str, r: dict) -> str:
    return (f"{seed:>6} | {law:>4} | {100 * r['kappa']:+7.1f} {100 * r['C']:+6.1f} "
            f"{r['alpha']:5.2f} | {r['LE_bias']:+7.1f} {r['LE_rms']:6.1f} {r['LE_true']:7.1f} | "
            f"{r['rmse']:5.3f} {r['fc_rmse']:7.3f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=8, help="number of seeds (default 8)")
    ap.add_argument("--first", type=int, default=1, help="first seed (default 1)")
    ap.add_argument("--fc", type=float, default=0.2, help="theta_fc of twin and law")
    ap.add_argument("--available", default="net_minus_ground",
                    help="the twin's available energy: net_minus_ground (default) or net")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp())
    for alpha, title in ((1.0, "(a) drying twin, LE = NP(theta) PT (R_n - G)"),
                         (0.0, "(b) SWC recorded, no latent heat")):
        print(f"\n{title}; swc = energy_balance_swc, PT = energy_balance_window; LE in W m-2 "
              "(q_net > 300), RMSE in degC\n" + HEAD, flush=True)
        rows = []
        for seed in range(args.first, args.first + args.seeds):
            r = run_twin(seed, alpha, args, tmp)
            rows.append(r)
            for law, tag in zip(LAWS, ("swc", "PT"), strict=True):
                print(line(seed, tag, r[law]), flush=True)
        for law, tag in zip(LAWS, ("swc", "PT"), strict=True):
            med = {k: float(np.median([r[law][k] for r in rows])) for k in rows[0][law]}
            print(line("median", tag, med))
        absmed = {law: (np.median([abs(r[law]["kappa"]) for r in rows]),
                        np.median([abs(r[law]["C"]) for r in rows])) for law in LAWS}
        print("median |kappa|, |C| errors: " + "; ".join(
            f"{tag} {100 * a:.1f} %, {100 * c:.1f} %" for (a, c), tag in
            zip(absmed.values(), ("swc", "PT"), strict=True)))


if __name__ == "__main__":
    main()
