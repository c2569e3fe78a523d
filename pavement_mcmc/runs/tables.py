"""The statistics table of a run (the paper's Tables 1-2 layout): CSV, Markdown and truths."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from .. import diagnostics as dg
from ..physics import LITERATURE
from ..physics.materials import Finding, check_values, declared_material, paper_values_apply
from ..posterior import Problem
from ..storage import write_atomic
from .folder import RunFolder
from .kept import KeptChain


def truth_values(problem: Problem) -> dict[str, float]:
    """True parameter values of a twin case (kappa, C, and h pieces averaged from
    ``h_true_obs`` with the basis' overlap weights); {} without a truth file."""
    truth = getattr(problem.cfg, "truth", None)
    if not truth:
        return {}
    out = {k: float(truth[k]) for k in ("kappa", "C") if truth.get(k) is not None}
    h_obs = truth.get("h_true_obs")
    basis = problem.model.h_basis
    if h_obs is not None and not problem.model.replaces_h and len(h_obs) == problem.meas.n_obs:
        h_obs = np.asarray(h_obs, float)
        dt = np.diff(problem.meas.t)
        h_int = 0.5 * (h_obs[1:] + h_obs[:-1])
        w = basis.W * dt[:, None]
        pieces = (w.T @ h_int) / w.sum(axis=0)
        out.update({n: float(v) for n, v in zip(basis.names, pieces)})
    return out


def statistics_table(problem: Problem, kept: KeptChain) -> list[dict]:
    """One row per free parameter of the kept chain: unit, literature value, prior mean/sd,
    posterior mean, sd, 2.5 % and 97.5 % quantiles, ESS, split-R-hat and the truth (twin data)."""
    names = kept.param_names
    try:
        summ = dg.summary(kept.get_chain(), names)
    except ValueError:  # too short for Geweke / R-hat: moments and quantiles only
        flat = kept.get_chain(flat=True)
        q = np.percentile(flat, [2.5, 97.5], axis=0) if flat.size else np.full((2, flat.shape[1]), np.nan)
        sd = flat.std(axis=0, ddof=1) if flat.shape[0] > 1 else np.full(flat.shape[1], np.nan)
        summ = {n: {"mean": float(flat[:, i].mean()), "sd": float(sd[i]),
                    "q2.5": float(q[0, i]), "q97.5": float(q[1, i]), "ess": float("nan"),
                    "rhat": float("nan")} for i, n in enumerate(names)}
    truth = truth_values(problem)
    paper = paper_values_apply(problem)
    rows = []
    for name in names:
        p = problem.space[name]
        lit = LITERATURE.get("h" if p.group == "h" else name, float("nan")) if paper else float("nan")
        try:
            pm, ps = float(p.prior.mean), float(p.prior.sd)
        except (NotImplementedError, TypeError):
            pm = ps = float("nan")
        s = summ[name]
        rows.append({
            "parameter": name, "unit": p.unit, "literature": lit, "prior_mean": pm,
            "prior_sd": ps, "mean": s["mean"], "sd": s["sd"], "q2.5": s["q2.5"],
            "q97.5": s["q97.5"], "ess": s["ess"], "rhat": s["rhat"],
            "truth": truth.get(name, float("nan")),
        })
    return rows


def write_table(rows: list[dict], run_dir: Path, findings: list[Finding] | None = None,
                note: str | None = None) -> None:
    """``summary.csv`` and ``summary.md`` in ``run_dir``, each written whole or not at all;
    ``summary.md`` ends with the plausibility ``findings`` and the boundary ``note`` when given
    (:func:`plausibility_text`)."""
    if not rows:
        return
    folder = RunFolder(run_dir)
    keys = list(rows[0])
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=keys)
    w.writeheader()
    w.writerows(rows)
    write_atomic(folder.summary_csv, buf.getvalue())
    tail = "" if findings is None else plausibility_text(findings, note)
    write_atomic(folder.summary_md, format_table(rows) + "\n" + tail)


def format_table(rows: list[dict]) -> str:
    """The statistics table as Markdown (4 significant digits)."""
    keys = list(rows[0])

    def fmt(v):
        if isinstance(v, float):
            return "" if math.isnan(v) else f"{v:.4g}"
        return str(v)

    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(fmt(r[k]) for k in keys) + " |" for r in rows]
    return "\n".join(lines)


def plausibility(problem: Problem, rows: list[dict]) -> list[Finding]:
    """Posterior means outside the plausible ranges (:mod:`pavement_mcmc.physics.materials`):
    alarms outside every ground material, notes outside the declared ``[model] material``."""
    mean = {r["parameter"]: r["mean"] for r in rows}
    fixed = problem.space.value_dict()
    kappa, C = mean.get("kappa", fixed.get("kappa")), mean.get("C", fixed.get("C"))
    h = [v for k, v in mean.items() if problem.space[k].group == "h"]
    declared = declared_material(problem)
    return check_values(kappa, C, h or None, declared)


def plausibility_text(findings: list[Finding], note: str | None = None) -> str:
    """The plausibility section of ``summary.md``: the findings (a line saying none were found
    otherwise) and ``note`` (what the model's boundary implies)."""
    lines = ["", "## Physical plausibility of the posterior means", ""]
    lines += [f"- {f.text()}" for f in findings] or ["- every estimate is inside the plausible "
                                                      "ranges of pavement and ground materials"]
    if note:
        lines += ["", f"Note: {note}."]
    return "\n".join(lines) + "\n"
