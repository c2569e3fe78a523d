"""Writing twin datasets in the CSV contract and turning columns into ``Measurements``."""

from __future__ import annotations

import csv
import json
import re
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ..data.measurements import Measurements
from ..data.times import seconds_between
from .effects import EFFECTS, REFERENCE_KEYS
from .simulate import SyntheticSpec, Truth, simulate

# decimals of each column in the CSV (those of the shipped reference case)
_DECIMALS = {"T_air": 2, "q_net": 1, "wind": 2, "rain": 1, "RH": 1, "SWC": 3}
_T_COLUMN = re.compile(r"^T_(\d+(?:\.\d+)?)cm$")


def write_case(spec: SyntheticSpec, directory: str | Path, name: str | None = None) -> Path:
    """Simulate ``spec`` and write ``measurements.csv`` and ``truth.json`` into ``directory``.

    Parameters
    ----------
    spec : what to generate.
    directory : output folder (created if needed).
    name : case name recorded in truth.json (default: the folder's name).

    Returns
    -------
    Path of the written measurements.csv. Temperatures and T_air have 2 decimals, q_net and
    rain 1, wind 2, as in the reference case, heat-flux plates ``G_<d>cm`` 1, ``SWC`` 3. truth.json has
    the reference case's keys (kappa, C, sigma, h_true_obs, one key per catalogue effect, null
    when absent) plus ``effects`` (every hidden effect -> parameters), ``spec`` and the series
    of :func:`truth_record`.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    columns, truth = simulate(spec)
    csv_path = directory / "measurements.csv"
    names = list(columns)
    with csv_path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(names)
        for i in range(columns["time"].size):
            writer.writerow(
                [columns[c][i] if c == "time" else f"{columns[c][i]:.{_decimals(c)}f}" for c in names]
            )
    record = truth_record(spec, truth, name or directory.name)
    (directory / "truth.json").write_text(json.dumps(record, indent=1))
    return csv_path


def drop_columns(csv_path: str | Path, names: tuple[str, ...]) -> None:
    """Remove the columns ``names`` from a written twin's CSV, in place: a record that lacks a
    series the simulator made (a site without humidity: ``("RH",)``)."""
    path = Path(csv_path)
    with path.open(newline="") as f:
        rows = list(csv.reader(f))
    keep = [j for j, h in enumerate(rows[0]) if h not in names]
    with path.open("w", newline="") as f:
        csv.writer(f, lineterminator="\n").writerows([[r[j] for j in keep] for r in rows])


def _decimals(column: str) -> int:
    return 1 if column.startswith("G_") or column in ("H", "LE") else _DECIMALS.get(column, 2)


def truth_record(spec: SyntheticSpec, truth: Truth, name: str) -> dict:
    """The JSON-ready truth of a dataset (the reference case's truth.json format, extended).

    Besides the reference keys: ``effects`` (every hidden effect, e.g. ``surface_layer`` with
    its derived ``R_surface``, ``evapotranspiration`` with ``et_alpha``), ``q_et_obs`` (true
    evapotranspiration LE at each row, W m-2, when that effect is on, or the soil-water limited
    one of ``swc_fc``), ``swc_true_obs`` (true top-soil water content, m3 m-3), ``flux_true_obs``
    (``G_<d>cm`` -> true conductive flux at each row, W m-2, positive downward, before the
    plate's factor and noise), ``soil_top_m`` (thatch thickness, m), ``grid`` (the simulator's
    cell size and time step) and ``spec``.
    """
    record: dict = {"name": name, "seed": spec.seed, "kappa": truth.kappa, "C": truth.C}
    for effect in EFFECTS:
        record[REFERENCE_KEYS[effect]] = truth.effects.get(effect)
    record["sigma"] = truth.sigma
    record["note"] = "synthetic twin; hidden effects: " + (", ".join(truth.effects) or "none")
    record["h_true_obs"] = [round(float(v), 3) for v in truth.h_obs]
    record["rmse_noise_only"] = truth.noise_rms
    record["effects"] = truth.effects
    if "evapotranspiration" in truth.effects or truth.swc is not None:
        record["q_et_obs"] = [round(float(v), 2) for v in truth.q_et]
    if truth.swc is not None:
        record["swc_true_obs"] = [round(float(v), 4) for v in truth.swc]
    if truth.flux:
        record["flux_true_obs"] = {k: [round(float(v), 2) for v in s] for k, s in truth.flux.items()}
    record["soil_top_m"] = truth.soil_top
    record["grid"] = {"dz_m": truth.dz, "dt_s": truth.dt}
    record["spec"] = {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(spec).items()}
    return record


def to_measurements(
    columns: dict[str, np.ndarray],
    sigma: float,
    *,
    bottom_cm: float | None = None,
    source: str = "synthetic",
) -> Measurements:
    """Build :class:`~pavement_mcmc.data.Measurements` straight from simulated columns.

    Parameters
    ----------
    columns : output of :func:`simulate` (or columns read back from its CSV, as arrays).
    sigma : measurement noise sd to record, degC.
    bottom_cm : depth of the Dirichlet sensor, cm; default the deepest ``T_<d>cm`` column.
        Every ``T_<d>cm`` column shallower than it is observed.
    source : recorded as ``Measurements.source``.

    Returns
    -------
    Measurements with t in s from the first row.
    """
    found = {}
    for name in columns:
        match = _T_COLUMN.match(name)
        if match:
            found[float(match.group(1))] = name
    if len(found) < 2:
        raise ValueError("need at least two T_<depth>cm columns (observed sensors + bottom)")
    bottom = max(found) if bottom_cm is None else float(bottom_cm)
    if bottom not in found:
        raise ValueError(f"no column T_{bottom:g}cm for the bottom sensor")
    observed = sorted(d for d in found if d < bottom)
    t = seconds_between(columns["time"])
    if np.any(np.diff(t) <= 0):
        raise ValueError("times must be strictly increasing")

    def get(name: str) -> np.ndarray | None:
        return None if name not in columns else np.asarray(columns[name], float)

    return Measurements(
        t=t,
        time0=str(columns["time"][0]),
        T_air=get("T_air"),
        q_net=get("q_net"),
        wind=get("wind"),
        rain=get("rain"),
        depths=np.asarray(observed) / 100.0,
        T_obs=np.stack([np.asarray(columns[found[d]], float) for d in observed], axis=1),
        bottom_depth=bottom / 100.0,
        T_bottom=np.asarray(columns[found[bottom]], float),
        sigma=float(sigma),
        source=source,
    )
