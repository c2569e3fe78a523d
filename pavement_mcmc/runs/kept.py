"""The kept chain of a stored run: :func:`keep`, the one rule that decides the burn-in, and
:class:`KeptChain`, the one view of what is kept (modelled on emcee's
``get_chain(discard=, thin=, flat=)``). Every reader of a run (report, diagnostics, diagnose,
compare, batch, guards, export, the statistics table) asks it for the kept rows.

The burn-in, in stored rows, is the first of

1. the one the caller gives (``--burn-in``);
2. the run loop's choice, stored in ``result.json`` (a finished run);
3. the case's ``sampler.burn_in`` (in steps; converted to stored rows);
4. for a run still being written: the MSER-5 truncation point of the log-posterior after the
   sampler's adaptation (:func:`~pavement_mcmc.diagnostics.choose_burn_in`), half the chain
   when it is too short for MSER;

raised to the end of the adaptation (no adaptation row is ever kept) and capped so that at
least one row is kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..diagnostics import choose_burn_in
from ..storage import RunData


@dataclass(frozen=True)
class KeptChain:
    """The rows of ``run`` after ``burn_in`` (stored rows; ``source`` says where it came from).

    ``n_adapt_rows``: stored rows of the sampler's adaptation (all inside the burn-in).
    """

    run: RunData
    burn_in: int
    source: str
    n_adapt_rows: int = 0

    @property
    def n_saved(self) -> int:
        return self.run.n_saved

    @property
    def n_kept(self) -> int:
        return max(self.run.n_saved - self.burn_in, 0)

    @property
    def param_names(self) -> list[str]:
        return list(self.run.param_names)

    def _cut(self, a: np.ndarray, thin: int, flat: bool) -> np.ndarray:
        if int(thin) < 1:
            raise ValueError(f"thin must be >= 1, got {thin}")
        k = a[self.burn_in :: int(thin)]
        return k.reshape(-1, *k.shape[2:]) if flat else k

    def get_chain(self, thin: int = 1, flat: bool = False) -> np.ndarray:
        """(n_kept / thin, n_chains, n_params), or (n_kept / thin * n_chains, n_params) if
        ``flat`` (step-major: all chains of a step, then the next step)."""
        return self._cut(self.run.chain, thin, flat)

    def get_log_prob(self, thin: int = 1, flat: bool = False) -> np.ndarray:
        """(n_kept / thin, n_chains), or flat."""
        return self._cut(self.run.log_prob, thin, flat)

    def get_blobs(self, thin: int = 1, flat: bool = False) -> np.ndarray:
        """(n_kept / thin, n_chains, n_blobs), or flat."""
        return self._cut(self.run.blobs, thin, flat)

    def get_accepted(self, thin: int = 1, flat: bool = False) -> np.ndarray:
        """(n_kept / thin, n_chains) bool, or flat."""
        return self._cut(self.run.accepted, thin, flat)


def _loop(run: RunData) -> dict:
    return (getattr(run.state, "extra", None) or {}).get("loop", {})


def adapt_rows(run: RunData, result: dict | None) -> int:
    """Stored rows of the sampler's adaptation: ``result.json``'s record, else the loop state's."""
    res = result or {}
    if isinstance(res.get("n_adapt_rows"), int | float):
        return int(res["n_adapt_rows"])
    loop = _loop(run)
    return int(loop.get("n_adapt", 0)) // max(1, int(loop.get("thin", 1)))


def _chosen(run: RunData, result: dict, sampler_cfg: dict, n_adapt: int) -> tuple[int, str]:
    """Steps 2-4 of the module docstring."""
    if isinstance(result.get("burn_in"), int | float):
        return int(result["burn_in"]), "chosen by the sampler loop (result.json)"
    b = sampler_cfg.get("burn_in")
    if b is not None:
        thin = max(1, int(_loop(run).get("thin", sampler_cfg.get("thin") or 1)))
        return -(-int(b) // thin), "from the case config"
    try:
        return (n_adapt + choose_burn_in(run.log_prob[n_adapt:]),
                "chosen by MSER on the log-posterior trace after the adaptation")
    except ValueError:
        return max(n_adapt, run.n_saved // 2), "half the chain (too short for MSER)"


def keep(run: RunData, result: dict | None = None, sampler_cfg: dict | None = None,
         burn_in: int | None = None) -> KeptChain:
    """The kept chain of ``run``: the one burn-in rule (see the module docstring).

    Parameters
    ----------
    run : the stored chain.
    result : the run's ``result.json`` (None or {} while it is unfinished).
    sampler_cfg : the case's ``[sampler]`` (its ``burn_in``, ``thin``).
    burn_in : stored rows to discard, given by the caller (still raised to the adaptation).
    """
    n = run.n_saved
    if n < 1:
        return KeptChain(run, 0, "no committed steps yet", 0)
    n_adapt = min(adapt_rows(run, result), n - 1)
    if burn_in is not None:
        burn_in, src = int(burn_in), "given"
    else:
        burn_in, src = _chosen(run, result or {}, sampler_cfg or {}, n_adapt)
    if burn_in < n_adapt:
        burn_in, src = n_adapt, f"{src}, raised to the end of the sampler's adaptation"
    return KeptChain(run, int(min(max(burn_in, 0), n - 1)), src, n_adapt)
