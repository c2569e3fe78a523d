"""A pilot, not a rule: would a surface layer that stores heat (``canopy``) forecast the
campaign's ``surface_layer`` twins where the massless ``surface_layer`` candidate does not?

The campaign's surface_layer twins hide a 1.5 cm layer of kappa 0.06 W m-1 K-1 and C 0.3 MJ m-3
K-1 (R 0.25 m2 K W-1, 4.5 kJ m-2 K-1 of storage); the catalogue's ``surface_layer`` is a
resistance without storage, and the rule claims it on 5 of 10 (docs/VALIDATION.md §4).
``canopy`` (physics/catalogue/canopy.py) is a lumped skin with heat capacity and a resistance,
but needs a first grid cell of at most 2 mm, so it is not a default candidate. Here, per twin:
the base model on the twin's grid, ``+surface_layer`` on it, and ``+canopy`` on a grid with a
1 mm first cell (stretched to the twin's 5 mm, same dt), each from the extension's own start
values (the best training fit kept) through
:func:`pavement_mcmc.criticism.forecast.forecast` (the last 10 h of 40 held out, the clock-hour
rule), and the forecast gain F of each against the base (the criticism's statistic; margin 15).
Clean twins give the null of canopy's F.

Result (docs/VALIDATION.md §4, "What the truth itself would score"): canopy does not recover
the twins' layer as it stands. The twins' sensors are measured from the soil surface under the
layer, while canopy's model puts the 0 cm sensor on its skin (x = 0, the soil 1 mm below), so
the fit removes the resistance (R_canopy at its lower bound) and forecasts worse. A fair test
needs a canopy whose sensor depths count from the soil surface.

    PYTHONPATH=. NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/canopy_pilot.py \\
        [--seeds 3700-3709] [--clean-seeds 3600-3609]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from pavement_mcmc.criticism.forecast import forecast, forecast_gain
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.synthetic.corpus import FORECAST_GRID, forecast_twins, write_twin

THIN = {"grid": {"kind": "stretched", "dx_top": 0.001, "growth": 1.15,
                 "dx_max": FORECAST_GRID["dx"], "dt": FORECAST_GRID["dt"]}}


def _seeds(text: str) -> tuple[int, ...]:
    a, b = (int(x) for x in text.split("-"))
    return tuple(range(a, b + 1))


def one(twin, root: Path) -> dict:
    t0 = time.perf_counter()
    case = write_twin(twin, root / twin.name)
    base = forecast(build_problem(load_case(case)))
    out = {"twin": twin.name, "base": base.rmse}
    for ext, ov in (("surface_layer", None), ("canopy", THIN)):
        pb = build_problem(load_case(case, ov, additions={"model": {"extensions": [ext]}}))
        # the extension's own starts (as the ranking's refits use them), the best training fit
        own = pb.model.extensions[-1].start_values(pb.meas, None) or [None]
        fc = min((forecast(pb, st) for st in own), key=lambda f: f.fits[-1].objective)
        out[ext] = {"F": forecast_gain(base, fc), "rmse": fc.rmse,
                    "values": {k: v for k, v in fc.fits[-1].values().items()
                               if k in ("R_surface", "R_canopy", "c_canopy")}}
    out["seconds"] = time.perf_counter() - t0
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", default="3700-3709", help="surface_layer twin seeds, A-B")
    ap.add_argument("--clean-seeds", default="3600-3609", help="clean twin seeds, A-B")
    a = ap.parse_args(argv)
    twins = (forecast_twins(("surface_layer",), _seeds(a.seeds), input_sigma=True)
             + forecast_twins((), _seeds(a.clean_seeds), input_sigma=True))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for tw in twins:
            r = one(tw, Path(tmp))
            rows.append(r)
            v = r["canopy"]["values"]
            print(f"{r['twin']}: base forecast {r['base']:.3f} degC; surface_layer F "
                  f"{r['surface_layer']['F']:+.1f}; canopy F {r['canopy']['F']:+.1f} "
                  f"(R_canopy {v.get('R_canopy', float('nan')):.3f}, c_canopy "
                  f"{v.get('c_canopy', float('nan')):.0f} J m-2 K-1) ({r['seconds']:.0f} s)",
                  flush=True)
    for kind in ("surface_layer", "clean"):
        sub = [r for r in rows if f"-{kind}-" in r["twin"]]
        for ext in ("surface_layer", "canopy"):
            n = sum(r[ext]["F"] > 15 for r in sub)
            print(f"{kind} twins: {ext} F > 15 on {n} of {len(sub)}")


if __name__ == "__main__":
    main()
