"""Convergence and mixing diagnostics: pure functions on chain arrays.

Chains are arrays shaped ``(n_steps, n_chains, n_params)`` (the layout of emcee's
``get_chain()``). A 2-D array is read as ``(n_steps, n_chains)`` of one parameter and a 1-D
array as a single chain of one parameter. Per-parameter results are arrays of shape
``(n_params,)`` (``(1,)`` for 1-D and 2-D input).

:class:`StoppingRule` is the one stopping rule of a run (the loop stops on it, the diagnostics
and the report judge by it). Nothing here prints. A diagnostic that cannot be trusted raises
:class:`AutocorrError` (carrying the estimate) or, when asked to be quiet, emits an
:class:`AutocorrWarning`.

Notes on emcee
--------------
emcee's walkers are *not* independent chains: every stretch move uses the positions of the other
walkers. Quantities that treat walkers as independent replicates (ESS = N M / tau, split-R-hat,
the pooled Geweke test, MCSE) are therefore approximations; R-hat across walkers in particular is
optimistic. The integrated autocorrelation time averaged over walkers is the diagnostic emcee's
authors recommend.
"""

from __future__ import annotations

from .autocorr import (
    AutocorrError,
    AutocorrWarning,
    autocorrelation,
    autocovariance_norm,
    ess,
    integrated_time,
    mcse,
    mcse_sd,
)
from .burnin import choose_burn_in, is_drifting, trend_z
from .rhat import split_rhat
from .segments import SegmentSummary, acceptance_over_time, segment_summary
from .stationarity import GewekeResult, GewekeVerdict, geweke, geweke_components, geweke_verdict
from .stopping import Check, StoppingRule
from .summarize import summary

__all__ = [
    "AutocorrError",
    "AutocorrWarning",
    "Check",
    "GewekeResult",
    "GewekeVerdict",
    "SegmentSummary",
    "StoppingRule",
    "acceptance_over_time",
    "autocorrelation",
    "autocovariance_norm",
    "choose_burn_in",
    "ess",
    "geweke",
    "geweke_components",
    "geweke_verdict",
    "integrated_time",
    "is_drifting",
    "mcse",
    "mcse_sd",
    "segment_summary",
    "split_rhat",
    "summary",
    "trend_z",
]
