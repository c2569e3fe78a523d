"""The report's built-in sections: statistics and diagnostics tables, figures, urban comparison."""

from __future__ import annotations

import html
from collections.abc import Callable

import numpy as np

from ..physics.materials import paper_values_apply
from ..runs.view import RunView
from .markup import _fmt, _img


def _lags(kept: np.ndarray, tau: float, thin: int) -> int:
    """Lags to draw: about 5 IACTs (at least 50 thinned steps), at most a third of the chain."""
    want = max(50, int(5 * tau / thin)) if np.isfinite(tau) else kept.shape[0] // 3
    return int(max(1, min(want, kept.shape[0] // 3)))


def _stats_table(view: RunView) -> str:
    from ..plotting import display

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
    from .. import plotting as pl
    from ..analysis.sensitivity import default_names, reduced_sensitivity
    from ..parameters import parameter_values

    pb, meas, names = view.problem, view.problem.meas, view.names
    subset = pl.default_selection(names)
    truths = view.truths()
    a = view.assessment

    paper_ground = paper_values_apply(pb)

    def fit():
        pr = view.predictive(n_draws)
        return pl.plot_fit(meas, pr.median, band=pr.band(),
                           literature=view.literature() if paper_ground else None,
                           label="posterior predictive median")

    def h_plot():
        return pl.plot_h(meas.t, view.predictive(n_draws).h, wind=meas.wind,
                         truth=view.h_truth())

    def fluxes():
        pr = view.predictive(n_draws)
        h_obs = np.concatenate([pr.h[:, :1], pr.h], axis=1)
        dT = meas.T_air[None, :] - pr.T_surface
        return pl.plot_fluxes(meas.t, h_obs * dT, meas.q_net, dT)

    def streams():
        pr = view.predictive(n_draws)
        return pl.plot_streams(meas.t, [
            (f"{st.quantity} {lab}", st.unit, st.data[:, k], pred[:, :, k])
            for st, pred in pr.others for k, lab in enumerate(st.labels)])

    def sens():
        mean = dict(zip(names, view.flat.mean(axis=0)))
        vals = parameter_values(pb.space, mean)
        s = reduced_sensitivity(pb.model, vals, default_names(pb.space, pb.model), space=pb.space)
        return pl.plot_sensitivity(s, sigma=meas.sigma)

    max_tau = float(np.nanmax([s["tau"] for s in a.table.values()]))
    kept, thin = view.thinned()
    thin_flat = kept.reshape(-1, kept.shape[2])
    figs = [
        ("Measured vs predicted temperatures", fit,
         f"Posterior predictive median and 95 % band from {n_draws} posterior draws solved in "
         "one batch; grey: ± σ" + ("; dashed: the paper's literature values for its pavement"
                                  if paper_ground else "")
         + ". Residuals are predicted minus measured, as in the criticism."),
    ]
    if not pb.model.top_measured:
        figs.append(("Surface heat transfer coefficient h(t)", h_plot,
                     "Posterior mean and 95 % credible band, with the measured wind (right "
                     "axis) and the truth where the case ships it."))
    if pb.posterior.streams[1:]:
        figs.append(("Heat-flux plates and infrared temperature", streams,
                     "The other observations beside the buried sensors, measured against the "
                     f"posterior predictive of {n_draws} draws (a plate's prediction includes "
                     "its calibration factor, the infrared one its offset, weight and lead)."))
    if not pb.model.replaces_h:  # an energy balance or a measured top has its own fluxes
        figs.append(("Surface fluxes", fluxes,
                     "Convective flux h (T_air − T_s) with its band, the measured net radiation, "
                     "and the modelled T_air − T_s."))
    figs += [
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
    from ..analysis.urban import compare
    from ..plotting import plot_urban

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
