r"""Observation streams: what the likelihood compares the solved model with, one object per kind.

An :class:`Observation` is one Gaussian term of the likelihood. It holds its data (the rows
after the initial one: the initial row is the solver's starting state and carries no
information) and its noise, and it says

- :meth:`~Observation.predict`: the model's prediction ``(n_sets, n_obs, n_cols)`` from the
  solved nodal temperatures, the solver coefficients and the parameters;
- :meth:`~Observation.whiten`: residuals ``r = predicted - observed`` ``(..., n_obs - 1,
  n_cols)`` -> whitened residuals ``(..., size)`` (``r / sd``, or a full whitening
  :math:`\Sigma^{-1/2} r`);
- :attr:`~Observation.logdet`: :math:`\log\det\Sigma` of that term;
- :meth:`~Observation.vjp`: the adjoint, d log-likelihood / d nodal temperatures (added into
  the running cotangent) and its direct parameter derivatives (for ``hmc``'s gradients);
- :meth:`~Observation.parameters`: the nuisance parameters it owns (an offset, a calibration
  factor), added to the problem's parameter space after the model's.

:class:`~pavement_mcmc.posterior.LogPosterior` loops over a list of them; the log-likelihood is
:math:`-\tfrac12\,(\sum_k \lVert z_k\rVert^2 + \sum_k \log\det\Sigma_k + n \log 2\pi)`. An
observation keeps no model: it is handed the model at each call, so one stream serves a fit,
a candidate model of the criticism and a hold-out refit alike.

The streams shipped here, and the column convention of each (see :mod:`pavement_mcmc.data`):

==================  =============  =========================================================
stream              columns        noise
==================  =============  =========================================================
:class:`Temperatures`  ``T_<d>cm``  ``[data] sigma`` (degC), or the input-noise whitening
                                   (:mod:`.input_noise`)
:class:`Plates`     ``G_<d>cm``    ``plate_sigma`` + ``plate_rel_sigma`` x reading (W m-2);
                                   factor ``plate_<label>``
:class:`~.surface_ir.SurfaceIR`  ``T_surf_IR``  ``ir_sigma`` (degC); offset ``ir_offset``
==================  =============  =========================================================

A new kind is one module: a subclass of :class:`Observation` and a line in
:func:`~pavement_mcmc.posterior.problem.build_problem` that switches it on from ``[data]``.
"""

from __future__ import annotations

import numpy as np

from .compiled import temperature_cotangent, temperature_terms

_LOG_2PI = np.log(2.0 * np.pi)


class Observation:
    """Base of an observation stream (see the module docstring); do-nothing defaults.

    Attributes
    ----------
    name : the stream's name.
    labels : one label per column (blob names ``rmse_<label>``).
    data : (n_obs - 1, n_cols) observed values after the initial row.
    """

    name = "observation"
    #: what it measures and its unit, for figures
    quantity, unit = "observation", ""
    labels: list[str] = []
    data: np.ndarray

    @property
    def size(self) -> int:
        """Number of data in the likelihood."""
        return int(self.data.size)

    def parameters(self) -> list:
        """Nuisance parameters of this stream (:class:`~pavement_mcmc.parameters.Parameter`)."""
        return []

    def predict(self, model, T_nodes: np.ndarray, coeffs, p: dict) -> np.ndarray:
        """Prediction (n_sets, n_obs, n_cols) from nodal temperatures (n_sets, n_obs, n_nodes)."""
        raise NotImplementedError

    def residuals(self, model, T_nodes, coeffs, p) -> np.ndarray:
        """Predicted minus observed (n_sets, n_obs - 1, n_cols)."""
        return self.predict(model, T_nodes, coeffs, p)[:, 1:, :] - self.data

    def whiten(self, r: np.ndarray) -> np.ndarray:
        """Whitened residuals (..., size) of residuals (..., n_obs - 1, n_cols)."""
        raise NotImplementedError

    @property
    def logdet(self) -> float:
        """``log det Sigma`` of the stream's noise."""
        raise NotImplementedError

    def marginal_sd(self) -> np.ndarray:
        """Sd of each datum alone (n_obs - 1, n_cols)."""
        raise NotImplementedError

    def vjp(self, model, pred, r, z, ok, T_nodes, coeffs, p, gT):
        """Adjoint of the log-likelihood term: ``(gT, direct)``.

        ``pred``: this stream's prediction (its cotangent is made with its memory layout, so
        the reductions downstream sum in the same order whatever the stream's history);
        ``r``, ``z``: its residuals and whitened residuals; ``ok`` (n_sets,): rows
        with a finite log-likelihood (the others get no gradient); ``gT``: the nodal
        cotangent so far (None for the first stream), to add into. ``direct``: derivatives of
        the term with respect to parameters (by name, (n_sets,)) or the cell conductivities
        (``"kappa"``, (n_sets, n_cells)).
        """
        raise NotImplementedError


