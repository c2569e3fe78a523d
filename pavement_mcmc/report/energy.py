"""The report's section on the surface energy balance (runs whose model has ``energy_balance``):
H, LE and G through the day with their bands beside the net radiation, and the midday Bowen
ratio, G/Rn and LE/Rn; a flux tower's H and LE beside them when the record has them."""

from __future__ import annotations

import html

from ..criticism.tower import tower_check, tower_fluxes
from ..physics.catalogue.energy import MIDDAY_NAMES, EnergyBalance, energy_partition

TITLE = "Surface energy balance (H, LE, G)"


def energy_section(problem, view, n_draws: int = 100):
    """The partition of the net radiation implied by ``n_draws`` posterior draws (one batch of
    solves); None when the model has no energy balance."""
    from ..plotting.energy import plot_energy_balance

    if not any(isinstance(e, EnergyBalance) for e in problem.model.extensions):
        return None
    part = energy_partition(problem.model, problem.space.expand(view.draws(n_draws)))
    rows = "".join(f"<tr><td>{html.escape(MIDDAY_NAMES[k])}</td><td>{m:.2f}</td><td>{lo:.2f}</td>"
                   f"<td>{hi:.2f}</td></tr>" for k, (m, lo, hi) in part.summary().items())
    law = next(e for e in problem.model.extensions if isinstance(e, EnergyBalance))
    latent = law.latent_form
    frag = ("<p>The net radiation Rn (measured) split by the fitted laws into sensible heat H "
            "(bulk transfer with the wind, or the no-wind fallback), latent heat LE "
            f"({latent}) and the heat flux into the ground G = "
            "Rn − H − LE (less what other surface terms take off the spot: a "
            "<code>shading</code> shadow, a radiation factor, a sink after rain). Midday: "
            "the rows where Rn exceeds half its maximum (ratios of sums). "
            "Over April grass LE/Rn is typically 0.5–0.8 and G/Rn 0.05–0.2; over dry bare soil "
            "LE is small and G/Rn 0.2–0.4.</p><table><tr><th>at midday</th><th>median</th>"
            "<th>2.5 %</th><th>97.5 %</th></tr>" + rows + "</table>")
    tower = tower_check(part, problem.meas)
    if tower is not None:
        frag += ("<p>The flux tower's H and LE (measured, not fitted) against the implied ones: "
                 + html.escape(tower.text()) + ". A tower closes typically 70–90 % of Rn − G, so "
                 "its midday share is read from its raw value to the value with its balance "
                 "closed at its own Bowen ratio.</p>")
    off = part.off if "off_Rn" in part.midday() else None  # other terms' own curve (a shadow), if any
    fig = plot_energy_balance(problem.meas.t, part.Rn[0], part.H, part.LE, part.G,
                              problem.meas.time0, part.summary_text(), off=off,
                              measured=tower_fluxes(problem.meas))
    return frag, [fig]
