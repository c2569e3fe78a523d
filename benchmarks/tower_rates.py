"""How often the flux-tower check (criticism/tower.py) agrees and disagrees, on twins with a
tower that closes 85 % of the balance (``SyntheticSpec.tower``; 72 h, 30 min, independent
simulator), seeds given on the command line (default 10-19):

- ``evapotranspiration`` twins (Priestley-Taylor latent heat on R_n; h diurnal, not a wind
  law) fitted with ``energy_balance_window``: the LE and H the law implies should agree;
  fitted with the latent heat fixed at 0: LE should disagree;
- ``wind_convection`` twins (h from the wind, no latent heat) fitted with the law: agree;
- clean twins (h diurnal, no latent heat): the law's H form is not the twin's, which the tower
  may see; and the base fit (free h) must not push more into the ground than the tower leaves
  (the energy check's alarm: a false alarm here).

    PYTHONPATH=. python benchmarks/tower_rates.py [first_seed n]
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from pavement_mcmc.criticism import refit
from pavement_mcmc.criticism.energy import energy_balance
from pavement_mcmc.criticism.point import case_problem
from pavement_mcmc.criticism.tower import tower_check
from pavement_mcmc.physics.catalogue.energy import energy_partition
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin

NO_LE = {"parameters": {"eb_alpha": {"value": 0.0, "vary": False}}}


def law_check(case: Path, overrides=None):
    pb, _ = case_problem(f"{case}+energy_balance_window", overrides)
    v = {**pb.space.value_dict(), **refit(pb).values()}
    part = energy_partition(pb.model, {k: np.array([x]) for k, x in v.items()})
    return tower_check(part, pb.meas)


def main(first: int, n: int) -> None:
    tmp = Path(tempfile.mkdtemp())
    counts: dict[str, list[int]] = {}

    def count(key: str, ok: bool) -> None:
        counts.setdefault(key, [0, 0])
        counts[key][0] += int(ok)
        counts[key][1] += 1

    for seed in range(first, first + n):
        for effects in (("evapotranspiration",), ("wind_convection",), ()):
            twin = forecast_twins(effects, (seed,), hours=72.0,
                                  spec={"tower": 0.85, "et_available": "net"})[0]
            case = write_twin(twin, tmp / twin.name)
            name = effects[0] if effects else "clean"
            tc = law_check(case)
            count(f"{name}: the law agrees with the tower (H and LE)", tc.agrees)
            line = f"{twin.name}: law {tc.text()}"
            if name == "evapotranspiration":
                dry = law_check(case, NO_LE)
                count(f"{name}: LE fixed at 0 disagrees on LE", not dry.fluxes["LE"]["agrees"])
            pb, _ = case_problem(case)
            eb = energy_balance(pb, refit(pb).values(), top_fit=False)
            alarm = eb.fit_share > eb.tower_share + 0.1
            count(f"{name}: base fit (free h), no tower alarm", not alarm)
            print(line + f" | base G/Rn {eb.fit_share:.2f} vs tower {eb.tower_share:.2f}",
                  flush=True)
    for key, (k, m) in counts.items():
        print(f"{key}: {k} of {m}")


if __name__ == "__main__":
    args = [int(a) for a in sys.argv[1:3]]
    main(*(args or [10, 10]))
