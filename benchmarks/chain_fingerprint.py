"""Fingerprints of the chains of Cases A/B/C and the Göttingen grass window, for checking that a
refactoring leaves every chain bit-identical.

    python benchmarks/chain_fingerprint.py > before.txt   # on the old commit
    python benchmarks/chain_fingerprint.py > after.txt    # on the new one
    diff before.txt after.txt                              # no output: bit-identical

Cases A and C run to their stopping rule (so the rule's decision is fingerprinted too), Case B
and the grass window (skipped without ../shared) for a fixed number of steps; then Cases A
(to its rule) and B (fixed steps) again under ``hmc`` instead of their shipped ``fast``. Each line is the
case, the steps taken, whether it converged, and SHA-256 digests of the stored chain, the
log-posterior and the sampler's saved state.
"""

from __future__ import annotations

import hashlib
import sys
import tempfile
from pathlib import Path

import numpy as np

from pavement_mcmc.runs import fit
from pavement_mcmc.storage.hdf5 import read_run

ROOT = Path(__file__).resolve().parents[1]
CASES = [  # (name, case TOML, sampler overrides)
    ("caseA", "caseA", {}),
    ("caseB", "caseB", {"max_steps": 400, "ess_target": 1e9}),
    ("caseC", "caseC", {}),
    ("grass", "grass", {"max_steps": 320, "ess_target": 1e9}),
    # Cases A and B ship with ``fast``: under ``hmc`` too, for its preparation (Laplace metric,
    # its guard) which the shipped samplers of A and B never reach
    ("caseA_hmc", "caseA", {"kind": "hmc"}),
    ("caseB_hmc", "caseB", {"kind": "hmc", "max_steps": 400, "ess_target": 1e9}),
]


def digest(a) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:16]


def _feed(h, v) -> None:
    if isinstance(v, dict):
        for k in sorted(v):
            h.update(str(k).encode())
            _feed(h, v[k])
    elif isinstance(v, np.ndarray):
        h.update(np.ascontiguousarray(v).tobytes())
    else:
        h.update(repr(v).encode())


def state_digest(state) -> str:
    """position, log_prob, blobs, the Generator's state, the sampler's extras and arrays."""
    h = hashlib.sha256()
    if state is not None:
        _feed(h, {k: getattr(state, k) for k in ("position", "log_prob", "blobs", "rng_state",
                                                 "extra", "arrays")})
    return h.hexdigest()[:16]


def main(names: list[str]) -> int:
    for name, toml, samp in CASES:
        if names and name not in names:
            continue
        case = ROOT / "runs" / f"{toml}.toml"
        if name == "grass" and not (ROOT.parent / "shared" / "data" / "goettingen_grass").exists():
            print(f"{name}: skipped (no ../shared/data/goettingen_grass)")
            continue
        with tempfile.TemporaryDirectory() as tmp:
            out = fit(case, Path(tmp) / name, overrides={"sampler": samp} if samp else None)
            data = read_run(Path(tmp) / name / "chain.h5")
            print(f"{name}: steps={out.result.n_steps} converged={out.result.converged} "
                  f"chain={digest(data.chain)} log_prob={digest(data.log_prob)} "
                  f"state={state_digest(data.state)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
