"""Which observation stream holds the grass window's effusivity above a loam's
(docs/VALIDATION.md section 5): MAP fits of runs/grass_energy.toml, its infrared view held at 1
(the footprint all canopy, as before the view was free; ``view`` rows free it), with kappa and C free and
held at the measured-top fit's loam values (1.41 W m-1 K-1, 2.47 MJ m-3 K-1), with every
stream, without the plate, and without the plate and the IR (its sd 100 degC: scored, not
fitted); then the stream weights re-estimated (each stream's sd set to its RMSE and refitted,
six rounds: the profile of a free noise scale per stream). With ``laws``, instead: the
Priestley-Taylor and the Penman-Monteith law (on the dew point estimated from the daily minimum
air temperature, ``[data] dew_below_tmin = 0``: the record has no humidity) with the plate's
factor free and held at 1 (its calibration trusted), and each with the view free.

    PYTHONPATH=. python benchmarks/grass_streams.py [laws]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from energy_records import REPO  # noqa: E402

from pavement_mcmc.criticism.fitting import refit  # noqa: E402
from pavement_mcmc.data import load_case, merge_overrides  # noqa: E402
from pavement_mcmc.physics.catalogue.energy import energy_partition  # noqa: E402
from pavement_mcmc.posterior import build_problem  # noqa: E402

TOML = REPO / "runs" / "grass_energy.toml"
LOAM = {"parameters": {"kappa": {"value": 1.41, "vary": False},
                       "C": {"value": 2.47e6, "vary": False}}}
NO_PLATE = {"data": {"plates": False}}
NO_IR = {"data": {"ir_sigma": 100.0}}
PM_TMIN = {"model": {"extensions": ["energy_balance_pm", "canopy"]}, "data": {"dew_below_tmin": 0.0}}
PLATE_1 = {"parameters": {"plate_G5cm": {"value": 1.0, "vary": False}}}
VIEW_1 = {"parameters": {"ir_view": {"value": 1.0, "vary": False}}}


def fit(overrides: dict) -> tuple[dict, dict, float, dict]:
    """MAP of the case with ``overrides`` (``"view": True`` frees the infrared view)."""
    ov = {k: x for k, x in (overrides or {}).items() if k != "view"}
    pb = build_problem(load_case(TOML, ov if (overrides or {}).get("view") else merge_overrides(VIEW_1, ov)))
    f = refit(pb, max_nfev=200)
    v = f.values()
    p = {k: np.array([x]) for k, x in {**pb.space.value_dict(), **v}.items()}
    blobs = dict(zip(pb.posterior.blob_names, pb.posterior.loglik_blobs(f.theta[None])[1][0],
                     strict=True))
    mid = {k: float(x[0]) for k, x in energy_partition(pb.model, p).midday().items()}
    return v, blobs, f.objective, mid


def line(label: str, v: dict, blobs: dict, objective: float, mid: dict) -> str:
    rm = ", ".join(f"{k[5:]} {x:.3g}" for k, x in blobs.items())
    return (f"{label}: objective {objective:.1f}; RMSE {rm}; kappa {v['kappa']:.3g}, C "
            f"{v['C'] / 1e6:.3g} MJ, plate {v.get('plate_G5cm', float('nan')):.3g}, R_canopy "
            f"{v['R_canopy']:.3g}, c_canopy {v['c_canopy'] / 1e3:.3g} kJ m-2 K-1, G/Rn {mid['G_Rn']:.2f}, "
            f"LE/Rn {mid['LE_Rn']:.2f}")


def laws() -> None:
    for label, ov in (("Priestley-Taylor, plate free", {}), ("Priestley-Taylor, plate 1", PLATE_1),
                      ("Penman-Monteith on T_min, plate free", PM_TMIN),
                      ("Penman-Monteith on T_min, plate 1", merge_overrides(PM_TMIN, PLATE_1)),
                      ("Priestley-Taylor, view free", {"view": True}),
                      ("Penman-Monteith on T_min, view free", {**PM_TMIN, "view": True})):
        v, blobs, objective, mid = fit(ov)
        print(line(label, v, blobs, objective, mid) + f", view {v.get('ir_view', 1.0):.3f}, kappa/C "
              f"{v['kappa'] / v['C'] * 1e6:.3f} mm2 s-1, effusivity "
              f"{np.sqrt(v['kappa'] * v['C']):.0f} J m-2 K-1 s-1/2", flush=True)


def main() -> None:
    for label, ov in (("all streams, free", {}), ("all streams, loam", LOAM),
                      ("no plate, free", NO_PLATE),
                      ("no plate, loam", merge_overrides(NO_PLATE, LOAM)),
                      ("no plate, no IR, free", merge_overrides(NO_PLATE, NO_IR)),
                      ("no plate, no IR, loam", merge_overrides(merge_overrides(NO_PLATE, NO_IR), LOAM))):
        print(line(label, *fit(ov)), flush=True)
    sig = {"sigma": 0.1, "ir_sigma": 0.5, "plate_sigma": 5.0, "plate_rel_sigma": 0.0}
    for _round in range(6):
        v, blobs, obj, mid = fit({"data": dict(sig)})
        print(line(f"stream sds {sig}", v, blobs, obj, mid), flush=True)
        temps = [x for n, x in blobs.items() if n.endswith("cm") and not n.startswith("rmse_G")]
        sig = {"sigma": float(np.sqrt(np.mean(np.square(temps)))),
               "ir_sigma": float(blobs["rmse_IR"]), "plate_sigma": float(blobs["rmse_G5cm"]),
               "plate_rel_sigma": 0.0}


if __name__ == "__main__":
    laws() if "laws" in sys.argv[1:] else main()
