"""Export a stored run as an ArviZ ``InferenceData`` (netCDF), for ArviZ's plots, LOO and WAIC.

ArviZ is an OPTIONAL dependency (``pip install pavement_mcmc[arviz]``); it is imported only when
an export is made, and a missing ArviZ raises :class:`ImportError` with that instruction. Both
ArviZ 0.x (``InferenceData``) and 1.x (``xarray.DataTree``) are supported.

Groups written
--------------
- ``posterior``: the kept chain (after burn-in), walkers as ``chain``, steps as ``draw``,
  thinned by ``thin`` (see below). Every parameter is a variable; the h pieces are gathered in
  one variable ``h`` with dimension ``h_piece``.
- ``sample_stats``: ``lp`` (log-posterior) and ``acceptance_rate`` (1.0 if the step's
  proposal was accepted, else 0.0) of the same draws.
- ``log_likelihood``: ``T``, the pointwise Gaussian log-likelihood of every datum,
  ``(chain, draw, time, sensor)``, from
  :meth:`~pavement_mcmc.posterior.LogPosterior.pointwise_log_likelihood` (one batched model
  solve over all exported draws).
- ``posterior_predictive``: ``T``, replicated data = model prediction + N(0, sigma^2) noise
  (seeded), same dims.
- ``observed_data``: ``T`` ``(time, sensor)``.

The first observation row is the initial condition and carries no likelihood, so ``time``
starts at the second row (coordinate in hours since the window start).

Thinning: computing the pointwise log-likelihood costs one model solve per exported draw, so
by default the kept chain is thinned so that at most ``max_draws`` draws per walker remain
(``thin = ceil(n_kept / max_draws)``); every group uses the same thinned draws so that
``log_likelihood`` and ``posterior`` line up (as ``az.loo`` requires). Pass ``thin=1`` to export
every kept step.
"""

from __future__ import annotations

import inspect
import math
from pathlib import Path

import numpy as np

__all__ = ["export_netcdf", "import_arviz", "to_inference_data"]

_MISSING = ("ArviZ is not installed; it is an optional extra: pip install 'pavement_mcmc[arviz]' "
            "(or pip install arviz)")


def import_arviz():
    """Import ArviZ lazily, with a clear error if it is missing."""
    try:
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)
            import arviz
    except ImportError as err:
        raise ImportError(_MISSING) from err
    return arviz


def _groups(view, thin: int | None, max_draws: int, seed: int) -> tuple[dict, dict, dict, dict]:
    """Plain numpy groups: ``(groups, coords, dims, attrs)``."""
    from ..diagnostics.assessment import chains_note

    pb, run, kept = view.problem, view.run, view.kept_chain
    if thin is None:
        thin = max(1, math.ceil(kept.n_kept / max_draws))
    chain = kept.get_chain(thin)  # (n_draw, n_chain, n_par); refuses thin < 1
    n_draw, n_chain, _ = chain.shape
    names = list(run.param_names)
    space = pb.space
    h_names = [n for n in names if space[n].group == "h"]

    def cd(a: np.ndarray) -> np.ndarray:  # (draw, chain, ...) -> (chain, draw, ...)
        return np.swapaxes(a, 0, 1)

    posterior = {n: cd(chain[:, :, i]) for i, n in enumerate(names) if n not in h_names}
    if h_names:
        posterior["h"] = cd(chain[:, :, [names.index(n) for n in h_names]])
    stats = {"lp": cd(kept.get_log_prob(thin)),
             "acceptance_rate": cd(kept.get_accepted(thin).astype(float))}
    flat = chain.reshape(-1, chain.shape[2])  # draw-major
    post = pb.posterior
    pred = post.predict(flat)[:, 1:, :]
    r = pred - post.obs
    sigma = post.sigma
    ll = -0.5 * (r / sigma) ** 2 - np.log(sigma) - 0.5 * np.log(2 * np.pi)
    rng = np.random.default_rng(seed)
    rep = pred + rng.normal(0.0, sigma, pred.shape)
    shape = (n_draw, n_chain) + pred.shape[1:]
    groups = {
        "posterior": posterior,
        "sample_stats": stats,
        "log_likelihood": {"T": cd(ll.reshape(shape))},
        "posterior_predictive": {"T": cd(rep.reshape(shape))},
        "observed_data": {"T": np.asarray(post.obs)},
    }
    coords = {"time": np.asarray(pb.meas.t[1:]) / 3600.0,
              "sensor": list(pb.meas.sensor_labels)}
    dims = {"T": ["time", "sensor"]}
    if h_names:
        coords["h_piece"] = h_names
        dims["h"] = ["h_piece"]
    attrs = {
        "case": pb.cfg.name,
        "data_hash": pb.meas.data_hash(),
        "burn_in": int(view.burn_in),
        "thin": int(thin),
        "sigma_degC": float(sigma),
        "sampler": str(run.meta.get("sampler", "")),
        "units": "kappa W m-1 K-1; C J m-3 K-1; h W m-2 K-1; T degC; time h",
        "note": chains_note(str(run.meta.get("sampler", "")), view.rule),
    }
    return groups, coords, dims, attrs


def to_inference_data(view, thin: int | None = None, max_draws: int = 250, seed: int = 0):
    """ArviZ InferenceData (0.x) or DataTree (1.x) of a stored run.

    Parameters
    ----------
    view : :class:`~pavement_mcmc.report.RunView` (from :func:`~pavement_mcmc.runs.load_view`).
    thin : keep every ``thin``-th kept step (default: so that <= ``max_draws`` per walker).
    max_draws : see ``thin``.
    seed : seed of the posterior predictive noise.

    Raises
    ------
    ImportError
        If ArviZ is not installed.
    """
    az = import_arviz()
    from .. import __version__

    groups, coords, dims, attrs = _groups(view, thin, max_draws, seed)
    attrs["pavement_mcmc_version"] = __version__
    params = inspect.signature(az.from_dict).parameters
    if "posterior" in params:  # ArviZ 0.x
        idata = az.from_dict(**groups, coords=coords, dims=dims, attrs=attrs)
        for g in groups:
            getattr(idata, g).attrs.update(attrs)
        return idata
    dt = az.from_dict(groups, coords=coords, dims=dims)  # ArviZ 1.x: a DataTree
    dt.attrs.update(attrs)
    for g in groups:
        dt[g].attrs.update(attrs)
    return dt


def export_netcdf(view, path: str | Path, **kwargs) -> Path:
    """Write :func:`to_inference_data` to a netCDF file; return its path."""
    path = Path(path)
    data = to_inference_data(view, **kwargs)
    data.to_netcdf(str(path))
    return path
