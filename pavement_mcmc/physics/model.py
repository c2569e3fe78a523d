"""The forward model: parameters -> solver coefficients -> nodal temperatures -> observations.

Observations are the temperatures at the observed sensors and, where the case has heat-flux
plates (``G_<d>cm`` columns), the conductive heat flux at the plates times a calibration factor
per plate (``plate_<label>``, plates read within +-20-30 %). With a measured top
(:meth:`~pavement_mcmc.data.Measurements.with_measured_top`) the shallowest sensor is a Dirichlet
boundary and the surface energy balance (h, net radiation) drops out.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..data.measurements import Measurements
from ..parameters import Parameter, ParameterSpace
from ..parameters.priors import Flat, GMRFSmoothness, Rayleigh, TruncatedNormal
from ..parameters.space import columns
from ..solver import Coefficients, Forcing, Grid, solve, solve_vjp
from .base import Extension
from .hbasis import HBasis
from .observe import (
    flux_weights,
    heat_flux,
    heat_flux_vjp,
    interpolate,
    interpolate_transpose,
    interpolation_weights,
)
from .registry import get_extension

#: the paper's "literature values" (h W m-2 K-1, C J m-3 K-1, kappa W m-1 K-1)
LITERATURE = {"kappa": 2.27, "C": 2.10e6, "h": 10.0}
#: prior of a heat-flux plate's calibration factor: plates read within +-20-30 %
PLATE_PRIOR = TruncatedNormal(1.0, 0.25, 0.05, 20.0)
_FD_REL = 1e-6  # relative step of the coefficient derivatives in solve_vjp


class Model:
    """Base conduction model + extensions for one case.

    Parameters
    ----------
    meas : the case's measurements (with ``T_top`` set: a measured top boundary).
    grid : the solver grid (``Grid.build(meas, ...)``).
    h_basis : the h(t) discretisation (unused with a measured top).
    extensions : extension instances or names (see :mod:`pavement_mcmc.physics.catalogue`).
    scheme : solver scheme, ``"cn"`` (default) or ``"dff"``.
    gamma0 : Rayleigh scale of the smoothness precision when ``h_basis.smooth``, m4 K2 W-2.
    plates : observe the heat-flux plates of ``meas`` (if it has any).
    """

    def __init__(
        self,
        meas: Measurements,
        grid: Grid,
        h_basis: HBasis,
        extensions=(),
        scheme: str = "cn",
        gamma0: float = 2.22,
        plates: bool = True,
    ):
        self.meas = meas
        self.h_basis = h_basis
        self.extensions: list[Extension] = [get_extension(e) for e in extensions]
        names = [e.name for e in self.extensions]
        if len(set(names)) != len(names):
            raise ValueError(f"extension listed twice: {names}")
        layers = [e.name for e in self.extensions if e.over_soil]
        if len(layers) > 1:
            raise ValueError(f"two layers between the air and the soil: {layers}; list one")
        skins = [e.name for e in self.extensions if e.skin_node]
        if len(skins) > 1:
            raise ValueError(f"two extensions put a skin node above the soil: {skins}")
        if skins and meas.T_top is not None:
            raise ValueError(f"{skins[0]} puts a skin above the soil, but a measured top has "
                             "none: its top node is a buried sensor")
        if skins and not grid.soil_top:  # the skin above the soil; depths count from the soil
            grid = grid.with_skin(max(e.skin_node for e in self.extensions))
        elif grid.soil_top and not skins:
            raise ValueError("the grid has a skin node above the soil but no extension puts one "
                             "there: build the model on the soil's grid")
        self.grid = grid
        self.scheme = scheme
        self.gamma0 = gamma0
        self.top_measured = meas.T_top is not None
        self.forcing = Forcing.from_measurements(meas, grid)
        self._obs_i, self._obs_w = interpolation_weights(grid.x, meas.depths + grid.soil_top)
        self.plates = bool(plates) and meas.n_plates > 0
        if self.plates:
            self._flux_c, self._flux_w = flux_weights(grid.x, meas.flux_depths + grid.soil_top)
        self._plate_names = [f"plate_{lab}" for lab in meas.plate_labels] if self.plates else []
        self.replaces_h = self.top_measured or any(e.replaces_h for e in self.extensions)
        if sum(e.replaces_h for e in self.extensions) > 1:
            raise ValueError("two extensions both replace h(t): " + str(names))

    # -- parameters --------------------------------------------------------------------------
    @property
    def plate_names(self) -> list[str]:
        """Calibration-factor parameter of each observed plate, e.g. ``plate_G5cm``."""
        return list(self._plate_names)

    def parameter_space(self) -> ParameterSpace:
        """Every parameter of the model with the paper's priors; extensions add theirs.

        Raises ``ValueError`` naming the clashing names if two components declare the same one.
        """
        params = [
            Parameter("kappa", LITERATURE["kappa"], 1e-3, 50.0,
                      prior=TruncatedNormal(2.27, 0.1135), unit="W m-1 K-1",
                      description="thermal conductivity"),
            Parameter("C", LITERATURE["C"], 1e4, 1e8, prior=TruncatedNormal(2.10e6, 0.021e6),
                      unit="J m-3 K-1", description="volumetric heat capacity"),
        ]
        joint = []
        if not self.replaces_h:
            hp = self.h_basis.parameters()
            if self.h_basis.smooth:
                hp = [replace(p, prior=Flat()) for p in hp]
                params.append(Parameter("gamma", self.gamma0, 0.0, 1e4,
                                        prior=Rayleigh(self.gamma0), unit="m4 K2 W-2",
                                        description="smoothness precision of h(t)"))
                joint.append(GMRFSmoothness(self.h_basis.names, "gamma"))
            params += hp
        params += [Parameter(n, 1.0, 0.05, 20.0, prior=PLATE_PRIOR, unit="-", group="plate",
                             description="heat-flux plate calibration factor (reading / true flux)")
                   for n in self.plate_names]
        owner = {p.name: "base model" for p in params}
        for ext in self.extensions:
            for p in ext.parameters(self.meas):
                if p.name in owner:
                    raise ValueError(
                        f"parameter name clash: {p.name!r} declared by both {owner[p.name]} "
                        f"and extension {ext.name!r}"
                    )
                owner[p.name] = f"extension {ext.name!r}"
                params.append(p)
        return ParameterSpace(params, joint)

    @property
    def surface_order(self) -> list:
        """The extensions in the order their surface hooks run: the one that replaces h(t)
        first (it sets h), a layer between the air and the soil (``surface_layer``) last (it
        damps the h and q every other term made), the others as listed between (they add to
        q). Any order a case lists gives the same coefficients."""
        return sorted(self.extensions, key=lambda e: (not e.replaces_h, e.over_soil))

    # -- forward -----------------------------------------------------------------------------
    def coefficients(self, p: dict[str, np.ndarray], record: dict | None = None) -> Coefficients:
        """Solver coefficients for a batch of parameter sets (``record``: gets the (h, q) that
        enter each surface hook with a ``surface_vjp``, by extension name)."""
        kappa = np.asarray(p["kappa"], float)
        n_sets = kappa.size
        if self.replaces_h:
            h = np.zeros((n_sets, self.meas.n_obs - 1))
        else:
            h = self.h_basis.evaluate(p)
        q = (np.zeros((n_sets, self.meas.n_obs)) if self.top_measured
             else np.broadcast_to(self.meas.q_net, (n_sets, self.meas.n_obs)).copy())
        C, n = np.asarray(p["C"], float), self.grid.x.size
        if kappa.ndim == C.ndim == 1 and C.size == n_sets == h.shape[0]:
            # Coefficients.uniform's arrays, without copying the fresh h and q once more
            coeffs = Coefficients(np.repeat(kappa[:, None], n - 1, axis=1),
                                  np.repeat(C[:, None], n, axis=1), h, q)
        else:
            coeffs = Coefficients.uniform(kappa, C, h, q, n)
        # a skin node's coefficients last: the soil's hooks (e.g. two_layer) set every cell
        for ext in sorted(self.extensions, key=lambda e: bool(e.skin_node)):
            ext.material(coeffs, p, self)
        for ext in self.surface_order:
            if record is not None and ext.surface_vjp is not None:
                record[ext.name] = (coeffs.h.copy(), coeffs.q.copy())
            ext.surface(coeffs, p, self)
        return coeffs

    def solve(self, p: dict[str, np.ndarray]) -> np.ndarray:
        """Nodal temperatures, shape (n_sets, n_obs, n_nodes), degC."""
        return solve(self.grid, self.forcing, self.coefficients(p), scheme=self.scheme)

    def surface_flux(self, T_nodes: np.ndarray, coeffs: Coefficients) -> np.ndarray:
        """Heat flux into the ground at the top (n_sets, n_obs), W m-2: h (T_air - T_s) + q of
        the surface balance (h of the interval ending at each time; the first row uses the
        first interval), or ``-kappa dT/dz`` of the top cell with a measured top."""
        if self.top_measured:
            x = self.grid.x
            return coeffs.kappa[:, None, 0] * (T_nodes[..., 0] - T_nodes[..., 1]) / (x[1] - x[0])
        h = np.concatenate([coeffs.h[:, :1], coeffs.h], axis=1)
        return h * (self.forcing.T_air[None, :] - T_nodes[..., 0]) + coeffs.q

    # -- observations ------------------------------------------------------------------------
    @property
    def observes_nominal(self) -> bool:
        """Whether the sensors are read at their nominal depths only (no extension overrides
        ``observe``): :meth:`observe` is then :meth:`observe_nominal`."""
        return all(type(e).observe is Extension.observe for e in self.extensions)

    @property
    def sensor_weights(self) -> tuple[np.ndarray, np.ndarray]:
        """Left node index and right-node weight of each observed sensor (:meth:`observe_nominal`)."""
        return self._obs_i, self._obs_w

    def observe_nominal(self, T_nodes: np.ndarray) -> np.ndarray:
        """Temperatures at the sensors' nominal depths (n_sets, n_obs, n_sensors)."""
        return interpolate(T_nodes, self._obs_i, self._obs_w)

    def observe_nominal_transpose(self, G: np.ndarray) -> np.ndarray:
        """Adjoint of :meth:`observe_nominal`: sensor cotangents (..., n_sensors) -> nodes."""
        return interpolate_transpose(G, self._obs_i, self._obs_w, self.grid.n_nodes)

    def observe(self, T_nodes: np.ndarray, p: dict[str, np.ndarray]) -> np.ndarray:
        """Sensor predictions (n_sets, n_obs, n_sensors) from nodal temperatures: the nominal
        depths, then every extension's ``observe`` hook in order."""
        pred = self.observe_nominal(T_nodes)
        for ext in self.extensions:
            pred = ext.observe(pred, T_nodes, p, self)
        return pred

    def observe_flux(self, T_nodes: np.ndarray, coeffs: Coefficients,
                     p: dict[str, np.ndarray]) -> np.ndarray | None:
        """Plate readings (n_sets, n_obs, n_plates), W m-2 (calibration factor x conductive flux
        at the plate), or None without plates."""
        if not self.plates:
            return None
        f = columns(p, self.plate_names)
        return f[:, None, :] * heat_flux(T_nodes, coeffs.kappa, self.grid.x, self._flux_c,
                                         self._flux_w)

    def predict(self, p: dict[str, np.ndarray]) -> np.ndarray:
        """Predicted temperatures at the observed sensors, (n_sets, n_obs, n_sensors), degC."""
        return self.observe(self.solve(p), p)

    # -- gradient ----------------------------------------------------------------------------
    @property
    def has_gradient(self) -> bool:
        """Whether :meth:`solve_vjp` is available: the Crank–Nicolson scheme, and extensions
        whose coefficients do not depend on temperature (``adjoint``) and whose ``observe``
        and ``skin`` hooks, if any, give their vector-Jacobian product."""
        for ext in self.extensions:
            overrides_observe = type(ext).observe is not Extension.observe
            if not ext.adjoint or (overrides_observe and ext.observe_vjp is None):
                return False
            if type(ext).skin is not Extension.skin and ext.skin_vjp is None:
                return False
        return self.scheme == "cn"

    def solve_vjp(self, p: dict[str, np.ndarray], cotangent_fn) -> tuple[np.ndarray, list, np.ndarray]:
        """Nodal temperatures and the gradient of a loss with respect to the parameters.

        ``cotangent_fn(T_nodes, coeffs) -> (G, direct)`` gives d loss / d T_nodes (same shape)
        and ``direct``, the loss's own derivatives: ``{"kappa": (n_sets, n_cells)}`` for the
        cell conductivities it reads (flux observations), ``"h"``/``"q"`` for the final surface
        coefficients (a skin temperature, :mod:`.skin`) and ``{name: (n_sets,)}`` for
        parameters. Returns ``(T_nodes, names, grad)``, ``grad`` (n_sets, len(names)) with
        respect to every parameter the model has, by the solver's discrete adjoint (about the
        cost of three solves); extensions' coefficients are differentiated by finite
        differences of :meth:`coefficients` (no solve).
        """
        if not self.has_gradient:
            raise NotImplementedError("no adjoint for this model (scheme or extensions)")
        record: dict = {}
        coeffs = self.coefficients(p, record)
        direct: dict = {}

        def cot(T_nodes):
            G, d = cotangent_fn(T_nodes, coeffs)
            direct.update(d)
            return G

        out, g = solve_vjp(self.grid, self.forcing, coeffs, cot)
        g = dict(g)
        for k in ("kappa", "h", "q"):  # a loss that reads the final coefficients (a skin)
            if k in direct:
                g[k] = g[k] + direct.pop(k)
        grads: dict[str, np.ndarray] = {}
        g_final = dict(g)  # the finite differences below act on the final coefficients
        for ext in reversed(self.surface_order):  # back through the surface hooks that say how
            if ext.surface_vjp is not None:
                g["h"], g["q"], own = ext.surface_vjp(g["h"], g["q"], *record[ext.name], p, self)
                grads.update(own)
        read = {r for e in self.extensions if e.surface_vjp is None for r in e.reads}
        if "kappa" not in read:
            grads["kappa"] = g["kappa"].sum(axis=1)
        if "C" not in read:
            grads["C"] = g["C"][:, :-1].sum(axis=1)
        h_block = None  # the pieces' gradients as one block (not a column per name)
        if not self.replaces_h and "h" not in read:
            h_block = self.h_basis.grad(g["h"])
        fd = [n for n in ("kappa", "C") if n in read]
        if "h" in read and not self.replaces_h:
            fd += list(self.h_basis.names)
        own = self._fd_parameters
        if own:
            fd += [n for n in p if n in own]
        grads.update(self._coefficient_vjp(p, fd, g_final))
        for name, v in direct.items():
            grads[name] = grads.get(name, 0.0) + v
        names = list(grads)
        n_h = 0 if h_block is None else h_block.shape[1]
        G = np.empty((out.shape[0], len(names) + n_h))
        for j, n in enumerate(names):  # assignment broadcasts scalars (no per-name array)
            G[:, j] = grads[n]
        if h_block is not None:
            G[:, len(names):] = h_block
            names += list(self.h_basis.names)
        return out, names, G

    @property
    def _fd_parameters(self) -> set[str]:
        """The parameters of extensions whose surface hook has no vector-Jacobian product (their
        gradients come from finite differences of the coefficients)."""
        return {q.name for e in self.extensions if e.surface_vjp is None
                for q in e.parameters(self.meas)}

    def _coefficient_vjp(self, p, names, g) -> dict[str, np.ndarray]:
        """``sum <g, d coeffs / d p_n>`` for each name, by central differences of the
        coefficients (cheap: no solve)."""
        out = {}
        for n in names:
            v = np.asarray(p[n], float)
            step = _FD_REL * np.maximum(np.abs(v), 1e-3)
            total = np.zeros(v.shape)
            cp = self.coefficients({**p, n: v + step})
            cm = self.coefficients({**p, n: v - step})
            for arr in ("kappa", "C", "h", "q"):
                d = (getattr(cp, arr) - getattr(cm, arr)) / (2.0 * step[:, None])
                total += np.sum(g[arr] * d, axis=1)
            out[n] = total
        return out

    def observe_vjp(self, g_pred: np.ndarray, T_nodes: np.ndarray,
                    p: dict[str, np.ndarray]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Adjoint of :meth:`observe`: prediction cotangents -> nodal cotangents and the
        gradients of the observe hooks' parameters."""
        hooks = []  # the hooks' own nodal cotangents (none without observe hooks)
        direct: dict[str, np.ndarray] = {}
        for ext in reversed(self.extensions):
            if ext.observe_vjp is None:
                continue
            g_pred, gT_ext, d = ext.observe_vjp(g_pred, T_nodes, p, self)
            hooks.append(gT_ext)
            direct.update(d)
        gT = self.observe_nominal_transpose(g_pred)  # a fresh array: add into it
        for h in hooks:
            gT += h
        return gT, direct

    def observe_flux_vjp(self, g_flux: np.ndarray, T_nodes: np.ndarray, coeffs: Coefficients,
                         p: dict[str, np.ndarray], gT: np.ndarray | None = None
                         ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Adjoint of :meth:`observe_flux`: plate cotangents -> (nodal cotangents, added into
        ``gT`` when given; direct gradients: the cell conductivities ``"kappa"`` and the
        calibration factors)."""
        raw = heat_flux(T_nodes, coeffs.kappa, self.grid.x, self._flux_c, self._flux_w)
        f = columns(p, self.plate_names)
        gT, gk = heat_flux_vjp(g_flux * f[:, None, :], T_nodes, coeffs.kappa, self.grid.x,
                               self._flux_c, self._flux_w, gT)
        direct = {"kappa": gk}
        for j, n in enumerate(self.plate_names):
            direct[n] = np.sum(g_flux[..., j] * raw[..., j], axis=1)
        return gT, direct

    def boundary_note(self) -> str | None:
        """What a measured top implies for identifiability (None with a surface balance)."""
        if not self.top_measured:
            return None
        base = ("measured top: the temperatures fix only the diffusivity kappa/C (a common scale "
                "of kappa and C leaves them unchanged); ")
        if self.plates:
            return base + (f"kappa comes from the heat-flux plate(s) {', '.join(self.meas.plate_labels)} "
                           "and its calibration factor's prior")
        return base + "kappa needs a flux observation (a G_<depth>cm column) or a prior on kappa or C"

    def describe(self) -> str:
        ext = ", ".join(e.name for e in self.extensions) or "none"
        law = next((e.name for e in self.extensions if e.replaces_h), None)
        top = ("measured top" if self.top_measured else f"h(t) from {law}" if law
               else f"{len(self.h_basis.names)} h pieces")
        plates = f", {len(self.plate_names)} flux plate(s)" if self.plates else ""
        return f"conduction + {top}{plates}; extensions: {ext}"
