r"""A stored run's view, its convergence assessment, and its one-file HTML report.

:func:`load_view` opens a run directory (``runs/NAME/chain.h5``; works while the run is still
being written) and rebuilds its :class:`~pavement_mcmc.problem.Problem`; :class:`RunView` adds
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
:class:`~pavement_mcmc.storage.RunData`, ``view.burn_in``, ``view.kept``, ``view.flat``,
``view.names``, ``view.draws(n)``, ``view.predictive()``, ``view.assessment``). The fragment is
inserted as is (escape your own text with :func:`html.escape`); the figures follow it, embedded
as PNG. Sections are placed after the built-in figures, ordered by ``order`` then by
registration. A section that raises is shown as an error box; the rest of the report is still
written. The report sits downstream of everything it shows: the built-in residual-diagnosis
section of :mod:`pavement_mcmc.criticism` is registered here, never the other way round.
"""

from __future__ import annotations

import base64
import html
import io
import json
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from . import __version__
from . import diagnostics as dg

__all__ = [
    "Assessment",
    "Predictive",
    "RunView",
    "assess",
    "build_report",
    "load_view",
    "register_section",
    "registered_sections",
    "unregister_section",
]

#: thresholds of the per-parameter checks
ESS_MIN = 100.0
RHAT_MAX = 1.1
TAU_FACTOR = 50.0  # the chain must be >= 50 IACT long (emcee's rule)
GEWEKE_Z = 1.96


# ------------------------------------------------------------------------------ run view


@dataclass(frozen=True)
class Predictive:
    """Posterior predictive of ``n`` draws, solved in one batch.

    Attributes
    ----------
    theta : (n, n_free) the draws.
    pred : (n, n_obs, n_sensors) predicted sensor temperatures, degC.
    T_surface : (n, n_obs) modelled surface temperature, degC.
    h : (n, n_obs - 1) h on each observation interval, W m-2 K-1.
    """

    theta: np.ndarray
    pred: np.ndarray
    T_surface: np.ndarray
    h: np.ndarray

    @property
    def median(self) -> np.ndarray:
        return np.median(self.pred, axis=0)

    def band(self, level: float = 95.0) -> tuple[np.ndarray, np.ndarray]:
        q = [50 - level / 2, 50 + level / 2]
        lo, hi = np.percentile(self.pred, q, axis=0)
        return lo, hi


def predictive(problem, theta: np.ndarray) -> Predictive:
    """Solve the model once for every row of ``theta`` (n, n_free)."""
    theta = np.atleast_2d(theta)
    p = problem.space.expand(theta)
    model = problem.model
    nodes = model.solve(p)
    h = model.coefficients(p).h
    return Predictive(theta, model.observe(nodes, p), nodes[..., 0], np.asarray(h))


