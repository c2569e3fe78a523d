"""The toy chain writer of the storage fault tests, run in a subprocess.

``python toy_writer.py PATH ROWS`` creates the run at PATH or continues it, up to ROWS rows in
blocks of 7, the rows drawn from the stored Generator (so a resume continues the same chain).
A failed write (a full disk, a file-size limit) prints the error and the committed steps as
JSON and exits with 3. The fault tests import :func:`write` into scripts that set the fault
up first (a file-size limit, a kill at a given moment).
"""

from __future__ import annotations

import json
import sys

import numpy as np

from pavement_mcmc.storage import HDF5Store, RunState, StoreWriteFailed


def write(path: str, total: int, m: int = 16, p: int = 6) -> None:
    try:
        store = HDF5Store.open_append(path)
        rng = store.state.make_rng()
    except FileNotFoundError:
        store = HDF5Store.create(path, [f"p{i}" for i in range(p)], ["b"], m, {})
        rng = np.random.default_rng(3)
    try:
        while store.n_saved < total:
            for _ in range(7):
                x = rng.standard_normal((m, p))
                store.append(x, x.sum(1), x[:, :1], x[:, 0] > 0)
            store.flush(RunState.capture(x, x.sum(1), x[:, :1], rng))
    except StoreWriteFailed as err:
        print(json.dumps({"error": str(err), "n_saved": err.n_saved}))
        store.close()
        sys.exit(3)
    store.close()


if __name__ == "__main__":
    write(sys.argv[1], int(sys.argv[2]))
