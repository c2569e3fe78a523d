"""The forward model: parameters -> solver coefficients -> nodal temperatures -> sensor predictions."""

from __future__ import annotations

import numpy as np

from ..data.measurements import Measurements
from ..parameters import Parameter, ParameterSpace
from ..parameters.priors import Flat, GMRFSmoothness, Rayleigh, TruncatedNormal
from ..solver import Coefficients, Forcing, Grid, solve, solve_vjp
from .base import Extension
from .hbasis import HBasis
from .observe import interpolate, interpolate_transpose, interpolation_weights
from .registry import get_extension

#: the paper's "literature values" (h W m-2 K-1, C J m-3 K-1, kappa W m-1 K-1)
LITERATURE = {"kappa": 2.27, "C": 2.10e6, "h": 10.0}


class Model:
    """Base conduction model + extensions for one case.

    Parameters
    ----------
    meas : the case's measurements.
    grid : the solver grid (``Grid.build(meas, ...)``).
    h_basis : the h(t) discretisation.
    extensions : extension instances or names (see :mod:`pavement_mcmc.physics.catalogue`).
    scheme : solver scheme, ``"cn"`` (default) or ``"dff"``.
    gamma0 : Rayleigh scale of the smoothness precision when ``h_basis.smooth``, m4 K2 W-2.
    """

    def __init__(
        self,
        meas: Measurements,
        grid: Grid,
        h_basis: HBasis,
        extensions=(),
        scheme: str = "cn",
        gamma0: float = 2.22,
    ):
        self.meas = meas
        self.grid = grid
        self.h_basis = h_basis
        self.extensions: list[Extension] = [get_extension(e) for e in extensions]
        names = [e.name for e in self.extensions]
        if len(set(names)) != len(names):
            raise ValueError(f"extension listed twice: {names}")
        self.scheme = scheme
        self.gamma0 = gamma0
        self.forcing = Forcing.from_measurements(meas, grid)
        self._obs_i, self._obs_w = interpolation_weights(grid.x, meas.depths)
        self.replaces_h = any(e.replaces_h for e in self.extensions)
        if sum(e.replaces_h for e in self.extensions) > 1:
            raise ValueError("two extensions both replace h(t): " + str(names))

    # -- parameters --------------------------------------------------------------------------
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
                from dataclasses import replace

                hp = [replace(p, prior=Flat()) for p in hp]
                params.append(Parameter("gamma", self.gamma0, 0.0, 1e4,
                                        prior=Rayleigh(self.gamma0), unit="m4 K2 W-2",
                                        description="smoothness precision of h(t)"))
                joint.append(GMRFSmoothness(self.h_basis.names, "gamma"))
            params += hp
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

    # -- forward -----------------------------------------------------------------------------
    def coefficients(self, p: dict[str, np.ndarray]) -> Coefficients:
        """Solver coefficients for a batch of parameter sets."""
        kappa = np.asarray(p["kappa"], float)
        n_sets = kappa.size
        if self.replaces_h:
            h = np.zeros((n_sets, self.meas.n_obs - 1))
        else:
            h = self.h_basis.evaluate(p)
        q = np.broadcast_to(self.meas.q_net, (n_sets, self.meas.n_obs)).copy()
        coeffs = Coefficients.uniform(kappa, np.asarray(p["C"], float), h, q, self.grid.x.size)
        for ext in self.extensions:
            ext.material(coeffs, p, self)
        for ext in self.extensions:
            ext.surface(coeffs, p, self)
        return coeffs

    def solve(self, p: dict[str, np.ndarray]) -> np.ndarray:
        """Nodal temperatures, shape (n_sets, n_obs, n_nodes), degC."""
        return solve(self.grid, self.forcing, self.coefficients(p), scheme=self.scheme)

    @property
    def has_gradient(self) -> bool:
        """Whether :meth:`solve_vjp` is available: the adjoint covers the base model (uniform
        kappa and C, h from the basis) with the Crank–Nicolson scheme, no extension."""
        return not self.extensions and self.scheme == "cn"

    def solve_vjp(self, p: dict[str, np.ndarray], cotangent_fn) -> tuple[np.ndarray, list, np.ndarray]:
        """Nodal temperatures and the gradient of a loss with respect to the parameters.

        ``cotangent_fn(T_nodes) -> G`` gives d loss / d T_nodes (same shape); returns
        ``(T_nodes, names, grad)`` with ``grad`` (n_sets, len(names)) the gradient with respect
        to kappa, C and every h piece (``names``), by the discrete adjoint of the solver
        (:mod:`pavement_mcmc.solver.adjoint`): about the cost of three solves.
        """
        if not self.has_gradient:
            raise NotImplementedError("the adjoint covers the base model with the 'cn' scheme only")
        out, g = solve_vjp(self.grid, self.forcing, self.coefficients(p), cotangent_fn)
        cols = [g["kappa"].sum(axis=1)[:, None], g["C"][:, :-1].sum(axis=1)[:, None]]
        names = ["kappa", "C"]
        if not self.replaces_h:
            cols.append(g["h"] @ self.h_basis.W)
            names += list(self.h_basis.names)
        return out, names, np.concatenate(cols, axis=1)

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

    def predict(self, p: dict[str, np.ndarray]) -> np.ndarray:
        """Predicted temperatures at the observed sensors, (n_sets, n_obs, n_sensors), degC."""
        return self.observe(self.solve(p), p)

    def describe(self) -> str:
        ext = ", ".join(e.name for e in self.extensions) or "none"
        return f"conduction + {len(self.h_basis.names)} h pieces; extensions: {ext}"
