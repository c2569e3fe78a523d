"""The extension base class: a physical effect is one small class overriding one hook.

A model is the base conduction problem plus a list of extensions. Each extension declares its
parameters (explicit names, bounds, priors) and overrides at most a hook or two; the base class
supplies do-nothing defaults. Hooks are called in this order for a batch of parameter sets:

1. :meth:`Extension.material` may edit ``coeffs.kappa`` (n_sets, n_cells), ``coeffs.C``
   (n_sets, n_nodes) or set ``coeffs.beta`` (n_sets,).
2. :meth:`Extension.surface` may edit ``coeffs.h`` (n_sets, n_obs-1) or ``coeffs.q``
   (n_sets, n_obs), the surface flux terms: flux into the ground = h (T_air - T_s) + q.
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

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"
