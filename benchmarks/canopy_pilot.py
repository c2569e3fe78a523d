"""A pilot, not a rule: would a surface layer that stores heat (``canopy``) forecast the
campaign's ``surface_layer`` twins where the massless ``surface_layer`` candidate does not?

The campaign's surface_layer twins hide a 1.5 cm layer of kappa 0.06 W m-1 K-1 and C 0.3 MJ m-3
K-1 (R 0.25 m2 K W-1, 4.5 kJ m-2 K-1 of storage); the catalogue's ``surface_layer`` is a
resistance without storage, and the rule claims it on 5 of 10 (docs/VALIDATION.md §4).
``canopy`` (physics/catalogue/canopy.py) is a lumped skin with heat capacity and a resistance,
a node the model puts 1 mm above the soil, the sensor depths counted from the soil surface
below it. Here, per twin: the base model, ``+surface_layer`` and ``+canopy`` on the twin's grid,
each from the extension's own start values (the best training fit kept) through
:func:`pavement_mcmc.criticism.forecast.forecast` (the last 10 h of 40 held out, the clock-hour
rule), and the forecast gain F of each against the base (the criticism's statistic; margin 15).
Clean twins give the null of canopy's F.

Result (docs/VALIDATION.md section 4, "canopy: a layer over the soil that stores heat"): canopy
recovers the layer (R_canopy 0.16-0.25 against 0.25) and gains F > 15 on 8 of 10 layer twins,
0 of 10 clean ones. (Before the skin node, with the skin on the grid's top node and the sensors
read from it, R went to its lower bound and F was -84 to -17.)

    PYTHONPATH=. NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/canopy_pilot.py \\
        [--seeds 3700-3709] [--clean-seeds 3600-3609]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from pavement_mcmc.criticism.forecast import forecast, forecast_from_starts, forecast_gain
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin


def _seeds(text: str) -> tuple[int, ...]:
    a, b = (int(x) for x in text.split("-"))
    return tuple(range(a, b + 1))


def one(twin, root: Path) -> dict:
    t0 = time.perf_counter()
    case = write_twin(twin, root / twin.name)
    base = forecast(build_problem(load_case(case)))
    out = {"twin": twin.name, "base": base.rmse}
    for ext in ("surface_layer", "canopy"):
        pb = build_problem(load_case(case, additions={"model": {"extensions": [ext]}}))
        # the extension's own starts (as the ranking's refits use them), the best training fit
        own = pb.model.extensions[-1].start_values(pb.meas, None) or [None]
        fc = forecast_from_starts(pb, own)
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
