"""A run folder: its files, what is in it, whether it finished, and the rule it was held to.

:class:`RunFolder` is the one place the names of a run's files are written::

    chain.h5      the chain, log-posterior, blobs, acceptance and resume state (storage)
    case.toml     the case as run (overrides applied, data paths absolute)
    config.json   the config record + overrides, and the stopping rule the run is held to
    result.json   the outcome (converged, reason, burn-in, ESS, R-hat, the rule); written last
    summary.csv   the statistics table; summary.md the same in Markdown
    report.html   the report (``pavement-mcmc report``)
    unit.json     a finished batch unit's table row (:mod:`pavement_mcmc.batch.unit`)

A run is *empty* (no chain yet), *unfinished* (a chain and no ``result.json``: running, being
resumed, killed or stopped before its first block ended), *failed* (``result.json`` says so) or *finished*
(converged or stopped by its budget: ``converged`` tells which).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from ..diagnostics.stopping import LEGACY_RULE, StoppingRule
from ..storage import write_atomic

#: the states of a run folder, in the order a run goes through them
STATES = ("empty", "unfinished", "failed", "finished")


def case_rule(sampler_cfg: dict | None, base: StoppingRule | None = None) -> StoppingRule:
    """The stopping rule a case's ``[sampler]`` asks for (its ``ess_target``; the other
    thresholds are ``base``'s, by default :class:`StoppingRule`'s)."""
    return (base or StoppingRule()).with_overrides(
        ess_target=(sampler_cfg or {}).get("ess_target"))


class _File:
    """A file of a run folder: ``folder.<role>`` is its path."""

    def __init__(self, name: str):
        self.name = name

    def __get__(self, folder, owner=None):
        return self if folder is None else folder.path / self.name


@dataclass(frozen=True)
class RunFolder:
    """The run directory ``path`` (see the module docstring for its files)."""

    path: Path

    def __post_init__(self):
        object.__setattr__(self, "path", Path(self.path))

    chain = _File("chain.h5")
    case = _File("case.toml")
    config = _File("config.json")
    result = _File("result.json")
    summary_csv = _File("summary.csv")
    summary_md = _File("summary.md")
    report = _File("report.html")
    unit = _File("unit.json")

    def files(self) -> dict[str, Path]:
        """Every file a run folder may hold, by role (``"chain"``, ``"result"``, ...)."""
        return {k: getattr(self, k) for k, v in vars(type(self)).items() if isinstance(v, _File)}

    def contents(self) -> list[str]:
        """The roles of the files present (``"chain"``, ``"result"``, ...)."""
        return [k for k, f in self.files().items() if f.is_file()]

    def outputs(self) -> list[Path]:
        """The files made from a chain, stale once the chain changes (a new fit removes them)."""
        return [self.result, self.summary_csv, self.summary_md, self.report]

    # ----------------------------------------------------------------- records
    def read_result(self) -> dict | None:
        """``result.json`` as a dict, None while the run is unfinished."""
        if not self.result.is_file():
            return None
        try:
            return json.loads(self.result.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as err:
            from ..data import RunError

            raise RunError(f"{self.result} is damaged ({err.__class__.__name__}: cut short by a "
                           f"full disk?); 'pavement-mcmc resume {self.path}' writes it again "
                           "from the chain") from None

    def write_result(self, rec: dict) -> None:
        write_atomic(self.result, json.dumps(rec, indent=2, default=float))

    def read_config(self) -> dict:
        return json.loads(self.config.read_text())

    def write_config(self, rec: dict) -> None:
        write_atomic(self.config, json.dumps(rec, indent=2))

    # ----------------------------------------------------------------- state
    @property
    def started(self) -> bool:
        """A chain file and the config record exist (a resume has something to continue)."""
        return self.chain.is_file() and self.config.is_file()

    @property
    def state(self) -> str:
        """One of :data:`STATES`."""
        res = self.read_result()
        if res is not None:
            return "failed" if res.get("failed") else "finished"
        return "unfinished" if self.chain.is_file() else "empty"

    @property
    def finished(self) -> bool:
        return self.state == "finished"

    @property
    def failed(self) -> bool:
        return self.state == "failed"

    @property
    def converged(self) -> bool:
        """Finished by its stopping rule."""
        return bool((self.read_result() or {}).get("converged", False))

    def unfinished_reason(self, n_saved: int | None = None) -> str | None:
        """None for a run that finished by its stopping rule, else why it did not."""
        res = self.read_result()
        if res is None:
            stored = f" ({n_saved} steps stored)" if n_saved is not None else ""
            return ("no result.json: the run is still being written or was stopped before it "
                    f"finished{stored}; continue it with 'pavement-mcmc resume'")
        if not res.get("converged"):
            return f"it stopped before meeting its stopping rule ({res.get('reason', '?')})"
        return None

    def rule(self, sampler_cfg: dict | None = None) -> StoppingRule:
        """The stopping rule the run was held to: the one stored with it (``result.json``, else
        ``config.json``). A run stored before the rule was: the thresholds its ``result.json``
        recorded, the ESS target of its case (``sampler_cfg``, else ``config.json``'s), the
        rest as the loop then had them (:data:`~pavement_mcmc.diagnostics.stopping.LEGACY_RULE`).
        """
        res = self.read_result() or {}
        cfg = self.read_config() if self.config.is_file() else {}
        for rec in (res, cfg):
            if isinstance(rec.get("rule"), dict):
                return StoppingRule.from_dict(rec["rule"])
        if sampler_cfg is None:  # the case's [sampler] as run, and a resume's new target
            sampler_cfg = {**(cfg.get("resolved") or {}).get("sampler", {}),
                           **(cfg.get("overrides") or {}).get("sampler", {})}
        rule = case_rule(sampler_cfg, LEGACY_RULE)
        return rule.with_overrides(**{k: res.get(k) for k in ("ess_target", "rhat_max",
                                                               "min_tau_lengths")})
