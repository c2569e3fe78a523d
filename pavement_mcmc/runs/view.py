"""The view of a stored run: :func:`load_view`, :class:`RunView` and the posterior predictive."""

from __future__ import annotations

import inspect
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

import numpy as np

from .. import diagnostics as dg
from ..data import RunError, RunNotFound
from ..diagnostics.assessment import Assessment, Rule, assess
from ..parameters import parameter_values
from ..physics import LITERATURE
from .load import load_run
from .tables import truth_values


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
    problem : the rebuilt :class:`~pavement_mcmc.posterior.Problem`.
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
    rule: Rule = Rule()
    unfinished: str | None = None
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
        space = self.problem.space
        over = {k: v for k, v in LITERATURE.items() if k in space}
        if any(p.group == "h" for p in space.params.values()):
            over["h"] = LITERATURE["h"]
        vals = parameter_values(space, over)
        return self.problem.model.predict({k: np.array([v]) for k, v in vals.items()})[0]

    def truths(self) -> dict[str, float]:
        """True parameter values where the case ships them (h pieces: interval-weighted)."""
        return {k: v for k, v in truth_values(self.problem).items() if k in self.names}

    def h_truth(self) -> np.ndarray | None:
        truth = getattr(self.problem.cfg, "truth", None) or {}
        h = truth.get("h_true_obs")
        return None if h is None or len(h) != self.problem.meas.n_obs else np.asarray(h, float)

    @cached_property
    def assessment(self) -> Assessment:
        return assess(self.run, self.burn_in, self.rule, self.unfinished)


def _run_file(path: Path) -> Path:
    if path.is_dir():
        f = path / "chain.h5"
        if not f.exists():
            raise RunNotFound(f"{path}: no chain.h5 in this run directory (nothing sampled yet?)")
        return f
    if not path.exists():
        raise RunNotFound(f"{path}: no such run directory or file")
    if path.suffix.lower() == ".toml":
        raise RunNotFound(f"{path} is a case file, not a run: fit it first (pavement-mcmc fit "
                          f"{path} --out {path.with_suffix('')}) and give the run directory")
    if path.suffix.lower() not in (".h5", ".hdf5"):
        raise RunNotFound(f"{path}: not a run directory or a chain.h5 file")
    return path


def _stored_burn_in(run, problem) -> tuple[int | None, str]:
    """The runner's burn-in (result.json) of a finished run, else the config's, else None."""
    result = run.meta.get("result") or {}
    if isinstance(result.get("burn_in"), int | float):
        return int(result["burn_in"]), "chosen by the sampler loop (result.json)"
    b = problem.cfg.sampler.get("burn_in") if hasattr(problem.cfg, "sampler") else None
    return (int(b), "from the case config") if b is not None else (None, "")


def run_rule(run, problem) -> tuple[Rule, str | None]:
    """The stopping rule a stored run was sampled under (result.json, else its config and the
    loop's defaults) and, unless it finished by that rule, why it is unfinished."""
    from .loop import run_sampler

    result = run.meta.get("result") or {}
    defaults = {k: v.default for k, v in inspect.signature(run_sampler).parameters.items()}
    scfg = getattr(problem.cfg, "sampler", {}) or {}
    loop = (getattr(run.state, "extra", None) or {}).get("loop", {})
    n_adapt_rows = loop.get("n_adapt", 0) // max(1, int(loop.get("thin", 1)))
    rule = Rule(ess_min=float(result.get("ess_target", scfg.get("ess_target", defaults["ess_target"]))),
                rhat_max=float(result.get("rhat_max", defaults["rhat_max"])),
                tau_factor=float(result.get("min_tau_lengths", defaults["min_tau_lengths"])),
                n_adapt_rows=int(result.get("n_adapt_rows", n_adapt_rows)))
    if not result:
        why = ("no result.json: the run is still being written or was stopped before it finished "
               f"({run.n_saved} steps stored); continue it with 'pavement-mcmc resume'")
    elif not result.get("converged"):
        why = f"it stopped before meeting its stopping rule ({result.get('reason', '?')})"
    else:
        why = None
    return rule, why


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
    problem, run = load_run(run_dir)
    if list(problem.space.free) != list(run.param_names):
        raise ValueError(f"{f}: stored parameters {run.param_names} differ from the rebuilt "
                         f"problem's {problem.space.free}")
    if run.n_saved < 1:
        raise RunError(f"{f}: the run has no committed steps yet")
    rule, unfinished = run_rule(run, problem)
    n_adapt = min(rule.n_adapt_rows, run.n_saved - 1)
    src = "given"
    if burn_in is None:
        burn_in, src = _stored_burn_in(run, problem)
    if burn_in is None:
        try:
            burn_in = n_adapt + dg.choose_burn_in(run.log_prob[n_adapt:])
            src = "chosen by MSER on the log-posterior trace after the adaptation"
        except ValueError:
            burn_in, src = max(n_adapt, run.n_saved // 2), "half the chain (too short for MSER)"
    if burn_in < n_adapt:
        burn_in, src = n_adapt, f"{src}, raised to the end of the sampler's adaptation"
    burn_in = int(min(max(burn_in, 0), run.n_saved - 1))
    return RunView(run_dir, problem, run, burn_in, src, seed, replace(rule, n_adapt_rows=n_adapt),
                   unfinished)
