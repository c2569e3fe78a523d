r"""Reduced sensitivity coefficients and identifiability before any sampling.

The reduced sensitivity coefficient of the predicted temperature at sensor :math:`s` and time
:math:`t` to parameter :math:`p_j` is

.. math:: X_j(t, s) = p_j \frac{\partial T(t, s)}{\partial p_j}
          \approx \frac{T(p_j + \Delta p_j) - T(p_j - \Delta p_j)}{2\,\Delta p_j / p_j},
          \qquad \Delta p_j = 10^{-2} p_j,

(central differences, as in the paper). It is in degC: the change of temperature per 100 %
relative change of the parameter, linearised. Every perturbed parameter set (``2 n_params``)
and the unperturbed one are solved in ONE batched model call.

A parameter whose value is 0 (e.g. a sensor bias at its null point) has no relative change; it
is perturbed by ``rel_step * scale`` instead, ``scale`` its prior sd (or 1 if the prior has
none), and its coefficient is :math:`\mathrm{scale}\,\partial T/\partial p_j`.

Identifiability (:func:`identifiability`) looks at the scaled sensitivity matrix
:math:`S = X / \sigma`, rows over every sensor and every time after the initial condition,
columns over parameters. For a Gaussian likelihood, :math:`S^T S` is the Fisher information of
the parameters' logarithms, so

- the cosine of the angle between two columns (their *correlation*) near :math:`\pm 1` means
  the two parameters change the temperatures in the same way and the data can only fix a
  combination of them;
- the condition number of :math:`S` measures how close the columns are to linear dependence;
- :math:`1/\lVert S_j \rVert` is the relative standard deviation the data alone would give
  :math:`p_j` with every other parameter known, and :math:`\sqrt{[(S^T S)^{-1}]_{jj}}` the one
  with every parameter free (no prior in either).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "Identifiability",
    "Sensitivity",
    "default_names",
    "identifiability",
    "reduced_sensitivity",
]

#: relative perturbation of the paper (Delta p_j = 1e-2 p_j)
PAPER_REL_STEP = 1e-2


@dataclass(frozen=True)
class Sensitivity:
    """Reduced sensitivity coefficients of one model at one parameter point.

    Attributes
    ----------
    names : (n_params,) parameter names.
    values : (n_params,) parameter values at which the derivatives are taken (SI).
    scale : (n_params,) the factor multiplying each derivative: ``values`` or, where a value is
        0, the fallback scale (see the module notes).
    t : (n_obs,) s since the window start.
    sensors : sensor labels, e.g. ``"0cm"``.
    base : (n_obs, n_sensors) predicted temperatures at ``values``, degC.
    coefficients : (n_obs, n_sensors, n_params) ``p_j dT/dp_j``, degC.
    rel_step : the relative step of the central differences.
    """

    names: list[str]
    values: np.ndarray
    scale: np.ndarray
    t: np.ndarray
    sensors: list[str]
    base: np.ndarray
    coefficients: np.ndarray
    rel_step: float

    def max_abs(self) -> dict[str, float]:
        """Largest ``|p_j dT/dp_j|`` over sensors and times, per parameter (degC)."""
        m = np.max(np.abs(self.coefficients), axis=(0, 1))
        return {n: float(v) for n, v in zip(self.names, m)}


@dataclass(frozen=True)
class Identifiability:
    """What the data can tell apart, from the scaled sensitivity matrix (linearised).

    Attributes
    ----------
    names : parameter names (columns).
    matrix : (n_rows, n_params) scaled sensitivity ``p_j dT/dp_j / sigma`` stacked over times
        (after the initial condition) and sensors; dimensionless.
    correlation : (n_params, n_params) cosine of the angle between columns of ``matrix``.
    estimate_correlation : (n_params, n_params) correlation of the linearised least-squares
        estimates, from ``pinv(S^T S)`` (data only, no prior).
    singular_values : of ``matrix``, decreasing.
    condition_number : largest / smallest singular value (``inf`` if a column is zero).
    rel_sd_alone : (n_params,) ``1/||S_j||``: relative sd of p_j from the data, others known.
    rel_sd_joint : (n_params,) ``sqrt(diag(pinv(S^T S)))``: relative sd, all parameters free.
    pairs : ``(name_a, name_b, correlation)`` with ``|correlation| > threshold``, strongest first.
    threshold : the correlation threshold of ``pairs``.
    verdict : plain-words sentences.
    """

    names: list[str]
    matrix: np.ndarray
    correlation: np.ndarray
    estimate_correlation: np.ndarray
    singular_values: np.ndarray
    condition_number: float
    rel_sd_alone: np.ndarray
    rel_sd_joint: np.ndarray
    pairs: list[tuple[str, str, float]]
    threshold: float
    verdict: list[str] = field(default_factory=list)

    def to_dict(self, max_pairs: int = 50) -> dict:
        """JSON-friendly summary (the matrix itself left out)."""
        return {
            "names": self.names,
            "condition_number": self.condition_number,
            "singular_values": self.singular_values.tolist(),
            "correlation": self.correlation.tolist(),
            "estimate_correlation": self.estimate_correlation.tolist(),
            "rel_sd_alone": dict(zip(self.names, self.rel_sd_alone.tolist())),
            "rel_sd_joint": dict(zip(self.names, self.rel_sd_joint.tolist())),
            "pairs": [{"a": a, "b": b, "correlation": c} for a, b, c in self.pairs[:max_pairs]],
            "n_pairs": len(self.pairs),
            "threshold": self.threshold,
            "verdict": self.verdict,
        }


# --------------------------------------------------------------------------------- values


def default_names(space, model=None) -> list[str]:
    """Free parameters that enter the predicted temperatures (hyperparameters such as ``gamma``,
    which only enter the prior, and a heat-flux plate's calibration factor, which only enters
    the plate's reading, are left out)."""
    jp = space.smoothness()
    hyper = set() if jp is None else {jp.gamma_name}
    hyper |= set(getattr(model, "plate_names", None) or [])
    return [n for n in space.free if n not in hyper]


# ---------------------------------------------------------------------------- sensitivity


def _fallback_scale(space, name: str) -> float:
    if space is None or name not in space:
        return 1.0
    try:
        sd = float(space[name].prior.sd)
    except (NotImplementedError, AttributeError, TypeError):
        sd = np.nan
    return sd if np.isfinite(sd) and sd > 0 else 1.0


def reduced_sensitivity(
    model,
    values: Mapping[str, float],
    names: Sequence[str] | None = None,
    rel_step: float = PAPER_REL_STEP,
    space=None,
) -> Sensitivity:
    """Reduced sensitivity coefficients ``p_j dT/dp_j`` at every sensor and time.

    Parameters
    ----------
    model : :class:`~pavement_mcmc.physics.Model`
        The forward model (``model.predict(p)`` on a dict of ``(n_sets,)`` arrays).
    values : mapping
        Every parameter of the model -> its value (floats or 1-element arrays), e.g. from
        :func:`pavement_mcmc.parameters.parameter_values`.
    names : sequence of str, optional
        Parameters to differentiate; default: every name in ``values`` (pass
        :func:`default_names` of the space to skip hyperparameters).
    rel_step : float
        Relative step ``Delta p_j / p_j`` (the paper: 1e-2).
    space : ParameterSpace, optional
        Only used for the fallback scale of parameters whose value is 0 (their prior sd).

    Returns
    -------
    Sensitivity

    Notes
    -----
    One model call on ``2 n_params + 1`` parameter sets: row 0 the base point, rows ``2j+1`` and
    ``2j+2`` parameter ``j`` raised and lowered by ``Delta p_j``.
    """
    if not rel_step > 0:
        raise ValueError(f"rel_step must be > 0, got {rel_step}")
    base = {k: float(np.ravel(v)[0]) for k, v in values.items()}
    names = list(base) if names is None else list(names)
    unknown = [n for n in names if n not in base]
    if unknown:
        raise ValueError(f"unknown parameter(s) {unknown}; valid: {', '.join(base)}")
    if not names:
        raise ValueError("no parameters to differentiate")
    k = len(names)
    vals = np.array([base[n] for n in names])
    scale = np.where(vals != 0.0, vals, [_fallback_scale(space, n) for n in names])
    step = rel_step * scale
    n_sets = 2 * k + 1
    p = {key: np.full(n_sets, v) for key, v in base.items()}
    for j, n in enumerate(names):
        p[n][2 * j + 1] += step[j]
        p[n][2 * j + 2] -= step[j]
    pred = np.asarray(model.predict(p), float)  # (n_sets, n_obs, n_sensors)
    up, down = pred[1::2], pred[2::2]  # (k, n_obs, n_sensors)
    coef = (up - down) / (2.0 * rel_step)  # scale * dT/dp = (T+ - T-) / (2 rel_step)
    return Sensitivity(
        names=names,
        values=vals,
        scale=scale,
        t=np.asarray(model.meas.t, float),
        sensors=list(model.meas.sensor_labels),
        base=pred[0],
        coefficients=np.moveaxis(coef, 0, -1),
        rel_step=float(rel_step),
    )


# ------------------------------------------------------------------------- identifiability


def identifiability(sens: Sensitivity, sigma: float, threshold: float = 0.95) -> Identifiability:
    """Scaled sensitivity matrix, its column correlations and condition number, and a verdict.

    Parameters
    ----------
    sens : Sensitivity
        From :func:`reduced_sensitivity`.
    sigma : float
        Measurement noise sd, degC.
    threshold : float
        Pairs of parameters with ``|correlation| > threshold`` are reported as not separable.

    Returns
    -------
    Identifiability
    """
    if not sigma > 0:
        raise ValueError(f"sigma must be > 0, got {sigma}")
    names = sens.names
    S = sens.coefficients[1:].reshape(-1, len(names)) / sigma  # row 0 is the initial condition
    norms = np.linalg.norm(S, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        U = S / np.where(norms > 0, norms, 1.0)
        corr = U.T @ U
        corr[norms == 0, :] = np.nan
        corr[:, norms == 0] = np.nan
    np.fill_diagonal(corr, 1.0)
    sv = np.linalg.svd(S, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
    F = S.T @ S
    cov = np.linalg.pinv(F, rcond=1e-12, hermitian=True)
    d = np.sqrt(np.clip(np.diag(cov), 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        est_corr = cov / np.outer(d, d)
        rel_alone = np.where(norms > 0, 1.0 / norms, np.inf)
    rel_joint = np.where(norms > 0, d, np.inf)
    pairs = []
    iu, ju = np.triu_indices(len(names), 1)
    for i, j in zip(iu, ju):
        c = corr[i, j]
        if np.isfinite(c) and abs(c) > threshold:
            pairs.append((names[i], names[j], float(c)))
    pairs.sort(key=lambda x: -abs(x[2]))
    return Identifiability(
        names=list(names),
        matrix=S,
        correlation=corr,
        estimate_correlation=est_corr,
        singular_values=sv,
        condition_number=cond,
        rel_sd_alone=rel_alone,
        rel_sd_joint=rel_joint,
        pairs=pairs,
        threshold=float(threshold),
        verdict=_verdict(names, norms, corr, cond, rel_joint, pairs, threshold),
    )


def _verdict(names, norms, corr, cond, rel_joint, pairs, threshold) -> list[str]:
    out = []
    zero = [n for n, v in zip(names, norms) if v == 0]
    if zero:
        out.append(
            f"The data carry no information on {', '.join(zero)}: the predictions do not change "
            "with it; only its prior determines it."
        )
    if pairs:
        shown = pairs[:8]
        txt = "; ".join(f"{a} and {b} ({c:+.3f})" for a, b, c in shown)
        more = f" and {len(pairs) - len(shown)} more pairs" if len(pairs) > len(shown) else ""
        out.append(
            f"{len(pairs)} pair(s) of parameters change the temperatures in almost the same way "
            f"(|correlation| > {threshold:g}): {txt}{more}. The data fix only a combination of "
            "each pair; their separate values lean on the priors (a positive correlation means "
            "raising one can be compensated by lowering the other)."
        )
    else:
        out.append(
            f"No pair of parameters has |correlation| > {threshold:g}: each changes the "
            "temperatures in its own way."
        )
    if np.isfinite(cond):
        level = "well" if cond < 1e2 else "moderately" if cond < 1e4 else "badly"
        out.append(
            f"Condition number of the scaled sensitivity matrix: {cond:.3g} ({level} conditioned)."
        )
    else:
        out.append("The scaled sensitivity matrix is singular (condition number infinite).")
    poor = [(n, r) for n, r, v in zip(names, rel_joint, norms) if v > 0 and r > 0.5]
    if poor:
        txt = ", ".join(f"{n} (±{100 * r:.0f} %)" for n, r in poor[:8])
        more = f" and {len(poor) - 8} more" if len(poor) > 8 else ""
        out.append(
            "With every parameter free and no prior, the data alone would leave these poorly "
            f"determined (linearised relative sd): {txt}{more}."
        )
    return out
