r"""A stored run's view, its convergence assessment, and its one-file HTML report.

:func:`load_view` opens a run directory (``runs/NAME/chain.h5``; works while the run is still
being written) and rebuilds its :class:`~pavement_mcmc.posterior.Problem`; :class:`RunView` adds
the burn-in, the kept chain, posterior draws and a cached posterior predictive.
:func:`assess` turns the diagnostics into per-parameter pass/fail and a run-level verdict.
:func:`build_report` writes ONE self-contained HTML file (figures as base64 PNG).

Extension point: report sections
--------------------------------
Other modules add sections with :func:`register_section`::

    from pavement_mcmc import report

    def residual_section(problem, view):
        '''Return (html_fragment, [matplotlib Figure, ...]) or None to skip the section.'''
        figs = [my_residual_figure(view.predictive().median, problem.meas)]
        return "<p>Residuals are autocorrelated at lag 1 ...</p>", figs

    report.register_section("Residual diagnosis", residual_section, order=50)

``problem`` is the run's Problem and ``view`` a :class:`RunView` (``view.run`` the
:class:`~pavement_mcmc.storage.RunData`, ``view.burn_in``, the kept chain
``view.get_chain(thin=, flat=)`` and its shorthands ``view.kept``, ``view.flat``,
``view.names``, ``view.draws(n)``, ``view.predictive()``, ``view.assessment``). The fragment is
inserted as is (escape your own text with :func:`html.escape`); the figures follow it, embedded
as PNG. Sections are placed after the built-in figures, ordered by ``order`` then by
registration. A section that raises is shown as an error box; the rest of the report is still
written. The report sits downstream of everything it shows: the built-in residual-diagnosis
section of :mod:`pavement_mcmc.criticism` is registered here, never the other way round.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

from .. import __version__
from ..diagnostics.assessment import chains_note
from ..diagnostics.stopping import StoppingRule
from ..runs.tables import plausibility
from ..runs.view import RunView
from ..storage import write_atomic
from .builtin import _diag_table, _figures, _stats_table, _urban_section
from .markup import _CSS, _img, figure_to_base64, section_error  # noqa: F401  (figure_to_base64)
from .sections import SectionBuilder, register_section, registered_sections, unregister_section

__all__ = [
    "build_report",
    "register_section",
    "registered_sections",
    "unregister_section",
]


def _plausibility_box(view: RunView) -> str:
    """The posterior means against the plausible ranges of ground materials (alarms red)."""
    rows = [{"parameter": k, "mean": s["mean"]} for k, s in view.assessment.table.items()]
    found = plausibility(view.problem, rows)
    if not found:
        return ("<p>Physical plausibility: every posterior mean is inside the ranges of pavement "
                "and ground materials.</p>")
    return "".join(f'<div class="{"verdict bad" if f.level == "alarm" else "warn"}">'
                   f"{html.escape(f.text())}</div>" for f in found)


def _diag_caption(rule: StoppingRule, sampler: str) -> str:
    """The diagnostics table's caption: the run's own stopping rule, and Geweke's check."""
    return ("<p class=cap>" + html.escape(
        f"A parameter passes if the kept chain is ≥ {rule.min_tau_lengths:g} IACT long, ESS ≥ "
        f"{rule.ess_target:g} and split-R̂ < {rule.rhat_max:g} (the stopping rule this run was "
        "held to) and |Geweke z| < 1.96 (first 10 % vs last 50 %; the relative difference is the "
        f"paper's). Note: {chains_note(sampler, rule)}") + "</p>")


def build_report(view: RunView, out: str | Path | None = None, dpi: int = 80,
                 n_draws: int = 100) -> Path:
    """Write the run's self-contained HTML report; return its path (default
    ``<run>/report.html``)."""
    out = Path(out) if out else view.folder.report
    doc = render(view, registered_sections(), dpi=dpi, n_draws=n_draws)
    write_atomic(out, doc)
    return out


