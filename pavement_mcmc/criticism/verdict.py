"""The ranking's verdict in plain words (see :mod:`.ranking` for the scores)."""

from __future__ import annotations

from .residuals import ResidualReport, noise_like


def _prior_conflicts(entries, threshold) -> str:
    """A sentence on the prior-driven candidates ('' if none)."""
    pd = [e for e in entries if e.prior_driven]
    if not pd:
        return ""
    items = ", ".join(
        f"{e.name} (S = {e.score:.0f}, of which {e.delta_prior:.0f} from the priors; data part "
        f"{e.data_score:.0f} <= {threshold:g})"
        for e in pd
    )
    return (
        f" Not claimed: {items}. The data alone cannot tell such a candidate from a shift of the "
        "other parameters (for radiation_factor: a common scale of kappa, C and h); its score "
        "reflects a conflict between the data and the priors (e.g. on kappa and C), not a "
        "detected effect."
    )


def make_verdict(best, entries, lookalikes, rep: ResidualReport, threshold) -> str:
    """One paragraph: the missing effect (or none, or unexplained structure), then the
    prior-driven candidates that are not claimed."""
    return _verdict_main(best, entries, lookalikes, rep, threshold) + _prior_conflicts(entries, threshold)


def _verdict_main(best, entries, lookalikes, rep: ResidualReport, threshold) -> str:
    if best is not None:
        txt = (
            f"Missing effect: {best.name} (score {best.score:.0f}; RMSE would fall from "
            f"{rep.rmse:.3f} to {best.rmse:.3f} °C = {best.rmse_sigma:.2f} σ)."
        )
        others = [n for n in lookalikes if n != best.name]
        if others:
            txt += (
                f" Look-alikes with a similar in-sample score: {', '.join(others)}; "
                f"{best.name} predicts held-out sensors best."
            )
        if best.name == "radiation_factor":
            txt += (
                f" Caveat: a radiation factor is identifiable only through the priors on kappa and "
                f"C (scale symmetry with kappa, C and h; {best.delta_prior:.0f} of the score comes "
                "from the priors): it is a radiometer error only if those priors are right."
            )
        return txt
    if noise_like(rep):
        return (
            f"No missing effect detected: RMSE {rep.rmse:.3f} °C = {rep.rmse_sigma:.2f} σ is "
            f"within the misfit floor and the residuals show no significant structure "
            f"(no candidate scores above {threshold:g} on the data)."
        )
    best_data = max((e.data_score for e in entries), default=float("nan"))
    corr = rep.strongest_correlations(z_min=3.0, k=3)
    words = "; ".join(f"{lab} with {name} (r = {r:+.2f})" for lab, name, r, _ in corr) or "none"
    return (
        f"The residuals are structured (RMSE {rep.rmse:.3f} °C = {rep.rmse_sigma:.2f} σ, "
        f"lag-1 {rep.rho:.2f}) but no catalogue entry explains them (best data part "
        f"{best_data:.0f} <= {threshold:g}). Strongest correlations: {words}."
    )
