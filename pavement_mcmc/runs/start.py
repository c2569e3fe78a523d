"""Where a refit with added effects starts (``fit --add``): a MAP of the extended model.

A new parameter started at its prior mean (or its null value) can leave the chains stuck at a
bound far from the mode (``fit --add evaporation`` stuck at evap_A ~ 2e-8 with R-hat 16.9
while the MAP route gave 0.30). So the extended model is fitted by MAP first: the base model's
MAP, then every start the new extensions propose
(:meth:`~pavement_mcmc.physics.Extension.start_values`) with their null values, the best of
them kept. ``--add finer_h`` is not an extension but a finer ``[model] h`` setting
(:func:`~pavement_mcmc.physics.hbasis.finer_spec`).
"""

from __future__ import annotations

from ..data import ConfigError, load_case, merge_overrides
from ..physics.hbasis import FINER_H, finer_spec
from ..posterior import build_problem, find_map
from ..posterior.starts import best_start, extension_starts


def resolve_finer_h(case, ov: dict, add: list[str]) -> tuple[dict, list[str]]:
    """``(overrides, add)`` with ``finer_h`` taken out of ``add`` and turned into the ``[model]
    h`` override it stands for (the one place ``finer_h`` is resolved: ``fit --add`` and
    :func:`~pavement_mcmc.criticism.point.load_point`); ConfigError if h is already one value
    per interval or given by an extension."""
    if FINER_H not in add:
        return ov, add
    rest = [a for a in add if a != FINER_H]
    adds = {"model": {"extensions": rest}} if rest else None
    cfg = load_case(case, ov or None, additions=adds)
    spec = finer_spec(build_problem(cfg).model)
    if spec is None:
        raise ConfigError(f"--add {FINER_H}: h(t) is already one value per interval or given by an "
                         "extension; there is no finer h to fit")
    return merge_overrides(ov, {"model": {"h": spec}}), rest


def map_start(problem, cfg, added: list[str]):
    """The best MAP (a :class:`~pavement_mcmc.posterior.Laplace`) of ``problem`` from the base
    model's MAP and the added extensions' starts; None if nothing was added."""
    names = {e.name for e in problem.model.extensions}
    new = [e for e in problem.model.extensions if e.name in set(added) & names]
    if not new:
        return None
    base = build_problem(cfg, extensions=[e.name for e in problem.model.extensions if e not in new],
                         input_noise=problem.posterior.input_noise)
    lb = find_map(base.posterior)
    base_vals = {**base.space.value_dict(), **dict(zip(lb.names, lb.theta, strict=True))}
    post = problem.posterior
    return best_start(lambda s: find_map(post, problem.space.start_vector(s)),
                      extension_starts(new, problem.meas, base_vals),
                      score=lambda lap: float(post(lap.theta[None, :])[0][0]))