def render(view: RunView, sections: list[tuple[str, SectionBuilder]], dpi: int = 80,
           n_draws: int = 100) -> str:
    """The report as one HTML string (see :func:`build_report`)."""
    pb, run, a = view.problem, view.run, view.assessment
    cfg = pb.cfg
    esc = html.escape
    body: list[str] = []
    toc: list[str] = []

    def section(title: str, content: str) -> None:
        anchor = f"s{len(toc)}"
        toc.append(f'<a href="#{anchor}">{esc(title)}</a>')
        body.append(f'<h2 id="{anchor}">{esc(title)}</h2>\n{content}')

    verdict = (f'<div class="verdict {"ok" if a.trusted else "bad"}">{esc(a.verdict_text())}'
               "</div>" + "".join(f'<div class="warn">{esc(w)}</div>' for w in a.warnings))
    verdict += (f"<p>Burn-in {a.burn_in} steps ({esc(view.burn_in_source)}); kept {a.n_kept} "
                f"of {a.n_steps} steps × {a.n_chains} walkers; acceptance after burn-in "
                f"{a.acceptance:.3f}; drift of the kept log-posterior: trend z = "
                f"{a.trend_z:.2f} ({'drifting' if a.drifting else 'no significant drift'}).</p>")
    section("Convergence verdict", verdict + _plausibility_box(view))
    section("Posterior statistics", _stats_table(view))
    section("Diagnostics", _diag_table(view) + _diag_caption(a.rule, run.meta.get("sampler", "")))
    for title, build, caption in _figures(view, n_draws):
        try:
            content = _img(build(), dpi, title)
            if caption:
                content += f"<p class=cap>{esc(caption)}</p>"
        except Exception as exc:  # a figure must not take the whole report down
            content = section_error(title, exc)
        section(title, content)
    try:
        section("Urban-scale comparison", _urban_section(view, dpi, n_draws))
    except Exception as exc:
        section("Urban-scale comparison", section_error("Urban-scale comparison", exc))
    for title, func in sections:
        try:
            res = func(pb, view)
            if res is None:
                continue
            frag, figs = res
            content = frag + "".join(_img(f, dpi, title) for f in figs or [])
        except Exception as exc:  # documented: a failing plug-in section becomes an error box
            content = section_error(title, exc)
        section(title, content)
    meta = run.meta
    prov = [("case", cfg.name), ("description", cfg.description), ("case file", str(cfg.path)),
            ("data file", str(getattr(cfg, "csv_path", ""))),
            ("data hash (sha256)", pb.meas.data_hash()),
            ("stored data hash", meta.get("data_hash", "")), ("sampler", meta.get("sampler", "")),
            ("run created", meta.get("created", "")), ("run written by", meta.get("version", "")),
            ("report by pavement_mcmc", __version__), ("model", pb.model.describe()),
            ("run file", str(view.folder.chain))]
    table = "".join(f"<tr><th class=l>{esc(k)}</th><td class=l>{esc(str(v))}</td></tr>"
                    for k, v in prov)
    section("Provenance", f"<table>{table}</table>")
    section("Case configuration", f"<pre>{esc(json.dumps(cfg.raw, indent=2))}</pre>")
    status = ("" if a.n_steps else "") + f"{a.n_steps} steps stored"
    head = (f"<!DOCTYPE html><html lang=en><head><meta charset=utf-8><title>pavement_mcmc "
            f"report: {esc(cfg.name)}</title><style>{_CSS}</style></head><body>"
            f"<h1>Run report: {esc(cfg.name)}</h1><p>{esc(cfg.description)} — {status}, "
            f"{a.n_chains} walkers; data hash <code>{esc(pb.meas.data_hash()[:16])}…</code>; "
            f"pavement_mcmc {esc(__version__)}.</p><nav>{''.join(toc)}</nav>")
    return head + "\n".join(body) + "</body></html>\n"
