"""The infrared view of a partial canopy (posterior/surface_ir.py: under a layer, T_IR = f
T_skin + (1 - f) T_soil + offset) on grass-like twins from the independent simulator
(:mod:`pavement_mcmc.synthetic.ir_view`: a resolved thatch, h from the wind, Priestley-Taylor
latent heat on R_n - G) seen by two thermometers: one looking down into the thatch (a share f
of its view stopped in the layer, Beer's law; f = 0.6, 0.8, 1) and one over tiles (f of its
footprint the thatch's top, the rest a bare sunlit patch; f = 0.6, 0.8). The MAP's f, kappa
and C against the truth with ``ir_view`` free and held at 1.

    PYTHONPATH=. python benchmarks/ir_view_twins.py [first_seed n_seeds]
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from pavement_mcmc.criticism import refit
from pavement_mcmc.data import load_case
from pavement_mcmc.posterior import build_problem
from pavement_mcmc.synthetic.ir_view import HELD, ir_view_case, tiled_case

VIEWS = (("into the layer", ir_view_case, 0.6), ("into the layer", ir_view_case, 0.8),
         ("into the layer", ir_view_case, 1.0), ("tiles", tiled_case, 0.6),
         ("tiles", tiled_case, 0.8))


def main(first: int, n: int) -> None:
    tmp = Path(tempfile.mkdtemp())
    rows = []
    for kind, make, view in VIEWS:
        for seed in range(first, first + n):
            toml, spec = make(tmp / f"{make.__name__}-v{view}-s{seed}", view, seed)
            out = {}
            for label, ov in (("free", None), ("held at 1", HELD)):
                fit = refit(build_problem(load_case(toml, ov)))
                v = fit.values()
                out[label] = (v.get("ir_view", 1.0), v["kappa"] / spec.kappa - 1, v["C"] / spec.C - 1,
                              fit.rmse)
            rows.append(((kind, view), out["free"], out["held at 1"]))
            fr, hd = out["free"], out["held at 1"]
            print(f"{kind}, view {view:g}, seed {seed}: free f {fr[0]:.3f}, kappa {100 * fr[1]:+.0f} %, C "
                  f"{100 * fr[2]:+.0f} %, RMSE {fr[3]:.3f} | f held at 1: kappa {100 * hd[1]:+.0f} %, "
                  f"C {100 * hd[2]:+.0f} %, RMSE {hd[3]:.3f}", flush=True)
    def med_max(a):
        return f"{100 * np.median(np.abs(a)):.0f} % (max {100 * np.max(np.abs(a)):.0f} %)"

    for kind, _, view in VIEWS:
        sel = [r for r in rows if r[0] == (kind, view)]
        fr = np.array([r[1] for r in sel])
        hd = np.array([r[2] for r in sel])
        print(f"{kind}, view {view:g} ({len(sel)} twins): f recovered {fr[:, 0].min():.3f}-"
              f"{fr[:, 0].max():.3f}; |kappa| error, f free {med_max(fr[:, 1])}, held at 1 "
              f"{med_max(hd[:, 1])}; |C| f free {med_max(fr[:, 2])}, held at 1 {med_max(hd[:, 2])}")


if __name__ == "__main__":
    args = [int(a) for a in sys.argv[1:3]]
    main(*(args or [1, 4]))
