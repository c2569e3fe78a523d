"""The stopping rule of a run: one frozen :class:`StoppingRule` that owns its thresholds and
:meth:`~StoppingRule.check`.

The run loop stops on it, the run folder stores it (``result.json``, key ``"rule"``), and the
diagnostics, the report and the batch table judge the run by the same object. Changing a
threshold is a change of this file only.

A kept chain (stored rows after the burn-in) passes when every parameter has ESS >=
``ess_target``, the chain is at least ``min_tau_lengths`` integrated autocorrelation times long,
every split-R-hat is below ``rhat_max``, the mean log-posterior does not drift
(``|trend z| <= drift_z``, :func:`~pavement_mcmc.diagnostics.is_drifting`) and, with
``geweke``, the early and late means of the kept chain agree by Geweke's test
(:func:`~pavement_mcmc.diagnostics.geweke_verdict`, the test the assessment judges a run by: a
run the rule stops is not then called untrustworthy by it). The burn-in, unless
given, is the adaptation rows plus the MSER-5 truncation point of the log-posterior after them
(:func:`~pavement_mcmc.diagnostics.choose_burn_in`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace

import numpy as np

from .autocorr import integrated_time
from .burnin import choose_burn_in, is_drifting
from .rhat import RHAT_ROWS, split_rhat
from .stationarity import GEWEKE_ROWS, geweke_verdict

#: rows (after thinning) on which a check estimates tau, ESS and drift / split-R-hat
TAU_ROWS = 1000
#: fewest kept rows a check estimates anything from
MIN_KEPT_ROWS = 8


@dataclass
class Check:
    """The outcome of :meth:`StoppingRule.check`: the burn-in (rows), per-parameter ESS, tau (in
    rows) and split-R-hat (``nan`` where not evaluated), the kept acceptance, the drift flag and
    the failed criteria (empty: the rule is met); ``held_by``, the parameter that failed: the
    one a quick check (``first``) failed on, else the largest R-hat when R-hat failed, else the
    smallest ESS when the ESS failed; None when neither failed."""

    burn_in: int
    ess: np.ndarray
    tau: np.ndarray
    rhat: np.ndarray
    acceptance: float
    drifting: bool
    failures: list
    held_by: int | None = None


@dataclass(frozen=True)
class StoppingRule:
    """When a run has sampled enough (see the module docstring).

    Attributes
    ----------
    ess_target : ESS every parameter needs.
    rhat_max : split-R-hat bound (strict).
    min_tau_lengths : the kept chain must be this many integrated autocorrelation times long.
    drift_z : the kept log-posterior drifts when its trend statistic exceeds this.
    geweke : Geweke's early/late test must pass too (False in rules recorded before it was
        part of the rule, so that a stored run is judged as it was sampled).
    """

    ess_target: float = 1000.0
    rhat_max: float = 1.01
    min_tau_lengths: float = 50.0
    drift_z: float = 3.0
    geweke: bool = True

    def with_overrides(self, **values) -> StoppingRule:
        """A copy with the given thresholds replaced; ``None`` values keep this rule's."""
        given = {k: float(v) for k, v in values.items() if v is not None}
        return replace(self, **given) if given else self

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict | None) -> StoppingRule:
        """The rule of a record; missing thresholds keep the defaults, unknown keys are ignored.
        A record without ``geweke`` predates that criterion: its rule has it off."""
        names = {f.name for f in fields(cls)} - {"geweke"}
        d = d or {}
        return cls(**{k: float(v) for k, v in d.items() if k in names and v is not None},
                   geweke=bool(d.get("geweke", False)))

    def text(self) -> str:
        """The criteria in words, as the report and the command line state them."""
        return (f"ESS ≥ {self.ess_target:g} for every parameter, kept chain ≥ "
                f"{self.min_tau_lengths:g} IACT, split-R̂ < {self.rhat_max:g}, no drift of the "
                f"kept log-posterior (|trend z| ≤ {self.drift_z:g})"
                + (", early and late means agree (Geweke)" if self.geweke else ""))

    def met_text(self) -> str:
        """The plain sentence of a run that met the rule (the loop's stop reason)."""
        return (f"ESS >= {self.ess_target:g} for every parameter, kept chain"
                f" >= {self.min_tau_lengths:g} tau, R-hat < {self.rhat_max}, no drift"
                + (", Geweke passed" if self.geweke else ""))

    def check(self, chain, logp: np.ndarray, accepted: np.ndarray, n_adapt_rows: int,
              burn_in: int | None = None, names: list[str] | None = None,
              full: bool = True, first: int | None = None) -> Check:
        """Apply the rule to stored rows.

        ``chain``: (n_rows, n_chains, n_params) array, or an object whose ``take(idx, cols=None)``
        returns the rows at increasing indices, of the parameters ``cols`` if given (the run
        loop's block list). ``logp``, ``accepted``:
        (n_rows, n_chains). The estimates use the kept chain thinned to at most
        :data:`TAU_ROWS` rows (tau, ESS, drift) and :data:`RHAT_ROWS` rows (split-R-hat; the
        rank normalisation sorts every draw). With ``full=False`` the check stops at the first
        failing criterion in the order ESS / length (cheap), drift, R-hat (the costly one);
        unevaluated R-hats are ``nan``. ``first`` (with ``full=False``): the parameter that held
        the last check (its ``held_by``); its ESS and its R-hat are estimated before the
        others', and a check it fails ends there (the rest ``nan``): a long run's checks then
        cost one parameter's autocorrelation or ranks instead of all of them (Case C: 115).
        Where it passes, every parameter is estimated, so the decision is the full check's.
        """
        take = (lambda idx, col=None: chain[idx] if col is None else chain[:, :, col][idx]) \
            if isinstance(chain, np.ndarray) else chain.take
        if burn_in is None:
            rest = logp[n_adapt_rows:]
            extra = choose_burn_in(rest) if rest.shape[0] >= 20 else 0
            burn_in = n_adapt_rows + extra
        n_kept = logp.shape[0] - burn_in
        row0 = take(np.arange(1))
        m, p = row0.shape[1], row0.shape[2]
        names = names or [f"p{i}" for i in range(p)]
        if n_kept < MIN_KEPT_ROWS:
            return Check(burn_in, np.zeros(p), np.full(p, np.inf), np.full(p, np.inf),
                         float("nan"), False, [f"only {max(n_kept, 0)} kept steps"])
        k = max(1, n_kept // TAU_ROWS)
        steps = np.arange(burn_in, logp.shape[0], k)
        acc = float(np.mean(accepted[burn_in:]))
        rows = np.arange(burn_in, logp.shape[0], max(1, n_kept // RHAT_ROWS))
        quick = not full and first is not None
        if quick:  # the parameter that held the last check: its ESS, then its R-hat
            ess, tau, rhat = np.full(p, np.nan), np.full(p, np.nan), np.full(p, np.nan)
            tau[first] = float(integrated_time(take(steps, [first]), tol=0, quiet=True)[0] * k)
            ess[first] = n_kept * m / tau[first]
            if ess[first] < self.ess_target:
                return Check(burn_in, ess, tau, rhat, acc, False,
                             [f"ESS {ess[first]:.0f} < {self.ess_target:g} ({names[first]})"], first)
            rhat[first] = split_rhat(take(rows, [first]))[0]
            if not rhat[first] < self.rhat_max:
                return Check(burn_in, ess, tau, rhat, acc, False,
                             [f"R-hat {rhat[first]:.3f} >= {self.rhat_max} ({names[first]})"], first)
        tau = integrated_time(take(steps), tol=0, quiet=True) * k
        ess = n_kept * m / tau
        fails, held = [], None
        if not np.all(ess >= self.ess_target):
            held = int(np.argmin(ess))
            fails.append(f"ESS {ess.min():.0f} < {self.ess_target:g} ({names[held]})")
        if not n_kept >= self.min_tau_lengths * np.max(tau):
            fails.append(f"kept chain {n_kept} < {self.min_tau_lengths:g} x tau_max "
                         f"{np.max(tau):.1f}")
        drifting = is_drifting(logp[burn_in:][::k], self.drift_z)
        if drifting:
            fails.append("log-posterior still drifting")
        rhat = np.full(p, np.nan)
        if full or not fails:
            rhat = split_rhat(take(rows))
            if not np.all(rhat < self.rhat_max):
                held = int(np.nanargmax(rhat))
                fails.append(f"R-hat {np.nanmax(rhat):.3f} >= {self.rhat_max} ({names[held]})")
        if self.geweke and (full or not fails):  # the rows geweke_verdict keeps of chain[burn_in:]
            gw = geweke_verdict(take(np.arange(burn_in, logp.shape[0],
                                               max(1, -(-n_kept // GEWEKE_ROWS)))))
            if gw.failed:
                fails.append(f"Geweke: {gw.text()}")
        return Check(burn_in, ess, tau, rhat, acc, drifting, fails, held)


#: the rule of runs stored before the rule was (their ``result.json`` has no ``"rule"``): the
#: run loop's thresholds of then; their ESS target is their case's. Kept as history, so that a
#: change of the defaults above does not re-judge old runs.
LEGACY_RULE = StoppingRule(ess_target=1000.0, rhat_max=1.01, min_tau_lengths=50.0, drift_z=3.0,
                           geweke=False)
