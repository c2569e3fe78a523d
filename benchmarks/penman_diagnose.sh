#!/bin/bash
# `pavement-mcmc diagnose` on 72 h twins with RH and a flux tower (docs/VALIDATION.md section 4):
# "pm" twins lose latent heat in the Penman-Monteith form (r_s 150 s/m, vapour 1.0 kPa) over a
# wind-driven h; "clean" twins have the same RH and wind-driven h but no latent heat. Prints each
# verdict's first line and whether the energy balance's partition agrees with the tower.
#   bash benchmarks/penman_diagnose.sh [SEEDS...]   (default 7 8 9 10 11; needs make install)
cd "$(dirname "$0")/.." || exit 1
repo=$(pwd)
seeds=("$@")
[ ${#seeds[@]} -eq 0 ] && seeds=(7 8 9 10 11)
out=$(mktemp -d)
for seed in "${seeds[@]}"; do
  for kind in pm clean; do
    if [ "$kind" = pm ]; then
      spec="{'tower': 0.85, 'vapour_kPa': 1.0, 'surface_resistance': 150.0}"
    else
      spec="{'tower': 0.85, 'vapour_kPa': 1.0}"
    fi
    d="$out/$kind-$seed"
    OMP_NUM_THREADS=1 "$repo/.venv/bin/python" -c "
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin
write_twin(forecast_twins(('wind_convection',), ($seed,), hours=72.0, spec=$spec)[0], '$d')"
    (cd "$d" && OMP_NUM_THREADS=1 "$repo/.venv/bin/pavement-mcmc" diagnose case.toml > diag.txt 2>&1)
    verdict=$(grep -m1 '^Verdict' "$d/diag.txt" | cut -c1-150)
    tower=$(tr '\n' ' ' < "$d/diag.txt" | grep -o "partition [A-Za-z ]* the flux tower's" | head -1)
    echo "$kind seed $seed: $verdict ${tower:+| $tower}"
  done
done
