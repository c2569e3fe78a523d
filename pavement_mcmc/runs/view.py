"""The view of a stored run: :func:`load_view`, :class:`RunView` and the posterior predictive."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from .. import diagnostics as dg
from ..diagnostics.assessment import Assessment, assess
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