@dataclass
class RunView:
    """A stored run with its problem, burn-in and derived quantities (computed lazily).

    Attributes
    ----------
    path : the run directory.
    problem : the rebuilt :class:`~pavement_mcmc.problem.Problem`.
    run : the stored :class:`~pavement_mcmc.storage.RunData` (committed steps).
    burn_in : steps discarded.
    burn_in_source : where ``burn_in`` came from (stored, config, or chosen here by MSER).
    seed : seed of the draws used for figures and the predictive.
    """

    path: Path
    problem: object
    run: object
    burn_in: int
    burn_in_source: str = "chosen by MSER on the log-posterior trace"
    seed: int = 0
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def names(self) -> list[str]:
        return list(self.run.param_names)

    @property
    def kept(self) -> np.ndarray:
        """(n_kept, n_chains, n_params) chain after burn-in."""
        return self.run.chain[self.burn_in :]

    @property
    def flat(self) -> np.ndarray:
        """(n_kept * n_chains, n_params) draws after burn-in."""
        return self.kept.reshape(-1, self.kept.shape[2])

    def thinned(self, max_steps: int = 2000) -> tuple[np.ndarray, int]:
        """The kept chain thinned to at most ``max_steps`` steps, and the thinning factor.

        Figures of long runs (Case C keeps ~75 000 steps x 32 chains x 115 parameters) use it:
        autocovariance norms and segment statistics of the full chain would take minutes.
        """
        thin = max(1, -(-self.kept.shape[0] // max_steps))
        return self.kept[::thin], thin

    def draws(self, n: int = 100) -> np.ndarray:
        """``n`` draws from the kept chain, evenly spaced in steps, walkers at random (seeded)."""
        k = self.kept
        if k.shape[0] == 0:
            raise ValueError(f"{self.path}: no steps left after a burn-in of {self.burn_in}")
        rng = np.random.default_rng(self.seed)
        steps = np.linspace(0, k.shape[0] - 1, n).round().astype(int)
        walkers = rng.integers(0, k.shape[1], n)
        return k[steps, walkers]

    def predictive(self, n: int = 100) -> Predictive:
        """Posterior predictive of ``n`` draws (cached)."""
        key = ("pred", n)
        if key not in self._cache:
            self._cache[key] = predictive(self.problem, self.draws(n))
        return self._cache[key]

    def literature(self) -> np.ndarray:
        """Prediction at the literature values (kappa 2.27, C 2.10e6, h 10), (n_obs, n_sensors)."""
        from .physics import LITERATURE
        from .sensitivity import parameter_values

        space = self.problem.space
        over = {k: v for k, v in LITERATURE.items() if k in space}
        if any(p.group == "h" for p in space.params.values()):
            over["h"] = LITERATURE["h"]
        vals = parameter_values(space, over)
        return self.problem.model.predict({k: np.array([v]) for k, v in vals.items()})[0]

    def truths(self) -> dict[str, float]:
        """True parameter values where the case ships them (h pieces: interval-weighted)."""
        from .runner import truth_values

        return {k: v for k, v in truth_values(self.problem).items() if k in self.names}

    def h_truth(self) -> np.ndarray | None:
        truth = getattr(self.problem.cfg, "truth", None) or {}
        h = truth.get("h_true_obs")
        return None if h is None or len(h) != self.problem.meas.n_obs else np.asarray(h, float)

    @cached_property
    def assessment(self) -> Assessment:
        return assess(self.run, self.burn_in)


def _run_file(path: Path) -> Path:
    if path.is_dir():
        f = path / "chain.h5"
        if not f.exists():
            raise FileNotFoundError(f"{path}: no chain.h5 in this run directory")
        return f
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such run directory or file")
    return path


def _stored_burn_in(run, problem) -> tuple[int | None, str]:
    """The runner's burn-in (result.json) of a finished run, else the config's, else None."""
    result = run.meta.get("result") or {}
    if isinstance(result.get("burn_in"), int | float):
        return int(result["burn_in"]), "chosen by the sampler loop (result.json)"
    b = problem.cfg.sampler.get("burn_in") if hasattr(problem.cfg, "sampler") else None
    return (int(b), "from the case config") if b is not None else (None, "")


def load_view(path: str | Path, burn_in: int | None = None, seed: int = 0) -> RunView:
    """Open a stored run (a directory with ``chain.h5``, or the file) and rebuild its problem.

    Parameters
    ----------
    path : run directory or HDF5 file. Safe while another process writes it.
    burn_in : steps to discard; default: the sampler loop's choice for a finished run
        (result.json), else the config's ``sampler.burn_in``, else (a run still being written)
        chosen by MSER (:func:`~pavement_mcmc.diagnostics.choose_burn_in`).
    seed : seed of the posterior draws used by figures.
    """
    path = Path(path)
    f = _run_file(path)
    run_dir = f.parent
    from .runner import load_run

    problem, run = load_run(run_dir)
    if list(problem.space.free) != list(run.param_names):
        raise ValueError(f"{f}: stored parameters {run.param_names} differ from the rebuilt "
                         f"problem's {problem.space.free}")
    if run.n_saved < 1:
        raise ValueError(f"{f}: the run has no committed steps yet")
    src = "given"
    if burn_in is None:
        burn_in, src = _stored_burn_in(run, problem)
    if burn_in is None:
        try:
            burn_in = dg.choose_burn_in(run.log_prob)
            src = "chosen by MSER on the log-posterior trace"
        except ValueError:
            burn_in, src = run.n_saved // 2, "half the chain (too short for MSER)"
    burn_in = int(min(max(burn_in, 0), run.n_saved - 1))
    return RunView(run_dir, problem, run, burn_in, src, seed)


# ---------------------------------------------------------------------------- assessment


@dataclass
class Assessment:
    """Per-parameter diagnostics and the run-level verdict.

    Attributes
    ----------
    table : ``{name: {mean, sd, q2.5, q50, q97.5, tau, ess, rhat, geweke_rel, geweke_z,
        passed}}``.
    acceptance : overall acceptance after burn-in.
    acceptance_walkers : (n_chains,) per walker.
    burn_in, n_steps, n_kept, n_chains : chain lengths.
    drifting : does the kept log-posterior still trend (|z| > 3)?
    trend_z : the trend statistic.
    trusted : the verdict.
    reasons : why not (empty when trusted).
    warnings : concerns that do not by themselves fail the run.
    """

    table: dict[str, dict[str, float]]
    acceptance: float
    acceptance_walkers: np.ndarray
    burn_in: int
    n_steps: int
    n_kept: int
    n_chains: int
    drifting: bool
    trend_z: float
    trusted: bool
    reasons: list[str]
    warnings: list[str]

    def to_dict(self) -> dict:
        d = {k: v for k, v in self.__dict__.items() if k != "acceptance_walkers"}
        d["acceptance_walkers"] = self.acceptance_walkers.tolist()
        return d

    def verdict_text(self) -> str:
        if self.trusted:
            return ("The run can be trusted: every parameter passes (IACT, ESS, split-R-hat, "
                    "Geweke) and the kept log-posterior does not drift.")
        return "The run can NOT be trusted yet: " + " ".join(self.reasons)


def assess(run, burn_in: int) -> Assessment:
    """Convergence diagnostics of a stored run after ``burn_in`` steps.

    A parameter passes if the kept chain is at least 50 integrated autocorrelation times long,
    its ESS is at least 100, split-R-hat < 1.1 and Geweke's |z| < 1.96. The run is trusted if
    at most 10 % of the parameters fail Geweke alone (5 % fail by chance), none fails the other
    checks, no |z| exceeds 3.5, no walker is stuck and the kept log-posterior does not drift.

    emcee's walkers are not independent chains: ESS and split-R-hat across walkers are
    optimistic approximations; the IACT criterion is the primary one.
    """
    chain = run.chain
    n, m, p = chain.shape
    kept = chain[burn_in:]
    names = list(run.param_names)
    nk = kept.shape[0]
    reasons: list[str] = []
    warns: list[str] = []
    if nk < 8:
        raise ValueError(f"only {nk} steps after a burn-in of {burn_in}: too short to diagnose")
    summ = dg.summary(kept, names)
    table = {}
    n_fail_other, n_fail_gew, big_z = [], [], []
    for name in names:
        s = dict(summ[name])
        ok_tau = np.isfinite(s["tau"]) and nk >= TAU_FACTOR * s["tau"]
        ok_ess = s["ess"] >= ESS_MIN
        ok_rhat = np.isfinite(s["rhat"]) and s["rhat"] < RHAT_MAX
        ok_gew = np.isfinite(s["geweke_z"]) and abs(s["geweke_z"]) < GEWEKE_Z
        s.update(tau_ok=bool(ok_tau), ess_ok=bool(ok_ess), rhat_ok=bool(ok_rhat),
                 geweke_ok=bool(ok_gew), passed=bool(ok_tau and ok_ess and ok_rhat and ok_gew))
        table[name] = s
        if not (ok_tau and ok_ess and ok_rhat):
            n_fail_other.append(name)
        if not ok_gew:
            n_fail_gew.append(name)
            if not np.isfinite(s["geweke_z"]) or abs(s["geweke_z"]) > 3.5:
                big_z.append(name)
    acc = np.asarray(run.accepted[burn_in:], float)
    acc_w = acc.mean(axis=0)
    acceptance = float(acc.mean())
    lp = run.log_prob[burn_in:]
    tz = float(dg.trend_z(lp))
    drifting = bool(abs(tz) > 3.0)
    taus = np.array([table[k]["tau"] for k in names])
    short = [k for k in names if not table[k]["tau_ok"]]
    if short:
        reasons.append(f"the kept chain ({nk} steps) is shorter than {TAU_FACTOR:g} IACT for "
                       f"{_list(short)} (max IACT {np.nanmax(taus):.1f} steps): run longer.")
    low_ess = [k for k in names if not table[k]["ess_ok"]]
    if low_ess:
        reasons.append(f"ESS below {ESS_MIN:g} for {_list(low_ess)}.")
    bad_rhat = [k for k in names if not table[k]["rhat_ok"]]
    if bad_rhat:
        reasons.append(f"split-R-hat ≥ {RHAT_MAX} for {_list(bad_rhat)} (walkers disagree).")
    if big_z or len(n_fail_gew) > max(1, 0.1 * p):
        reasons.append(f"Geweke: early and late means differ for {_list(n_fail_gew)} "
                       f"({len(n_fail_gew)} of {p}; about {0.05 * p:.1f} expected by chance).")
    elif n_fail_gew:
        warns.append(f"Geweke |z| ≥ 1.96 for {_list(n_fail_gew)}: no more than chance "
                     f"({0.05 * p:.1f} of {p} expected).")
    if drifting:
        reasons.append(f"the kept log-posterior still drifts (trend z = {tz:.1f}): burn-in is "
                       "not over or the chain is still moving.")
    stuck = int(np.sum(acc_w == 0))
    if stuck:
        reasons.append(f"{stuck} of {m} walkers accepted nothing after burn-in (stuck).")
    if not 0.1 <= acceptance <= 0.9:
        warns.append(f"acceptance {acceptance:.2f} is outside 0.1–0.9: the proposal scale is "
                     "poorly tuned and mixing will be slow.")
    if burn_in > 0.5 * n:
        warns.append(f"burn-in ({burn_in} steps) is more than half the chain.")
    return Assessment(table, acceptance, acc_w, int(burn_in), n, nk, m, drifting, tz,
                      not reasons, reasons, warns)


def chains_note(sampler: str) -> str:
    """What ESS and split-R-hat across chains mean for this sampler."""
    if "emcee" in str(sampler):
        return ("emcee walkers are not independent chains (each move uses the other walkers), "
                "so ESS and split-R-hat across walkers are optimistic; the IACT check (chain "
                ">= 50 IACT) is the primary one.")
    return (f"the {sampler or 'sampler'}'s chains are independent Markov chains, so split-R-hat "
            "across them compares independent runs; the IACT check (chain >= 50 IACT) still "
            "applies to each.")


def _list(names: list[str], k: int = 6) -> str:
    return ", ".join(names[:k]) + (f" and {len(names) - k} more" if len(names) > k else "")


# ----------------------------------------------------------------------- section registry

SectionBuilder = Callable[[object, RunView], "tuple[str, list] | None"]
_SECTIONS: list[tuple[float, int, str, SectionBuilder]] = []


def register_section(title: str, func: SectionBuilder | None = None, *, order: float = 100.0):
    """Add a report section ``func(problem, view) -> (html_fragment, [figures]) | None``.

    Usable as ``register_section("Title", func)`` or as a decorator
    ``@register_section("Title")``. Registering the same title again replaces the section.
    See the module docstring for the contract.
    """

    def add(f: SectionBuilder) -> SectionBuilder:
        unregister_section(title)
        _SECTIONS.append((float(order), len(_SECTIONS), title, f))
        return f

    return add if func is None else add(func)


def unregister_section(title: str) -> None:
    """Remove the section ``title`` if registered."""
    _SECTIONS[:] = [s for s in _SECTIONS if s[2] != title]


def registered_sections() -> list[tuple[str, SectionBuilder]]:
    """``(title, builder)`` of the registered sections, in report order."""
    return [(t, f) for _, _, t, f in sorted(_SECTIONS, key=lambda s: (s[0], s[1]))]


def _register_builtin_sections() -> None:
    from .criticism.report_section import TITLE, criticism_section

    register_section(TITLE, criticism_section, order=50)


_register_builtin_sections()

# ---------------------------------------------------------------------------- the report


def _lags(kept: np.ndarray, tau: float, thin: int) -> int:
    """Lags to draw: about 5 IACTs (at least 50 thinned steps), at most a third of the chain."""
    want = max(50, int(5 * tau / thin)) if np.isfinite(tau) else kept.shape[0] // 3
    return int(max(1, min(want, kept.shape[0] // 3)))


def build_report(view: RunView, out: str | Path | None = None, dpi: int = 80,
                 n_draws: int = 100) -> Path:
    """Write the run's self-contained HTML report; return its path (default
    ``<run>/report.html``)."""
    out = Path(out) if out else view.path / "report.html"
    doc = render(view, registered_sections(), dpi=dpi, n_draws=n_draws)
    out.write_text(doc, encoding="utf-8")
    return out


def figure_to_base64(fig, dpi: int = 80) -> str:
    """PNG of a figure as base64 text."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def section_error(title: str, exc: BaseException) -> str:
    tb = "".join(traceback.format_exception_only(type(exc), exc)).strip()
    return (f'<div class="err">Section “{html.escape(title)}” failed: '
            f"<code>{html.escape(tb)}</code></div>")


# ------------------------------------------------------------------------ HTML rendering

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;max-width:1180px;
margin:1.5em auto;padding:0 1em;color:#222;line-height:1.4}
h1{font-size:1.6em;margin-bottom:.2em}h2{border-bottom:2px solid #ddd;padding-bottom:.2em;
margin-top:1.6em}h3{margin-bottom:.3em}
table{border-collapse:collapse;font-size:.88em;margin:.5em 0}
th,td{border:1px solid #ccc;padding:3px 7px;text-align:right}th{background:#f2f2f2}
td.l,th.l{text-align:left}tr.fail td{background:#fde8e8}
.verdict{padding:.7em 1em;border-radius:6px;font-weight:600;margin:.6em 0}
.ok{background:#e5f5e5;border:1px solid #7c7}.bad{background:#fde8e8;border:1px solid #d77}
.warn{background:#fff6dd;border:1px solid #db5;padding:.4em .8em;border-radius:6px;margin:.3em 0}
.err{background:#fde8e8;border:1px solid #d77;padding:.5em;border-radius:6px}
img{max-width:100%;height:auto;display:block;margin:.5em 0;border:1px solid #eee}
.cap{font-size:.88em;color:#555;margin-top:-.2em}pre{background:#f7f7f7;padding:.6em;
overflow:auto;font-size:.8em;max-height:40em}nav a{margin-right:.8em}code{font-size:.9em}
"""


def _img(fig, dpi: int, alt: str) -> str:
    return (f'<img alt="{html.escape(alt)}" src="data:image/png;base64,'
            f'{figure_to_base64(fig, dpi)}">')


def _fmt(x: float, digits: int = 4) -> str:
    return "–" if x is None or not np.isfinite(x) else f"{x:.{digits}g}"


def _stats_table(view: RunView) -> str:
    from .plotting import display

    a = view.assessment
    truths = view.truths()
    space = view.problem.space
    rows = []
    for name, s in a.table.items():
        f, label = display(name, space[name].unit)
        prior = space[name].prior
        try:
            pm, psd = float(prior.mean), float(prior.sd)
        except (NotImplementedError, AttributeError, TypeError):
            pm = psd = float("nan")
        pr = "–" if not np.isfinite(pm) else f"{_fmt(pm * f)} ± {_fmt(psd * f, 3)}"
        rows.append(
            f"<tr><td class=l>{html.escape(label)}</td><td>{_fmt(s['mean'] * f)}</td>"
            f"<td>{_fmt(s['sd'] * f, 3)}</td><td>{_fmt(s['q2.5'] * f)}</td>"
            f"<td>{_fmt(s['q50'] * f)}</td><td>{_fmt(s['q97.5'] * f)}</td>"
            f"<td>{pr}</td><td>{_fmt(truths.get(name, np.nan) * f)}</td></tr>")
    return ("<table><tr><th class=l>parameter</th><th>mean</th><th>sd</th><th>2.5 %</th>"
            "<th>median</th><th>97.5 %</th><th>prior mean ± sd</th><th>truth</th></tr>"
            + "".join(rows) + "</table>")


def _diag_table(view: RunView) -> str:
    rows = []
    for name, s in view.assessment.table.items():
        cls = "" if s["passed"] else " class=fail"
        rows.append(
            f"<tr{cls}><td class=l>{html.escape(name)}</td><td>{s['tau']:.1f}</td>"
            f"<td>{s['ess']:.0f}</td><td>{s['mcse']:.3g}</td><td>{s['rhat']:.3f}</td>"
            f"<td>{100 * s['geweke_rel']:.3f} %</td><td>{s['geweke_z']:.2f}</td>"
            f"<td class=l>{'pass' if s['passed'] else 'FAIL'}</td></tr>")
    return ("<table><tr><th class=l>parameter</th><th>IACT (steps)</th><th>ESS</th>"
            "<th>MCSE</th><th>split-R̂</th><th>Geweke rel. diff.</th><th>Geweke z</th>"
            "<th class=l>check</th></tr>" + "".join(rows) + "</table>")


def _figures(view: RunView, n_draws: int) -> list[tuple[str, Callable, str]]:
    """(title, builder -> Figure, caption) of the built-in figures."""
    from . import plotting as pl
    from .sensitivity import default_names, parameter_values, reduced_sensitivity

    pb, meas, names = view.problem, view.problem.meas, view.names
    subset = pl.default_selection(names)
    truths = view.truths()
    a = view.assessment

    def fit():
        pr = view.predictive(n_draws)
        return pl.plot_fit(meas, pr.median, band=pr.band(), literature=view.literature(),
                           label="posterior predictive median")

    def h_plot():
        return pl.plot_h(meas.t, view.predictive(n_draws).h, wind=meas.wind,
                         truth=view.h_truth())

    def fluxes():
        pr = view.predictive(n_draws)
        h_obs = np.concatenate([pr.h[:, :1], pr.h], axis=1)
        dT = meas.T_air[None, :] - pr.T_surface
        return pl.plot_fluxes(meas.t, h_obs * dT, meas.q_net, dT)

    def sens():
        mean = dict(zip(names, view.flat.mean(axis=0)))
        vals = parameter_values(pb.space, mean)
        s = reduced_sensitivity(pb.model, vals, default_names(pb.space), space=pb.space)
        return pl.plot_sensitivity(s, sigma=meas.sigma)

    max_tau = float(np.nanmax([s["tau"] for s in a.table.values()]))
    kept, thin = view.thinned()
    thin_flat = kept.reshape(-1, kept.shape[2])
    figs = [
        ("Measured vs predicted temperatures", fit,
         f"Posterior predictive median and 95 % band from {n_draws} posterior draws solved in "
         "one batch; grey: ± σ; dashed: the literature values. Residuals are measured minus "
         "predicted."),
        ("Surface heat transfer coefficient h(t)", h_plot,
         "Posterior mean and 95 % credible band, with the measured wind (right axis) and the "
         "truth where the case ships it."),
        ("Surface fluxes", fluxes,
         "Convective flux h (T_air − T_s) with its band, the measured net radiation, and the "
         "modelled T_air − T_s."),
        ("Corner plot", lambda: pl.plot_corner(thin_flat, names, subset, truths),
         "Posterior after burn-in (dashed lines: 2.5, 50, 97.5 %); red: truth."),
        ("Markov chains", lambda: pl.plot_chains(view.run.chain[::thin], names,
                                                 view.burn_in // thin, subset, truths),
         "Walker traces (grey), their mean (blue), burn-in (red dashed); histograms after "
         "burn-in."),
        ("Log-posterior trace", lambda: pl.plot_logp(view.run.log_prob, view.burn_in), ""),
        ("Acceptance", lambda: pl.plot_acceptance(view.run.accepted, view.burn_in), ""),
        ("Autocovariance norm", lambda: pl.plot_autocovariance(kept, tau=max_tau, thin=thin,
                                                               max_lag=_lags(kept, max_tau, thin)),
         "Norm of the lag-k autocovariance matrix of the standardised kept chain."),
        ("Geweke", lambda: pl.plot_geweke(kept, names, subset), ""),
        ("Early vs late segments", lambda: pl.plot_segments(kept, names, subset), ""),
        ("Sensitivity coefficients at the posterior mean", sens,
         "Reduced sensitivity coefficients p ∂T/∂p by central differences (Δp = 10⁻² p)."),
    ]
    return figs


def _urban_section(view: RunView, dpi: int, n_draws: int) -> str:
    from .plotting import plot_urban
    from .urban import compare

    if view.problem.meas.wind is None:
        return "<p>No wind column in the data: the urban comparison needs one.</p>"
    pb = view.problem
    mean = pb.space.expand(view.flat.mean(axis=0)[None, :])
    c = compare(pb.model, {k: v[0] for k, v in mean.items()},
                draws=pb.space.expand(view.draws(min(n_draws, 50))))
    s = c.summary()
    return (f"<p>The same ground driven with the standard correlation h = 4 + 4 v (site wind) "
            f"instead of the estimated h(t): max |ΔT_s| = <b>{s['max_abs_dTs']:.2f} °C</b> "
            f"(at {s['time_of_max_dTs_h']:.1f} h), max |Δ(ε σ T_s⁴)| = "
            f"<b>{s['max_abs_dq_lw']:.1f} W m⁻²</b> (ε = {s['emissivity']:g}); mean h "
            f"{s['mean_h_standard']:.1f} (standard) vs {s['mean_h_estimated']:.1f} W m⁻² K⁻¹ "
            "(estimated). Paper: more than 2 °C and about 15 W m⁻².</p>"
            + _img(plot_urban(c), dpi, "urban comparison"))


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
    section("Convergence verdict", verdict)
    section("Posterior statistics", _stats_table(view))
    section("Diagnostics", _diag_table(view) + (
        "<p class=cap>A parameter passes if the kept chain is ≥ 50 IACT long, ESS ≥ 100, "
        "split-R̂ < 1.1 and |Geweke z| < 1.96 (first 10 % vs last 50 %; the relative difference "
        f"is the paper's). Note: {esc(chains_note(run.meta.get('sampler', '')))}</p>"))
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
            ("run file", str(view.path / "chain.h5"))]
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
