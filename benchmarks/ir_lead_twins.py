"""Does the IR stream's lead (``ir_lead``, posterior/surface_ir.py) find the top of a sward that
leads its heat-storing bulk, and only there? MAP fits of grass-like twins from the independent
simulator (synthetic/ir_view.py: a resolved thatch, not the inversion's lumped canopy node).

- ``storing``: a thatch that stores 30 kJ m-2 K-1 (``storing_thatch_case``), the thermometer
  reading its top; the lead free and held at 0 (the weight held at 1), and both free.
- ``thin``: the thin thatch of ``ir_view_case`` (4.5 kJ m-2 K-1), 60 % of the view stopped in it;
  the weight free, the lead held at 0 and free (a lead found there would be false).
- both with ``[data] ir_storage_free`` (the weight free): no lead parameter, the node's own
  relaxation time c_canopy / K as the lead (posterior/surface_ir.py).

Per twin and fit: the in-sample RMSE of the buried sensors, the IR RMSE, the errors of kappa and
C against the truth, the lead (min), the weight, the fitted canopy heat capacity (J m-2 K-1) and
the node's relaxation time c_canopy / K (:func:`relaxation_min`), which the lead comes out near.

    PYTHONPATH=. python benchmarks/ir_lead_twins.py [first_seed] [n_seeds]
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from pavement_mcmc.criticism import refit
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.synthetic.ir_view import STORING_C, ir_view_case, storing_thatch_case

LEAD_0 = {"parameters": {"ir_lead": {"vary": False, "value": 0.0}}}
LEAD = {"parameters": {"ir_lead": {"vary": True}}}


def line(label: str, toml: Path, spec, overrides: dict | None) -> str:
    pb = build_problem(load_case(toml, overrides))
    fit = refit(pb, max_nfev=200)
    v = fit.values()
    blobs = dict(zip(pb.posterior.blob_names, pb.posterior.loglik_blobs(fit.theta[None])[1][0],
                     strict=True))
    return (f"{label:34s} RMSE {fit.rmse:.3f}  IR {blobs['rmse_IR']:.3f}  "
            f"kappa {v['kappa'] / spec.kappa - 1:+.2f}  C {v['C'] / spec.C - 1:+.2f}  "
            f"lead {v.get('ir_lead', 0.0):5.1f}  weight {v.get('ir_view', 1.0):.2f}  "
            f"c_canopy {v['c_canopy']:.0f}  c/K {relaxation_min(pb.model.meas, v):.1f} min")


def relaxation_min(meas, v: dict) -> float:
    """The canopy node's relaxation time c_canopy / K, minutes, K = h_H + 1/R_canopy with h_H
    the fitted law's at the mean daytime wind (q_net > 0)."""
    wind = 0.0 if meas.wind is None else float(np.mean(np.asarray(meas.wind)[meas.q_net > 0]))
    K = v["eb_h0"] + v.get("eb_h1", 0.0) * wind + 1.0 / v["R_canopy"]
    return v["c_canopy"] / K / 60.0


def main(first: int, n: int) -> None:
    print(f"storing thatch: {STORING_C * 0.015:.0f} J m-2 K-1 over 1.5 cm; errors are fit/truth - 1")
    with tempfile.TemporaryDirectory() as d:
        for seed in range(first, first + n):
            toml, spec = storing_thatch_case(Path(d) / f"s{seed}", seed)
            print(f"seed {seed}", flush=True)
            print("  " + line("storing, lead free", toml, spec, None), flush=True)
            print("  " + line("storing, lead 0", toml, spec, LEAD_0), flush=True)
            toml, spec = storing_thatch_case(Path(d) / f"v{seed}", seed, free=("ir_lead", "ir_view"))
            print("  " + line("storing, lead and weight free", toml, spec, None), flush=True)
            toml, spec = storing_thatch_case(Path(d) / f"f{seed}", seed, free=("ir_view",))
            storage_free(toml)
            print("  " + line("storing, storage-free, weight free", toml, spec, None), flush=True)
            toml, spec = ir_view_case(Path(d) / f"t{seed}", 0.6, seed)
            print("  " + line("thin into 0.6, weight free, lead 0", toml, spec, None), flush=True)
            print("  " + line("thin into 0.6, lead free too", toml, spec, LEAD), flush=True)
            toml, spec = ir_view_case(Path(d) / f"u{seed}", 0.6, seed)
            storage_free(toml)
            print("  " + line("thin into 0.6, storage-free", toml, spec, None), flush=True)


def storage_free(toml: Path) -> None:
    """The case reads the IR as a surface without storage (``[data] ir_storage_free``)."""
    toml.write_text(toml.read_text().replace("ir_sigma = ", "ir_storage_free = true\nir_sigma = "))


if __name__ == "__main__":
    args = [int(a) for a in sys.argv[1:]]
    main(args[0] if args else 1, args[1] if len(args) > 1 else 3)
