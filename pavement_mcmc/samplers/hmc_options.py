r"""The options of ``hmc`` and the rule that chooses the ``"auto"`` ones from the problem.

Three options are ``"auto"`` unless a case sets them (``[sampler.options]``, ``--set
sampler.options.X=...``; a value set by hand always wins): the working coordinates
``log_positive`` and ``sqrt_at_zero`` (:mod:`.coords`) and the number of metric windows
``metric_windows`` (:mod:`.hmc`). :func:`resolve` decides them once, at the (gamma-marginal)
MAP and its Laplace covariance, from three numbers of the problem:

- **coordinates**: ``n_near``, the parameters bounded below by 0 whose mode lies within one
  Laplace sd of 0 (night-time h piled against their bound). When at least
  :data:`PILED_SHARE` of the parameters bounded at 0, and at least :data:`PILED_MIN` of them,
  are piled there, the posterior of h is far from the Gaussian the metric assumes: both
  coordinates go on (the shifted sqrt for those near 0, log for those above it), as
  ``runs/grass.toml`` sets by hand for the Göttingen 72-h window (65 of 144 near 0). Case C
  (9 of 112 near 0), where ``log_positive`` alone costs 158k-194k instead of 114k gradients to
  the stopping rule, and any problem with only a few such parameters keep linear coordinates
  unless their posteriors are **skewed**: when the median, over the parameters bounded at 0,
  of mode / Laplace sd is below :data:`SKEWED_MEDIAN` (a positive parameter whose sd is more
  than a sixth of its value has a visibly skewed posterior) and there are at least
  :data:`SKEWED_MIN` of them, both coordinates go on too. The
  SoilVUE desert 72-h window (``runs/desert_plain.toml``: sensors from 5 cm, 72 hourly h,
  median 4.9, only 5 of 72 near 0) needed 920 steps, 314k gradients in linear coordinates,
  525 steps, 174k with this rule (546, 173k with the hand options of ``runs/desert.toml``);
  Case C's median is 9.1, the Göttingen window's 1.3.
- **metric windows**: the second window pools ``n_chains * metric_at`` draws (800 with 16
  chains); with fewer than :data:`DRAWS_PER_DIM` of them per parameter (more than 133
  parameters) its covariance is too noisy to freeze, and a third window (``4 metric_at``) is
  added: the Göttingen window (147 parameters) needed 196k instead of 229k gradients with it,
  Case C (114) 167k instead of 114k.

The choice and its reason are kept (:attr:`HMCSampler.chosen`), stored in the run state (a
resumed run keeps it) and in ``result.json``; ``fit`` prints it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

AUTO = "auto"
#: coordinates: share of the parameters bounded at 0 whose mode is within a Laplace sd of 0 ...
PILED_SHARE = 0.2
#: ... and at least this many of them
PILED_MIN = 3
#: coordinates also when the median of mode / Laplace sd of the parameters bounded at 0 is
#: below this, for a series of at least SKEWED_MIN of them (an h(t); a few skewed parameters
#: are left to the metric: hmc's truncated-normal tests keep linear coordinates)
SKEWED_MEDIAN, SKEWED_MIN = 6.0, 10
#: metric windows: pooled draws per parameter below which a third window is added
DRAWS_PER_DIM = 6
#: the values an ``"auto"`` option took before the rule existed (a resumed old run keeps them)
LEGACY = {"log_positive": False, "sqrt_at_zero": False, "metric_windows": 2}


def _auto():
    return field(default=AUTO, metadata={"choices": (AUTO,)})


@dataclass(frozen=True)
class HMCOptions:
    """Options of the ``hmc`` sampler.

    target_acceptance : acceptance rate the dual averaging tunes ``eps`` towards.
    trajectory_length : in whitened units (~pi/2 is a half period of a Gaussian with exactly
        the metric's covariance).
    max_leapfrog : most leapfrog steps per trajectory.
    step_size : initial ``eps`` (default ``0.5 d^-1/4``).
    adapt_metric : re-estimate the metric from the pooled adaptation draws.
    metric_at : the adaptation step at which it is first re-estimated.
    metric_skip : adaptation steps before the first window's draws are pooled.
    metric_windows : how many times it is re-estimated: window ``k`` ends at adaptation step
        ``metric_at * 2**k`` and pools the draws since the previous window's end (the first one
        those after ``metric_skip``). ``"auto"`` (default): 2, or 3 for many parameters
        (:func:`resolve`).
    log_positive : sample ``log(x + c)`` (``log_shift``) instead of ``x`` for every parameter
        bounded below by 0 whose mode lies more than one Laplace sd above 0 (h pieces away from
        0, a layer's resistance); the draws are stored as ``x``. ``"auto"`` (default): on when many
        parameters are piled against 0 (:func:`resolve`; see :mod:`.coords`).
    sqrt_at_zero : sample ``sqrt(x + c) - sqrt c`` instead of ``x`` for every parameter bounded
        below by 0 whose mode lies within one Laplace sd of 0 (night-time h against their
        bound). ``"auto"`` (default): as ``log_positive``.
    sqrt_shift : that ``c`` in units of the parameter's exponential scale at the bound (0: ``sqrt x``).
    log_shift : ``log_positive`` samples ``log(x + c)``, ``c`` this many Laplace sd of the
        parameter (0: ``log x``, whose infinite tail towards 0 traps chains: :mod:`.coords`).
    rough_moves : with a free smoothness precision (Case C), scale moves of h's rough part after
        each trajectory (:mod:`.rough`; one solve each, and one gradient for a chain that moved);
        0: none.
    rough_cut : the rough part: the DCT modes ``k >= rough_cut N`` of the N values of h.
    """

    target_acceptance: float = 0.8
    trajectory_length: float = 1.5
    max_leapfrog: int = 64
    step_size: float | None = None
    adapt_metric: bool = True
    metric_at: int = 50
    metric_skip: int = 10
    metric_windows: int | str = _auto()
    log_positive: bool | str = _auto()
    sqrt_at_zero: bool | str = _auto()
    sqrt_shift: float = 0.25
    log_shift: float = 1.0
    rough_moves: int = 0
    rough_cut: float = 0.25

    def __post_init__(self):
        for k in ("sqrt_shift", "log_shift"):
            if not getattr(self, k) >= 0.0:
                raise ValueError(f"hmc option {k} must be >= 0, got {getattr(self, k)}")
        if not (isinstance(self.rough_moves, int) and self.rough_moves >= 0):
            raise ValueError(f"hmc option rough_moves must be an integer >= 0, got {self.rough_moves!r}")
        if not 0.0 < self.rough_cut < 1.0:
            raise ValueError(f"hmc option rough_cut must lie in (0, 1), got {self.rough_cut}")

    def auto_names(self) -> list[str]:
        """The options still ``"auto"``."""
        return [k for k in LEGACY if getattr(self, k) == AUTO]


def resolve(options: HMCOptions, *, n_params: int, n_chains: int, n_at0: int,
            n_near: int, z_median: float = float("inf")) -> tuple[HMCOptions, dict]:
    """The options with every ``"auto"`` one decided, and what was chosen.

    Parameters
    ----------
    options : the sampler's options (those set by hand are kept as they are).
    n_params : parameters the trajectories move (gamma integrated out).
    n_chains : chains pooled by the metric windows.
    n_at0 : parameters bounded below by 0.
    n_near : of those, the ones whose mode lies within one Laplace sd of 0.
    z_median : the median of their mode / Laplace sd (default: none is skewed).

    Returns
    -------
    (options, chosen) : ``chosen`` maps each option that was ``"auto"`` to the value taken and
        has ``"why"``, a sentence with the numbers it was decided from (empty if none was auto).
    """
    auto = options.auto_names()
    if not auto:
        return options, {}
    piled = n_near >= max(PILED_MIN, PILED_SHARE * n_at0)
    skewed = n_at0 >= SKEWED_MIN and z_median < SKEWED_MEDIAN
    draws = n_chains * options.metric_at
    few = draws < DRAWS_PER_DIM * n_params
    rule = {"log_positive": piled or skewed, "sqrt_at_zero": piled or skewed,
            "metric_windows": 3 if few else 2}
    chosen = {k: rule[k] for k in auto}
    why = []
    if {"log_positive", "sqrt_at_zero"} & set(auto):
        coords = ("sqrt for those, log for the others" if piled else
                  f"linear coordinates (sqrt and log from {PILED_MIN} and {PILED_SHARE:.0%}, "
                  f"or a median mode/sd below {SKEWED_MEDIAN:g} of {SKEWED_MIN}+)")
        if skewed and not piled:
            coords = (f"their median mode/sd is {z_median:.1f}, skewed posteriors (below "
                      f"{SKEWED_MEDIAN:g}): sqrt for those, log for the others")
        why.append(f"{n_near} of {n_at0} parameters bounded at 0 have their mode within a "
                   f"Laplace sd of it; {coords}")
    if "metric_windows" in auto:
        why.append(f"{n_chains} chains x {options.metric_at} steps = {draws / n_params:.0f} "
                   f"draws per parameter in a metric window: {chosen['metric_windows']} windows "
                   f"(3 below {DRAWS_PER_DIM})")
    return replace(options, **chosen), {**chosen, "why": "; ".join(why)}


def restored(options: HMCOptions, chosen: dict | None) -> HMCOptions:
    """The options of a resumed run: the ``"auto"`` ones as the run chose them (a run stored
    before the rule: as they were then, :data:`LEGACY`)."""
    auto = options.auto_names()
    src = LEGACY if chosen is None else {**LEGACY, **chosen}
    return replace(options, **{k: src[k] for k in auto})