def _add(gT: np.ndarray | None, g: np.ndarray) -> np.ndarray:
    if gT is None:
        return g
    gT += g
    return gT


class Temperatures(Observation):
    """The buried sensors' temperatures (``T_<d>cm``), degC: sd ``sigma``, or the whitening of
    :class:`~pavement_mcmc.posterior.input_noise.InputNoise` (``input_noise``, set after the
    noisy inputs' Jacobian is known)."""

    name = "temperatures"
    quantity, unit = "temperature", "°C"

    def __init__(self, meas):
        self.data = meas.T_obs[1:]
        self.sigma = float(meas.sigma)
        self.labels = list(meas.sensor_labels)
        self.input_noise = None

    def predict(self, model, T_nodes, coeffs, p):
        return model.observe(T_nodes, p)

    def whiten(self, r):
        flat = r.reshape(*r.shape[:-2], -1)
        if self.input_noise is None:
            return flat / self.sigma
        return self.input_noise.whiten(flat)

    def weighted(self, z: np.ndarray) -> np.ndarray:
        """``W^T z`` for whitened residuals ``z`` (``W = Sigma^(-1/2)``, symmetric)."""
        return z / self.sigma if self.input_noise is None else self.input_noise.whiten(z)

    @property
    def logdet(self) -> float:
        if self.input_noise is None:
            return self.size * np.log(self.sigma**2)
        return self.input_noise.logdet

    def marginal_sd(self):
        if self.input_noise is None:
            return np.full(self.data.shape, self.sigma)
        return self.input_noise.marginal_sd.reshape(self.data.shape)

    def compiled_applies(self, model) -> bool:
        """Whether :meth:`compiled_terms` gives this stream's terms: whitened by ``sigma`` (no
        input noise), read at the sensors' nominal depths (no ``observe`` hook)."""
        return self.input_noise is None and model.observes_nominal

    def compiled_terms(self, model, T_nodes, alone: bool = True):
        """``(ll, rmse, gT)`` of this stream alone by the compiled path (:mod:`.compiled`;
        the caller checks :meth:`compiled_applies`): what :meth:`predict`, :meth:`whiten`,
        :func:`log_likelihood` and :meth:`vjp` give, to the bit, in two compiled calls; None
        for nodal temperatures in a layout other than the solver's or C order (NumPy's
        summation order is only known for those). Beside other streams (``alone=False``):
        ``(z, rmse)``, the whitened residuals and the RMSE, whose log-likelihood and
        cotangent (:meth:`compiled_cotangent`) need every stream's rows."""
        terms = self._compiled(model, T_nodes)
        if terms is None:
            return None
        ll, rmse, z, pairwise = terms
        if not alone:  # in the layout NumPy's whiten would give (it decides the sum's order)
            return (z if pairwise else np.asfortranarray(z)), rmse
        ok = np.isfinite(ll)
        return np.where(ok, ll, -np.inf), rmse, self.compiled_cotangent(model, T_nodes, z, ok)

    def _compiled(self, model, T_nodes):
        """``(ll, rmse, z, pairwise)`` by :func:`.compiled.temperature_terms`, summing the
        squares as NumPy does for this layout: pairwise for C order (one set is also the
        solver's layout, and NumPy sums a one-set residual row pairwise), in sequence for the
        solver's buffer (sets innermost); None for any other layout."""
        if T_nodes.flags.c_contiguous:
            pairwise = True
        elif T_nodes.transpose(1, 2, 0).flags.c_contiguous:
            pairwise = False
        else:
            return None
        oi, ow = model.sensor_weights
        return (*temperature_terms(T_nodes, oi, ow, self.data, self.sigma, self.logdet,
                                   self.size * _LOG_2PI, pairwise), pairwise)

    def compiled_loglik(self, model, T_nodes):
        """``(ll, rmse)`` of this stream alone by the compiled path, without the cotangent:
        what :meth:`predict`, :meth:`whiten` and :func:`log_likelihood` give, to the bit (the
        caller checks :meth:`compiled_applies`); None for a layout whose sum order is unknown."""
        terms = self._compiled(model, T_nodes)
        return None if terms is None else terms[:2]

    def compiled_cotangent(self, model, T_nodes, z, ok):
        """d log-likelihood / d nodal temperatures of this stream from its whitened residuals
        ``z`` (:meth:`compiled_terms`); rows without ``ok`` get 0 (as :meth:`vjp`)."""
        oi, ow = model.sensor_weights
        return temperature_cotangent(z, ok, oi, ow, self.sigma, T_nodes.shape[1], T_nodes.shape[2])

    def vjp(self, model, pred, r, z, ok, T_nodes, coeffs, p, gT):
        gp = np.zeros_like(pred)
        gp[:, 1:, :] = -self.weighted(np.where(ok[:, None], z, 0.0)).reshape(r.shape)
        g, direct = model.observe_vjp(gp, T_nodes, p)  # rows with a non-finite fit: 0
        return _add(gT, g), direct


