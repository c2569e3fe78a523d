"""The view of a stored run: :func:`load_view`, :class:`RunView` and the posterior predictive."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from ..data import RunError, RunNotFound
from ..diagnostics.assessment import Assessment, assess
from ..diagnostics.stopping import StoppingRule
from ..parameters import parameter_values
from ..physics import LITERATURE
from .folder import RunFolder
from .kept import KeptChain
from .load import load_kept
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
    others : ``(stream, prediction)`` of every observation stream after the sensors' (heat-flux
        plates, the infrared temperature), each prediction (n, n_obs, n_cols) in its unit.
    """

    theta: np.ndarray
    pred: np.ndarray
    T_surface: np.ndarray
    h: np.ndarray
    others: tuple = ()

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
    coeffs = model.coefficients(p)
    others = tuple((s, s.predict(model, nodes, coeffs, p)) for s in problem.posterior.streams[1:])
    return Predictive(theta, model.observe(nodes, p), nodes[..., 0], np.asarray(coeffs.h), others)


@dataclass
class RunView:
    """A stored run with its problem, kept chain and derived quantities (computed lazily).

    Attributes
    ----------
    path : the run directory.
    problem : the rebuilt :class:`~pavement_mcmc.posterior.Problem`.
    kept_chain : the :class:`~pavement_mcmc.runs.kept.KeptChain` (``run`` and ``burn_in``);
        ``get_chain(thin=, flat=)`` reads it.
    seed : seed of the draws used for figures and the predictive.
    rule : the :class:`~pavement_mcmc.diagnostics.StoppingRule` the run was held to.
    unfinished : None for a run that finished by its rule, else why it did not.
    """

    path: Path
    problem: object
    kept_chain: KeptChain
    seed: int = 0
    rule: StoppingRule = StoppingRule()
    unfinished: str | None = None
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def folder(self) -> RunFolder:
        return RunFolder(self.path)

    @property
    def run(self):
        """The stored :class:`~pavement_mcmc.storage.RunData` (committed steps)."""
        return self.kept_chain.run

    @property
    def burn_in(self) -> int:
        """Stored rows discarded."""
        return self.kept_chain.burn_in

    @property
    def burn_in_source(self) -> str:
        """Where ``burn_in`` came from (given, stored, config, or chosen by MSER)."""
        return self.kept_chain.source

    @property
    def names(self) -> list[str]:
        return list(self.run.param_names)

    def get_chain(self, thin: int = 1, flat: bool = False) -> np.ndarray:
        """The kept chain (:meth:`KeptChain.get_chain <pavement_mcmc.runs.kept.KeptChain.get_chain>`)."""
        return self.kept_chain.get_chain(thin, flat)

    @property
    def kept(self) -> np.ndarray:
        """(n_kept, n_chains, n_params) chain after burn-in."""
        return self.get_chain()

    @property
    def flat(self) -> np.ndarray:
        """(n_kept * n_chains, n_params) draws after burn-in."""
        return self.get_chain(flat=True)

    def thinned(self, max_steps: int = 2000) -> tuple[np.ndarray, int]:
        """The kept chain thinned to at most ``max_steps`` steps, and the thinning factor.

        Figures of long runs (Case C keeps ~75 000 steps x 32 chains x 115 parameters) use it:
        autocovariance norms and segment statistics of the full chain would take minutes.
        """
        thin = max(1, -(-self.kept_chain.n_kept // max_steps))
        return self.get_chain(thin), thin

    def draws(self, n: int = 100) -> np.ndarray:
        """``n`` draws from the kept chain, evenly spaced in steps, walkers at random (seeded)."""
        k = self.get_chain()
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
        members = {k: [p for p in space.params.values() if p.name == k or p.group == k] for k in over}
        over = {k: v for k, v in over.items()  # a case's bounds may exclude the paper's values
                if all(p.lower <= v <= p.upper for p in members[k])}
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
        return assess(self.run, self.burn_in, self.rule, self.unfinished,
                      self.kept_chain.n_adapt_rows)


def _run_file(path: Path) -> Path:
    if path.is_dir():
        f = RunFolder(path).chain
        if not f.exists():
            raise RunNotFound(f"{path}: no {f.name} in this run directory (nothing sampled yet?)")
        return f
    if not path.exists():
        raise RunNotFound(f"{path}: no such run directory or file")
    if path.suffix.lower() == ".toml":
        raise RunNotFound(f"{path} is a case file, not a run: fit it first (pavement-mcmc fit "
                          f"{path} --out {path.with_suffix('')}) and give the run directory")
    if path.suffix.lower() not in (".h5", ".hdf5"):
        raise RunNotFound(f"{path}: not a run directory or a chain.h5 file")
    return path


def load_view(path: str | Path, burn_in: int | None = None, seed: int = 0) -> RunView:
    """Open a stored run (a directory with ``chain.h5``, or the file) and rebuild its problem.

    Parameters
    ----------
    path : run directory or HDF5 file. Safe while another process writes it.
    burn_in : stored rows to discard; default: the one rule of
        :func:`~pavement_mcmc.runs.kept.keep` (the loop's choice for a finished run, else the
        config's ``sampler.burn_in``, else MSER after the adaptation).
    seed : seed of the posterior draws used by figures.
    """
    f = _run_file(Path(path))
    folder = RunFolder(f.parent)
    problem, kept = load_kept(folder.path, burn_in)
    run = kept.run
    if list(problem.space.free) != list(run.param_names):
        raise ValueError(f"{f}: stored parameters {run.param_names} differ from the rebuilt "
                         f"problem's {problem.space.free}")
    if run.n_saved < 1:
        raise RunError(f"{f}: the run has no committed steps yet")
    return RunView(folder.path, problem, kept, seed, folder.rule(problem.cfg.sampler),
                   folder.unfinished_reason(run.n_saved))
