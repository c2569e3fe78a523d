"""The report's section on where the model fails: the criticism's residual report as HTML."""

from __future__ import annotations

import html

from ..criticism.residuals import analyse_point, plain_signals

TITLE = "Where the model fails (residual diagnosis)"


def criticism_section(problem, view):
    """Residual map and correlations at the posterior mean, with the patterns in words."""
    from ..plotting.criticism import plot_residual_correlations, plot_residual_map

    mean = view.flat.mean(axis=0)
    values = problem.space.value_dict()
    values.update({n: float(v) for n, v in zip(view.names, mean, strict=True)})
    rep = analyse_point(problem, values)
    pats = plain_signals(rep)
    rows = "".join(
        f"<tr><td>{html.escape(s.label)}</td><td>{s.rmse:.3f}</td><td>{s.bias:+.3f}</td>"
        f"<td>{s.lag1:.2f}</td><td>{s.ljung_box_p:.1e}</td><td>{s.amp_ratio:.3f}</td>"
        f"<td>{s.phase_error_h:+.2f}</td></tr>"
        for s in rep.sensors
    )
    items = "".join(f"<li>{html.escape(v)}</li>" for v in pats.values()) or "<li>none</li>"
    frag = (
        f"<p>At the posterior mean: RMSE {rep.rmse:.3f} °C = {rep.rmse_sigma:.2f} σ, pooled "
        f"lag-1 autocorrelation {rep.rho:.2f}. Run <code>pavement-mcmc diagnose "
        f"{html.escape(str(view.path))}</code> for the ranking of missing effects.</p>"
        "<table><tr><th>sensor</th><th>RMSE</th><th>mean</th><th>lag-1</th><th>Ljung–Box p</th>"
        "<th>24 h amplitude ratio</th><th>phase error (h)</th></tr>" + rows + "</table>"
        f"<p>Residual patterns:</p><ul>{items}</ul>"
    )
    return frag, [plot_residual_map(rep), plot_residual_correlations(rep)]

