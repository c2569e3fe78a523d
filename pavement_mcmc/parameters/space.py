"""Parameters as objects (value, bounds, ``vary`` flag, prior) and the ordered space of them.

A sampler sees only the *free* parameters as a matrix ``theta`` of shape ``(n_sets, n_free)``;
:meth:`ParameterSpace.expand` turns it into a dict of ``(n_sets,)`` arrays for every parameter,
fixed ones included, which is what the physics consumes. Fixing a parameter is one word in a
config (``vary = false``), never a code change.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from operator import is_, itemgetter

import numpy as np

from .priors import Flat, GMRFSmoothness, Prior, prior_from_config


@dataclass(frozen=True)
class Parameter:
    """One model parameter.

    Attributes
    ----------
    name : unique name, e.g. ``"kappa"`` or ``"h_3"``.
    value : initial / fixed value (SI units).
    lower, upper : hard bounds; outside them the posterior is ``-inf``.
    vary : False fixes the parameter at ``value``.
    prior : a :class:`~pavement_mcmc.parameters.priors.Prior` (default: flat within the bounds).
    unit, description : for tables and figures.
    group : parameters configured together, e.g. every ``h_i`` has group ``"h"``.
    """

    name: str
    value: float
    lower: float = -np.inf
    upper: float = np.inf
    vary: bool = True
    prior: Prior = field(default_factory=Flat)
    unit: str = ""
    description: str = ""
    group: str = ""


_KEYS = {"value", "lower", "upper", "vary", "prior"}


@dataclass(frozen=True)
class PriorResiduals:
    r"""The priors of a :class:`ParameterSpace` written as residuals: :math:`-2\log\pi(\theta) =
    \lVert r(\theta)\rVert^2 + \text{const}`.

    One row per free parameter with a Gaussian-family prior (:attr:`Prior.gaussian`),
    :math:`(\theta_i - \mu_i)/s_i`, and :math:`N - 1` rows per smoothness prior,
    :math:`\sqrt{\gamma}\,Dh`; flat and uniform priors add no row (their bounds are kept by the
    parameters). The one place a prior becomes residuals: the least-squares MAP, the criticism's
    prior penalty and its effective parameter count all use it.

    Attributes
    ----------
    cols : (k,) free-parameter columns of the Gaussian rows; ``mu``, ``sd`` their means and sds.
    smooth : ``(h columns, gamma column or None, fixed gamma)`` per smoothness prior whose h are
        all free.
    """

    cols: np.ndarray
    mu: np.ndarray
    sd: np.ndarray
    smooth: tuple

    @classmethod
    def of(cls, space: ParameterSpace) -> PriorResiduals:
        free = space.free
        rows = [(i, *space[n].prior.gaussian) for i, n in enumerate(free)
                if space[n].prior.gaussian is not None]
        cols, mu, sd = (np.array(v, dtype=t) for v, t in
                        zip(zip(*rows, strict=True) if rows else ((), (), ()), (int, float, float),
                            strict=True))
        col = {n: i for i, n in enumerate(free)}
        smooth = []
        jp = space.smoothness()
        if jp is not None and all(n in col for n in jp.names):
            g = jp.gamma_name
            smooth.append((np.array([col[n] for n in jp.names]), col.get(g), float(space[g].value)))
        return cls(cols, mu, sd, tuple(smooth))

    def __call__(self, theta: np.ndarray, gamma: float | None = None) -> np.ndarray:
        """Residual rows ``(n_sets, n_rows)`` of ``theta`` (n_sets, n_free); ``gamma`` overrides
        the smoothness precision (the MAP's EM step holds it fixed)."""
        theta = np.atleast_2d(theta)
        parts = [(theta[:, self.cols] - self.mu) / self.sd]
        for hcols, gcol, gfix in self.smooth:
            g = gamma if gamma is not None else (theta[:, gcol] if gcol is not None else gfix)
            parts.append(np.sqrt(np.asarray(g, float)).reshape(-1, 1) * np.diff(theta[:, hcols], axis=1))
        return np.concatenate(parts, axis=1)

    def penalty(self, theta: np.ndarray) -> np.ndarray:
        """``||r||^2`` per set: ``-2 log prior`` up to a constant."""
        r = self(theta)
        return np.sum(r * r, axis=1)

    def precision(self, n_free: int) -> np.ndarray:
        """Diagonal ``1/s^2`` of the Gaussian rows on every free parameter (0 where none)."""
        out = np.zeros(n_free)
        out[self.cols] = 1.0 / self.sd**2
        return out


class ParameterSpace:
    """Ordered collection of :class:`Parameter` plus joint priors (e.g. smoothness on h)."""

    def __init__(self, params: list[Parameter], joint_priors: list[GMRFSmoothness] | None = None):
        names = [p.name for p in params]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"parameter names clash: {dup}")
        self.params = {p.name: p for p in params}
        self.joint_priors = list(joint_priors or [])
        # a space is not changed after it is made (``configure`` makes a new one): what the
        # per-evaluation calls need is worked out once
        self._free = [n for n, p in self.params.items() if p.vary]
        self._col = {n: i for i, n in enumerate(self._free)}
        self._fixed = [(n, p.value) for n, p in self.params.items() if not p.vary]
        self._columns: dict = {}  # columns()'s index plans by names (shared by every expand)

    # -- views -------------------------------------------------------------------------------
    @property
    def names(self) -> list[str]:
        return list(self.params)

    @property
    def free(self) -> list[str]:
        return list(self._free)

    def __getitem__(self, name: str) -> Parameter:
        return self.params[name]

    def __contains__(self, name: str) -> bool:
        return name in self.params

    def initial(self) -> np.ndarray:
        """Values of the free parameters, shape ``(n_free,)``."""
        return np.array([self.params[n].value for n in self.free])

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.array([self.params[n].lower for n in self.free])
        hi = np.array([self.params[n].upper for n in self.free])
        return lo, hi

    def smoothness(self) -> GMRFSmoothness | None:
        """The smoothness (GMRF) prior on h(t)'s pieces, with its precision ``gamma_name``, or
        None: the one place the joint priors are searched for it."""
        return next((jp for jp in self.joint_priors if isinstance(jp, GMRFSmoothness)), None)

    def start_vector(self, values: dict[str, float] | None = None) -> np.ndarray:
        """Free-parameter vector ``(n_free,)`` of ``values`` by name (others, and non-finite
        values, at the parameter's ``value``), moved strictly inside the bounds by 1e-6 of their
        span: where an optimiser or a sampler starts."""
        lo, hi = self.bounds()
        x = self.initial().astype(float)
        for i, n in enumerate(self.free):
            if values and n in values and np.isfinite(values[n]):
                x[i] = float(values[n])
        span = np.where(np.isfinite(hi - lo), hi - lo, np.abs(x) + 1.0)
        return np.clip(x, lo + 1e-6 * span, hi - 1e-6 * span)

    def expand(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """Free-parameter matrix ``(n_sets, n_free)`` -> ``{name: (n_sets,)}`` for all parameters."""
        theta = np.atleast_2d(np.asarray(theta, float))
        free = self._free
        if theta.shape[1] != len(free):
            raise ValueError(f"theta has {theta.shape[1]} columns, expected {len(free)}: {free}")
        out = ParameterSets(zip(free, theta.T))  # column views theta[:, i]
        out.theta, out.col, out.views, out.plans = theta, self._col, tuple(out.values()), self._columns
        n_sets = theta.shape[0]
        for n, value in self._fixed:
            out[n] = np.full(n_sets, value)
        return out

    def values(self) -> dict[str, np.ndarray]:
        """Every parameter at its ``value``, as a one-set dict."""
        return self.expand(self.initial()[None, :])

    # -- prior -------------------------------------------------------------------------------
    def log_prior(self, theta: np.ndarray) -> np.ndarray:
        """Log prior density of each row of ``theta`` (``-inf`` outside the bounds)."""
        theta = np.atleast_2d(theta)
        lo, hi = self.bounds()
        inside = np.all((theta >= lo) & (theta <= hi), axis=1)
        lp = np.zeros(theta.shape[0])
        for i, n in enumerate(self.free):
            lp += self.params[n].prior.logpdf(theta[:, i])
        if self.joint_priors:
            p = self.expand(theta)
            for jp in self.joint_priors:
                lp += jp.logpdf(p)
        return np.where(inside & np.isfinite(lp), lp, -np.inf)

    def grad_log_prior(self, theta: np.ndarray, joint: bool = True) -> np.ndarray:
        """Gradient of :meth:`log_prior` with respect to ``theta`` (n_sets, n_free), for rows
        inside the bounds; ``joint=False`` leaves the joint (smoothness) priors out."""
        theta = np.atleast_2d(np.asarray(theta, float))
        free = self.free
        out = np.zeros_like(theta)
        for i, n in enumerate(free):
            prior = self.params[n].prior
            if not isinstance(prior, Flat):
                out[:, i] = prior.grad_logpdf(theta[:, i])
        if joint and self.joint_priors:
            p = self.expand(theta)
            col = {n: i for i, n in enumerate(free)}
            for jp in self.joint_priors:
                for n, g in jp.grad_logpdf(p).items():
                    if n in col:
                        out[:, col[n]] += g
        return out

    def prior_residuals(self) -> PriorResiduals:
        """The priors as residual rows (see :class:`PriorResiduals`)."""
        return PriorResiduals.of(self)

    def value_dict(self) -> dict[str, float]:
        """Every parameter at its ``value``, as floats by name."""
        return {n: float(p.value) for n, p in self.params.items()}

    # -- configuration -----------------------------------------------------------------------
    def configure(self, section: dict) -> ParameterSpace:
        """Apply a config ``[parameters]`` section; keys are parameter names or group names.

        Each entry may set ``value``, ``lower``, ``upper``, ``vary`` and ``prior`` (a table, see
        :func:`~pavement_mcmc.parameters.priors.prior_from_config`). A group entry (``h``) applies to all
        members; a name entry (``h_3``) overrides the group. Unknown names raise ``ValueError``
        listing the valid ones.
        """
        groups = {p.group for p in self.params.values() if p.group}
        for key, spec in section.items():
            if key not in self.params and key not in groups:
                valid = sorted(set(self.params) | groups, key=_natural)
                raise ValueError(f"unknown parameter {key!r} in [parameters]; valid: {valid}")
            if not isinstance(spec, dict) or set(spec) - _KEYS:
                raise ValueError(
                    f"[parameters.{key}] must be a table with keys among {sorted(_KEYS)}, got {spec!r}"
                )
            if spec.get("vary") is False and "value" not in spec:
                raise ValueError(f"[parameters.{key}] vary = false needs a value: the value to "
                                 "fix it at (its default is not the case's)")
        new = dict(self.params)
        for level in ("group", "name"):
            for key, spec in section.items():
                is_group = key in groups and key not in self.params
                if (level == "group") != is_group:
                    continue
                for n, p in new.items():
                    if n == key or (is_group and p.group == key):
                        new[n] = _apply(p, spec)
        for key, spec in section.items():
            if "value" in spec:
                for n, p in new.items():
                    if n == key or (key in groups and key not in self.params and p.group == key):
                        _check_bounds(p, p.value, f"[parameters.{key}] value")
        return ParameterSpace(list(new.values()), self.joint_priors)



def parameter_values(space, overrides: Mapping[str, float] | None = None) -> dict[str, float]:
    """Every parameter's value, with ``overrides`` applied.

    Parameters
    ----------
    space : :class:`ParameterSpace`
        Supplies names, groups and default values (config or literature values).
    overrides : mapping, optional
        ``{name: value}``; a group name (``"h"``) sets every member (``h_1 .. h_K``); a member
        name given as well overrides its group.

    Returns
    -------
    dict of str to float

    Raises
    ------
    ValueError
        For an unknown name (the message lists the valid ones) or a non-finite value.
    """
    values = {n: float(p.value) for n, p in space.params.items()}
    groups: dict[str, list[str]] = {}
    for n, p in space.params.items():
        if p.group:
            groups.setdefault(p.group, []).append(n)
    overrides = dict(overrides or {})
    for key, v in overrides.items():
        if key not in values and key not in groups:
            valid = sorted(groups) + [n for n in values if not space[n].group]
            shown = valid + ([f"{groups['h'][0]}..{groups['h'][-1]}"] if "h" in groups else [])
            raise ValueError(f"unknown parameter {key!r}; valid: {', '.join(shown)}")
        if not np.isfinite(float(v)):
            raise ValueError(f"parameter {key!r}: value {v!r} is not a finite number")
        for n in groups.get(key, [key]) if key not in values else [key]:
            _check_bounds(space[n], float(v), key)
    for level_group in (True, False):
        for key, v in overrides.items():
            is_group = key in groups and key not in values
            if is_group != level_group:
                continue
            for n in groups[key] if is_group else [key]:
                values[n] = float(v)
    return values


def _check_bounds(p: Parameter, v: float, what: str) -> None:
    """A value outside a parameter's bounds has zero posterior density: refuse it."""
    if not p.lower <= v <= p.upper:
        raise ValueError(f"{what}: {v:g} is outside {p.name}'s bounds [{p.lower:g}, {p.upper:g}]"
                         + (f" ({p.unit})" if p.unit and p.unit != "-" else ""))


def _apply(p: Parameter, spec: dict) -> Parameter:
    kw = {k: v for k, v in spec.items() if k != "prior"}
    if "value" in kw:
        kw["value"] = float(kw["value"])
    for b in ("lower", "upper"):
        if b in kw:
            kw[b] = float(kw[b])
    if "vary" in kw:
        kw["vary"] = bool(kw["vary"])
    if "prior" in spec:
        try:
            kw["prior"] = prior_from_config(spec["prior"])
        except ValueError as err:
            raise ValueError(f"[parameters.{p.name}] prior: {err}") from None
    return replace(p, **kw)


def _natural(s: str):
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", s)]


class ParameterSets(dict):
    """``{name: (n_sets,)}`` as :meth:`ParameterSpace.expand` returns it, keeping the matrix
    ``theta`` its free columns are views of, so :func:`columns` can hand many of them over as
    one block (h(t)'s 144 pieces on a 72-h window) instead of stacking them one by one."""

    theta: np.ndarray
    col: dict[str, int]
    views: tuple  # the column views, as expand made them
    plans: dict  # columns()'s plans, shared by the space's expands


def columns(p: dict[str, np.ndarray], names) -> np.ndarray:
    """The parameters ``names`` of ``p`` as one (n_sets, len(names)) array: a slice of the
    matrix behind a :class:`ParameterSets` when every one is still its own column there (not
    replaced after :meth:`ParameterSpace.expand`), else stacked."""
    theta = getattr(p, "theta", None)
    if theta is not None and len(names):
        plan = _plan(p, names)
        if plan is not None:
            same, views, block = plan
            if all(map(is_, same(p), views(p.views))):  # none replaced after expand
                return theta[:, block]
    return np.stack([np.asarray(p[n], float) for n in names], axis=-1)


def _plan(p: ParameterSets, names):
    """How :func:`columns` reads ``names`` from ``p``'s matrix, worked out once per space and
    names (``p.plans``): getters of the entries and of their column views, and the block (a
    slice for consecutive columns: a view, no copy); None when a name is not a free column."""
    key = tuple(names)
    plan = p.plans.get(key, False)
    if plan is False:
        idx = [p.col.get(n, -1) for n in key]
        plan = None
        if min(idx) >= 0:
            lo = idx[0]
            block = slice(lo, lo + len(idx)) if idx == list(range(lo, lo + len(idx))) else idx
            plan = (_getter(key), _getter(idx), block)
        p.plans[key] = plan
    return plan


def _getter(keys):
    """``itemgetter`` that always returns a tuple (also of one key)."""
    get = itemgetter(*keys)
    return get if len(keys) > 1 else (lambda d: (get(d),))
