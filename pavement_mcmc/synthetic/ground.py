"""The simulated ground: layers (thatch, soil, a second soil layer), the node grid and where
sensors, plates and a buried source sit in it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .column import Column, layered_column, point_source, stretched_nodes


@dataclass(frozen=True)
class Ground:
    """A discretised ground and the depths of everything in it.

    Attributes
    ----------
    column : the finite-volume column (node 0 is the surface where the energy balance acts).
    soil_top : depth of the soil surface in the column, m (the thatch thickness, else 0);
        nominal depths d (from the soil surface) sit at ``z = soil_top + d``.
    sensor_z : (n_observed + 1,) true depths of the observed sensors and the bottom one, m.
    plate_z : (n_plates,) depths of the heat-flux plates, m.
    source : (n_nodes,) steady heat source per node, W m-2, or None.
    beta : temperature coefficient of the conductivity, 1/K.
    """

    column: Column
    soil_top: float
    sensor_z: np.ndarray
    plate_z: np.ndarray
    source: np.ndarray | None
    beta: float

    @property
    def z(self) -> np.ndarray:
        return self.column.z


def build_ground(
    kappa: float,
    C: float,
    effects: dict,
    depths: np.ndarray,
    bottom: float,
    column_depth: float,
    dz: float,
    plate_depths: np.ndarray,
) -> Ground:
    """Layers, grid and positions of a twin's ground.

    Parameters
    ----------
    kappa, C : soil (top soil layer) conductivity W m-1 K-1 and heat capacity J m-3 K-1.
    effects : resolved hidden effects (see :mod:`pavement_mcmc.synthetic.effects`); used here:
        surface_layer, two_layer, sensor_depth, buried_source, conductivity_temperature.
    depths : (n_observed,) nominal observed sensor depths, m from the soil surface.
    bottom : nominal bottom sensor depth, m.
    column_depth : depth of the soil column below the soil surface, m (Dirichlet there).
    dz : cell size of the uniformly resolved zone (down to 2 cm below the deepest sensor,
        plate, source or interface), m; geometric growth (x1.08) below.

    Returns
    -------
    Ground.
    """
    top = effects["surface_layer"]["layer_thickness"] if "surface_layer" in effects else 0.0
    kap, Cs, interfaces = [kappa], [C], []
    if "two_layer" in effects:
        p = effects["two_layer"]
        kap, Cs, interfaces = [kappa, p["kappa2"]], [C, p["C2"]], [p["d_layer"] + top]
    if "surface_layer" in effects:
        p = effects["surface_layer"]
        kap, Cs, interfaces = [p["layer_kappa"], *kap], [p["layer_C"], *Cs], [top, *interfaces]
    offsets = np.array(list(effects.get("sensor_depth", {}).values()) or np.zeros(depths.size))
    sensor_z = np.append(depths + offsets, bottom) + top
    plate_z = np.asarray(plate_depths, float) + top
    source_z = effects["buried_source"]["source_depth"] + top if "buried_source" in effects else 0.0
    fine = max(sensor_z.max(), *interfaces, *plate_z, source_z) + 0.02
    z = stretched_nodes(fine, column_depth + top, dz)
    column = layered_column(z, np.asarray(interfaces), np.asarray(kap), np.asarray(Cs))
    source = None
    if "buried_source" in effects:
        source = point_source(z, source_z, effects["buried_source"]["source_flux"])
    beta = effects.get("conductivity_temperature", {}).get("kappa_beta", 0.0)
    return Ground(column, top, sensor_z, plate_z, source, beta)