class Plates(Observation):
    """Heat-flux plates (``G_<d>cm``, W m-2, positive downward): the model's conductive flux at
    the plate times its calibration factor ``plate_<label>`` (a parameter of the model);
    independent errors of sd ``flux_sd`` per reading (:func:`default_flux_sd`)."""

    name = "plates"
    quantity, unit = "heat-flux plate", "W m⁻²"

    def __init__(self, meas, flux_sd: np.ndarray | None = None):
        self.data = meas.G_obs[1:]
        self.labels = list(meas.plate_labels)
        sd = default_flux_sd(self.data) if flux_sd is None else np.asarray(flux_sd, float)
        self.sd = np.broadcast_to(sd, self.data.shape).copy()
        if not np.all(self.sd > 0):
            raise ValueError("flux_sd must be > 0 for every plate reading")

    def predict(self, model, T_nodes, coeffs, p):
        return model.observe_flux(T_nodes, coeffs, p)

    def whiten(self, r):
        return (r / self.sd).reshape(*r.shape[:-2], -1)

    @property
    def logdet(self) -> float:
        if self.__dict__.get("_logdet_of") is not self.sd:  # once per sd array
            self._logdet, self._logdet_of = 2.0 * float(np.sum(np.log(self.sd))), self.sd
        return self._logdet

    def marginal_sd(self):
        return self.sd

    def vjp(self, model, pred, r, z, ok, T_nodes, coeffs, p, gT):
        gG = np.zeros_like(pred)
        gG[:, 1:, :] = -np.where(ok[:, None, None], r, 0.0) / self.sd**2
        return model.observe_flux_vjp(gG, T_nodes, coeffs, p, gT)  # adds into gT


def default_flux_sd(G_obs: np.ndarray, abs_sd: float = 2.0, rel_sd: float = 0.1) -> np.ndarray:
    """Sd of each plate reading, W m-2: ``sqrt(abs_sd^2 + (rel_sd G)^2)`` (a floor and a share
    of the reading; the calibration error is the separate factor parameter)."""
    return np.sqrt(abs_sd**2 + (rel_sd * np.asarray(G_obs, float)) ** 2)


def with_parameters(space, streams: list[Observation]):
    """``space`` (a :class:`~pavement_mcmc.parameters.ParameterSpace`) with the streams'
    nuisance parameters appended (a name clash raises ``ValueError``)."""
    extra = [q for s in streams for q in s.parameters()]
    if not extra:
        return space
    return type(space)([*space.params.values(), *extra], space.joint_priors)


def log_likelihood(streams: list[Observation], z: np.ndarray) -> np.ndarray:
    """Gaussian log-likelihood of the streams' concatenated whitened residuals ``z`` (..., n)."""
    logdet = streams[0].logdet
    n = streams[0].size
    for s in streams[1:]:
        logdet = logdet + s.logdet
        n += s.size
    return -0.5 * (np.sum(z * z, axis=-1) + logdet + n * _LOG_2PI)
