"""The extension base class: a physical effect is one small class overriding one hook.

A model is the base conduction problem plus a list of extensions. Each extension declares its
parameters (explicit names, bounds, priors) and overrides at most a hook or two; the base class
supplies do-nothing defaults. Hooks are called in this order for a batch of parameter sets:

1. :meth:`Extension.material` may edit ``coeffs.kappa`` (n_sets, n_cells), ``coeffs.C``
   (n_sets, n_nodes) or set ``coeffs.beta`` (n_sets,).
2. :meth:`Extension.surface` may edit ``coeffs.h`` (n_sets, n_obs-1) or ``coeffs.q``
   (n_sets, n_obs), the surface flux terms: flux into the ground = h (T_air - T_s) + q. The
   hook of an effect that replaces h(t) runs first and a layer over the soil's last
   (:attr:`~pavement_mcmc.physics.model.Model.surface_order`); the others add to q.
3. :meth:`Extension.observe` may change the predicted sensor temperatures (n_sets, n_obs,
   n_sensors) given the nodal solution.

``p`` is a dict of ``(n_sets,)`` arrays, one per parameter of the whole model. ``model`` gives
access to ``model.meas`` (Measurements) and ``model.grid`` (solver Grid).

Example: a user-defined effect, a constant extra heat flux into the ground::

    class ExtraFlux(Extension):
        name = "extra_flux"
        hint = "a constant bias in the surface energy balance"
        def parameters(self, meas):
            return [Parameter("q_extra", 0.0, -100, 100, prior=Normal(0, 20), unit="W m-2")]
        def surface(self, coeffs, p, model):
            coeffs.q += p["q_extra"][:, None]
"""

from __future__ import annotations

import numpy as np

from ..parameters import Parameter


class Extension:
    """A physical effect added to the base conduction model (do-nothing defaults)."""

    #: short unique name used in configs (``extensions = ["two_layer"]``) and ``--add``
    name: str = "extension"
    #: one sentence: which residual pattern this effect explains (shown by ``diagnose``)
    hint: str = ""
    #: True if the effect provides h(t) itself, replacing the free h pieces
    replaces_h: bool = False
    #: residual patterns that point at this effect, keys of
    #: :func:`pavement_mcmc.criticism.residuals.plain_signals` (e.g. ``"corr:q_net"``,
    #: ``"depth_growth"``); ``diagnose`` quotes them as evidence
    signals: tuple[str, ...] = ()
    #: base parameters (``"kappa"``, ``"C"``, ``"h"`` for every h piece) the hooks read besides
    #: the effect's own; the gradient (the solver's adjoint) then differentiates the
    #: coefficients with respect to them too
    reads: tuple[str, ...] = ()
    #: False if the solver's adjoint cannot give this effect's gradient (e.g. a conductivity
    #: that depends on temperature makes the solve nonlinear); the likelihood's gradient is then
    #: taken by central differences of whole solves
    adjoint: bool = True
    #: False if the criticism's ranking should try this effect only when named (a law that
    #: replaces several others, e.g. ``energy_balance``, would shadow them as a look-alike)
    candidate: bool = True
    #: thickness (m) of a skin node this effect puts above the soil (0: none). The model then
    #: solves on its grid with that node on top (:meth:`~pavement_mcmc.solver.Grid.with_skin`):
    #: sensor and plate depths still count from the soil surface below it, and the effect's
    #: ``material`` hook (run after the others) sets the skin's first cell and node
    skin_node: float = 0.0

    @property
    def over_soil(self) -> bool:
        """Whether the effect is a layer between the air and the soil (a skin node, or a skin
        hook such as ``surface_layer``'s): a model takes one such layer at most."""
        return bool(self.skin_node) or type(self).skin is not Extension.skin

    def parameters(self, meas) -> list[Parameter]:
        """The effect's parameters, with values at the *null* (no-effect) point where one exists."""
        return []

    def null_values(self, meas) -> dict[str, float] | None:
        """Parameter values at which the effect vanishes (for score tests); None if it has none."""
        return None

    def start_values(self, meas, base: dict[str, float]) -> list[dict[str, float]]:
        """Extra starting points for quick refits, for effects with several optima (optional).

        ``base`` is the current point estimate by parameter name; return a list of dicts of
        this effect's parameter values to try besides its default values.
        """
        return []

    def material(self, coeffs, p: dict[str, np.ndarray], model) -> None:
        """Edit the material coefficients in place."""

    def surface(self, coeffs, p: dict[str, np.ndarray], model) -> None:
        """Edit the surface flux terms in place."""

    def observe(self, pred: np.ndarray, T_nodes: np.ndarray, p: dict[str, np.ndarray], model):
        """Return the predicted sensor temperatures, possibly changed."""
        return pred

    def skin(self, T: np.ndarray, G: np.ndarray, p: dict[str, np.ndarray], model) -> np.ndarray:
        """The skin temperature (n_sets, n_obs) above ``T`` (the soil top, or the skin of an
        earlier layer) given the flux into the ground ``G``: what an infrared thermometer
        reads (:mod:`pavement_mcmc.physics.skin`). Override together with ``skin_vjp``."""
        return T

    skin_vjp = None
    """``skin_vjp(g, T, G, p, model) -> (g_T, g_G, {name: (n_sets,)})``: the cotangents of
    ``T`` and ``G`` and the gradients of the effect's parameters, given ``g`` of the skin."""

    # Gradients (optional). The material and surface hooks need nothing more: the model
    # differentiates the coefficients they produce with respect to the effect's parameters
    # (and to ``reads``) by finite differences, which costs no solve. An ``observe`` hook needs
    # its vector-Jacobian product below, else the gradient falls back to whole solves.
    observe_vjp = None
    """``observe_vjp(g_pred, T_nodes, p, model) -> (g_pred_in, g_T_nodes, {name: (n_sets,)})``:
    the cotangents of the predictions before the hook, the extra cotangents of the nodal
    temperatures, and the gradients of the effect's parameters, given ``g_pred`` after it."""
    surface_vjp = None
    """``surface_vjp(g_h, g_q, h_in, q_in, p, model) -> (g_h_in, g_q_in, {name: (n_sets,)})``
    (optional, for a surface hook that reads h: exact and cheaper than finite differences over
    every h piece): the cotangents of ``coeffs.h`` and ``coeffs.q`` before the hook (whose
    values there were ``h_in``, ``q_in``) and the gradients of the effect's parameters."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"
