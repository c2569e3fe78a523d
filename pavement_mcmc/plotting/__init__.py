"""Every figure of the package. The only package that imports matplotlib.

Functions take arrays (or small result objects such as
:class:`~pavement_mcmc.analysis.sensitivity.Sensitivity`) plus an optional ``fig`` and RETURN the
:class:`~matplotlib.figure.Figure`; they use :class:`~matplotlib.figure.Figure` objects directly
(no pyplot global state), so they work with any backend and in threads. Save with
``fig.savefig(path)``. Figures of a stored run are assembled by :mod:`pavement_mcmc.report`.
"""

from ._base import default_selection, display
from .batch import plot_batch, plot_season
from .chains import (
    plot_acceptance,
    plot_autocovariance,
    plot_chains,
    plot_geweke,
    plot_logp,
    plot_segments,
)
from .energy import plot_energy_balance
from .fit import plot_fit, plot_streams
from .physics import plot_fluxes, plot_h, plot_identifiability, plot_sensitivity, plot_urban
from .posterior import plot_corner

__all__ = [
    "default_selection",
    "display",
    "plot_acceptance",
    "plot_autocovariance",
    "plot_batch",
    "plot_chains",
    "plot_corner",
    "plot_energy_balance",
    "plot_fit",
    "plot_fluxes",
    "plot_geweke",
    "plot_h",
    "plot_identifiability",
    "plot_logp",
    "plot_segments",
    "plot_season",
    "plot_sensitivity",
    "plot_streams",
    "plot_urban",
]
