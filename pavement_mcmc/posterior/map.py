r"""Maximum a posteriori point by least squares and its Gauss–Newton (Laplace) covariance.

The negative log-posterior of the model is written as half a sum of squares,

.. math:: -\log\pi(\theta) = \tfrac12 \lVert r(\theta) \rVert^2 + \text{const},\qquad
          r = \big[(T_\mathrm{pred}-T_\mathrm{obs})/\sigma,\ (\theta_i-\mu_i)/s_i,\
          \sqrt{\gamma}\, D h\big],

(whitened residuals, one row per Gaussian prior, and the smoothness prior as residuals), and
minimised with :func:`scipy.optimize.least_squares` (trust-region reflective, within the bounds)
in scaled coordinates ``z = theta / scale``. The Jacobian is central finite differences of all
``2 d`` perturbed sets in ONE vectorised posterior call (one-sided within a step of a bound).
Flat and uniform priors contribute no rows; other priors are ignored by the fit (the samplers
still use the exact posterior).

The smoothness precision :math:`\gamma` (Case C) is not fitted jointly: the joint mode over
``h`` and :math:`\gamma` drifts to large :math:`\gamma` (the :math:`\gamma^{(N-1)/2}` factor
rewards shrinking ``Dh``) and biases kappa and C. Instead an EM iteration: fit ``h, kappa, C``
at fixed :math:`\gamma`, then set :math:`\gamma` to the maximiser of
:math:`\tfrac{N-1}{2}\log\gamma - \tfrac12\gamma\,E\lVert Dh\rVert^2 + \log\pi(\gamma)` with the
expectation under the Laplace approximation, :math:`E\lVert Dh\rVert^2 = \lVert D\hat h\rVert^2 +
\mathrm{tr}(D\Sigma_{hh}D^T)` — an approximate marginal-posterior mode of :math:`\gamma`.

The Laplace covariance is :math:`(J^T J)^{-1}` at the optimum (Gauss–Newton Hessian).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import optimize

from .map_steps import expected_roughness, gamma_update, gamma_variance, refine_log

__all__ = ["Laplace", "ScaledResiduals", "find_map", "parameter_scales", "psd_factor",
           "regularised_inverse"]


@dataclass
class Laplace:
    """MAP point and Gaussian approximation of a posterior.

    Attributes
    ----------
    names : free parameter names (the posterior's order).
    theta : (n_free,) the mode in the working coordinates ``z`` mapped back (for ``gamma``: the
        EM value); ``theta_ls`` is the plain least-squares MAP.
    cov : (n_free, n_free) Laplace covariance by the delta method (``gamma``: its conditional
        variance, uncorrelated).
    z, logc, cov_z : working coordinates of the mode, which of them are logs, their covariance.
    idx : indices of the parameters in the least-squares fit (all free ones but ``gamma``).
    scale : (len(idx),) scales ``z = theta[idx] / scale`` (where not log-parameterised).
    K : (len(idx), len(idx)) Gauss–Newton precision of ``z`` at the MAP, ``J^T J``.
    B : (len(idx), len(idx)) ``d K / d gamma`` (the smoothness part ``S D^T D S``; zeros if none).
    gamma_index : index of the free smoothness precision, or None.
    gamma_hat : the value of gamma used in ``K``.
    n_gmrf : number N of smoothed pieces (0 if none).
    gmrf_cols : positions of the smoothed pieces within ``idx``.
    n_evals : posterior evaluations (parameter sets solved) spent.
    rmse : (n_sensors,) RMSE per sensor at the MAP, degC.
    message : the optimiser's last message.
    notes : what was done to the approximation (e.g. a precision that was not positive definite
        and was regularised).
    """

    names: list[str]
    theta: np.ndarray
    cov: np.ndarray
    idx: np.ndarray
    scale: np.ndarray
    K: np.ndarray
    B: np.ndarray
    gamma_index: int | None
    gamma_hat: float
    n_gmrf: int
    gmrf_cols: np.ndarray
    n_evals: int
    rmse: np.ndarray
    message: str = ""
    history: list = field(default_factory=list)
    z: np.ndarray | None = None
    logc: np.ndarray | None = None
    cov_z: np.ndarray | None = None
    theta_ls: np.ndarray | None = None
    notes: list = field(default_factory=list)

    def to_theta(self, Z: np.ndarray) -> np.ndarray:
        """Working coordinates ``z`` (n, len(idx)) -> theta[idx] (log for ``logc``, else scaled)."""
        with np.errstate(over="ignore"):
            return np.where(self.logc, np.exp(Z), Z * self.scale)

    def draw(self, rng: np.random.Generator, n: int, inflate: float = 1.0) -> np.ndarray:
        """``n`` draws of every free parameter from the Gaussian approximation in the working
        coordinates (log-normal for log-parameterised ones and for gamma)."""
        k = self.idx.size
        Lc = psd_factor(self.cov_z) if k else np.zeros((0, 0))
        Z = self.z + inflate * rng.standard_normal((n, k)) @ Lc.T
        out = np.repeat(self.theta[None, :], n, axis=0)
        out[:, self.idx] = self.to_theta(Z)
        if self.gamma_index is not None:
            g = self.theta[self.gamma_index]
            sdl = np.sqrt(self.cov[self.gamma_index, self.gamma_index]) / g
            out[:, self.gamma_index] = g * np.exp(inflate * sdl * rng.standard_normal(n))
        return out

    @property
    def sd(self) -> np.ndarray:
        return np.sqrt(np.diag(self.cov))


#: relative distance beyond a bound that :meth:`ScaledResiduals.theta` takes as rounding (a few
#: hundred ulps; the Jacobian's steps are 1e-5 of a value)
_ROUNDING = 1e-13


class ScaledResiduals:
    """Whitened residuals of a batch of scaled points ``Z (n, k)`` at fixed gamma: the
    posterior's whitened data residuals (:meth:`LogPosterior.standardized_residuals`), then the
    priors' residual rows (:class:`~pavement_mcmc.parameters.PriorResiduals`); a point outside
    the bounds gets residuals of 1e6.

    A ``z`` on its bound (``hi / scale``, ``log hi``) maps back to within rounding of the
    parameter's bound, and for some scales just outside it (``(500 / s) s > 500`` for 15 % of
    ``s``): :meth:`theta` puts such values on the bound. Taken as outside, the one-sided
    Jacobian step onto the bound of an h at its upper bound 500 (the SoilVUE desert window with
    ``two_layer``) gave that column 3e10; the Laplace precision's eigenvalue floor then made
    every sd ~1e-7 of its value, and ``hmc`` never recovered from that metric (R-hat 2.4 after
    700 steps).

    :meth:`jac` (also :func:`~pavement_mcmc.posterior.marginal.find_marginal_map`'s) steps
    one-sidedly where a bound is closer than the step. A central step across the bound scored
    1e6 and gave that column ~5e10, and a parameter that reached its bound stayed there: the
    desert window's MAP stopped at C = 1e4 (its lower bound, kappa 0.0035; now C 6.8e5, kappa
    0.24), ``fit --add two_layer``'s start at C2 = 100008 (kappa 0.037), and a mode within a
    step of a bound got Laplace sds ~1e-7 of their value."""

    def __init__(self, posterior, theta_full: np.ndarray, idx, scale, logc):
        self.logc = logc
        self.post = posterior
        self.space = posterior.space
        self.base = np.asarray(theta_full, float).copy()
        self.idx, self.scale = idx, scale
        self.priors = self.space.prior_residuals()
        self.n_evals = 0
        self.n_res = getattr(posterior, "n_whitened", None) or posterior.obs.size
        lo, hi = self.space.bounds()
        self._lo, self._hi = lo[idx], hi[idx]
        with np.errstate(divide="ignore", invalid="ignore"):  # log 0 = -inf: no bound on z
            self.lo_z = np.where(logc, np.log(self._lo), self._lo / scale)
            self.hi_z = np.where(logc, np.log(self._hi), self._hi / scale)

    def theta(self, Z: np.ndarray) -> np.ndarray:
        Z = np.atleast_2d(Z)
        th = np.repeat(self.base[None, :], Z.shape[0], axis=0)
        lo, hi = self._lo, self._hi
        with np.errstate(over="ignore", invalid="ignore"):
            v = np.where(self.logc, np.exp(Z), Z * self.scale)
            tol = _ROUNDING * np.where(self.logc, np.maximum(np.abs(Z), 1.0), 1.0)  # exp: z's ulp
            v = np.where((v > hi) & (v <= hi + tol * np.abs(hi)), hi, v)
            v = np.where((v < lo) & (v >= lo - tol * np.abs(lo)), lo, v)
        th[:, self.idx] = v
        return th

    def to_z(self, theta_idx: np.ndarray) -> np.ndarray:
        floor = 1e-3 * self.scale
        return np.where(self.logc, np.log(np.maximum(theta_idx, floor)), theta_idx / self.scale)

    def dtheta_dz(self, z: np.ndarray) -> np.ndarray:
        return np.where(self.logc, np.exp(z), self.scale)

    def __call__(self, Z: np.ndarray, gamma: float) -> np.ndarray:
        th = self.theta(Z)
        lo, hi = self.space.bounds()
        ok = np.all(np.isfinite(th) & (th >= lo) & (th <= hi), axis=1)
        self.n_evals += int(ok.sum())
        r = np.full((th.shape[0], self.n_res), 1e6)
        if ok.any():
            with np.errstate(all="ignore"):
                r[ok] = self.post.whitened(th[ok])
        out = np.concatenate([r, self.priors(th, gamma)], axis=1)
        return np.where(np.isfinite(out), out, 1e6)

    def jac(self, z: np.ndarray, gamma: float, rel: float = 1e-5) -> np.ndarray:
        """Central differences of the residuals in ``z`` (steps ``rel * max(|z|, 1)``), one-sided
        where a bound is closer than the step (a parameter on or next to its bound)."""
        k = z.size
        step = rel * np.maximum(np.abs(z), 1.0)
        zp, zm = np.minimum(z + step, self.hi_z), np.maximum(z - step, self.lo_z)
        Z = np.repeat(z[None, :], 2 * k, axis=0)
        Z[np.arange(k), np.arange(k)] = zp
        Z[k + np.arange(k), np.arange(k)] = zm
        R = self(Z, gamma)
        return ((R[:k] - R[k:]) / np.where(zp > zm, zp - zm, step)[:, None]).T


def parameter_scales(space, idx, theta0) -> np.ndarray:
    """Working scale of each free parameter in ``idx``: its Gaussian prior's sd, else
    ``max(|theta0|, 1e-3)``."""
    free = space.free
    s = []
    for i in idx:
        g = space[free[i]].prior.gaussian
        if g is not None and np.isfinite(g[1]) and g[1] > 0:
            s.append(float(g[1]))
        else:
            s.append(max(abs(float(theta0[i])), 1e-3))
    return np.array(s)


def find_map(posterior, theta0: np.ndarray | None = None, *, em_max_iter: int = 30,
             em_tol: float = 1e-2, max_nfev: int = 200, log_positive: bool = True,
             refine_tol: float = 1e-10) -> Laplace:
    """MAP by least squares (EM for a free smoothness precision) and the Laplace covariance.

    Parameters
    ----------
    posterior : :class:`~pavement_mcmc.posterior.LogPosterior`.
    theta0 : (n_free,) start (default: the parameters' values).
    em_max_iter, em_tol : EM iterations on gamma and the tolerance on ``|d log gamma|``.
    max_nfev : least-squares iterations per fit.
    log_positive : parameterise parameters with lower bound 0 by their logarithm (``z = log
        theta``) and, after the least-squares fit, refine to the mode of the density of ``z``
        (which includes the Jacobian ``theta``); this keeps the Gaussian approximation away from
        the hard bound (Case C's night-time h sits at 0 in the plain MAP).
    refine_tol : that refinement stops when a step lowers the objective by less than this
        fraction of it (the criticism's refits, which compare objectives to within units, use
        a looser one than the samplers' starts).

    Returns
    -------
    Laplace
    """
    space = posterior.space
    theta = np.asarray(space.initial() if theta0 is None else theta0, float).copy()
    w = _Working.of(space, theta, log_positive)
    res_fn = ScaledResiduals(posterior, theta, w.idx, w.scale, w.logc)
    z = np.clip(res_fn.to_z(theta[w.idx]), w.lo_z, w.hi_z)
    z, gamma, msg, history = _em_fit(res_fn, w, z, em_max_iter, em_tol, max_nfev)
    theta_ls = res_fn.theta(z)[0]
    if w.logc.any():
        z = refine_log(res_fn, z, gamma, w.lo_z, w.hi_z, tol=refine_tol)
    K, B, cov_z, cov, note = _gauss_newton_covariance(res_fn, w, z, gamma)
    theta_map = res_fn.theta(z)[0]
    if w.g_free:
        gi = w.gamma_index
        theta_map[gi] = gamma
        hh = theta_map[w.idx[w.gmrf_cols]]
        cov[gi, gi] = gamma_variance(space, w.gamma_name, w.n_gmrf, float(np.sum(np.diff(hh) ** 2)),
                                 gamma)
        theta_ls[gi] = gamma
    _, blobs = posterior(theta_map[None, :])
    return Laplace(
        names=list(space.free), theta=theta_map, cov=cov, idx=w.idx, scale=w.scale, K=K, B=B,
        gamma_index=w.gamma_index, gamma_hat=gamma, n_gmrf=w.n_gmrf,
        gmrf_cols=w.gmrf_cols if w.gmrf_cols is not None else np.zeros(0, int),
        n_evals=res_fn.n_evals + 1, rmse=blobs[0], message=str(msg), history=history,
        z=z, logc=w.logc, cov_z=cov_z, theta_ls=theta_ls, notes=[note] if note else [],
    )


@dataclass(frozen=True)
class _Working:
    """The least-squares fit's layout: which free parameters it fits (``idx``: all but a free
    smoothness precision ``gamma``), their working scales, which are log-parameterised, the
    working bounds, where the smoothed h pieces sit, and the starting gamma."""

    idx: np.ndarray
    gamma_index: int | None
    gamma_name: str | None
    gamma0: float
    gmrf_cols: np.ndarray | None
    n_gmrf: int
    scale: np.ndarray
    logc: np.ndarray
    lo_z: np.ndarray
    hi_z: np.ndarray

    @property
    def g_free(self) -> bool:
        return self.gamma_index is not None

    @classmethod
    def of(cls, space, theta: np.ndarray, log_positive: bool) -> _Working:
        free = space.free
        jp = space.smoothness()
        gname, h_names = (None, None) if jp is None else (jp.gamma_name, list(jp.names))
        g_free = gname is not None and gname in free
        gi = free.index(gname) if g_free else None
        idx = np.array([i for i in range(len(free)) if i != gi], dtype=int)
        gmrf_cols = None
        if h_names is not None and all(n in free for n in h_names):
            pos = {free[i]: j for j, i in enumerate(idx)}
            gmrf_cols = np.array([pos[n] for n in h_names])
        gamma = float(theta[gi]) if g_free else (float(space[gname].value) if gname else 0.0)
        scale = parameter_scales(space, idx, theta)
        lo, hi = space.bounds()
        logc = (lo[idx] == 0.0) & (theta[idx] > 0) if log_positive else np.zeros(idx.size, bool)
        with np.errstate(divide="ignore"):
            lo_z = np.where(logc, np.log(np.maximum(1e-6 * scale, lo[idx])), lo[idx] / scale)
            hi_z = np.where(logc, np.log(hi[idx]), hi[idx] / scale)
        N = len(h_names) if gmrf_cols is not None else 0
        return cls(idx=idx, gamma_index=gi, gamma_name=gname, gamma0=gamma, gmrf_cols=gmrf_cols,
                   n_gmrf=N, scale=scale, logc=logc, lo_z=lo_z, hi_z=hi_z)


def _em_fit(res_fn, w: _Working, z, em_max_iter, em_tol, max_nfev):
    """Least squares at fixed gamma; with a free gamma, EM: alternate with the gamma update.
    Returns ``(z, gamma, last message, history of (gamma, new gamma, E|Dh|^2))``."""
    gamma, history, msg = w.gamma0, [], ""
    for _ in range(em_max_iter if w.g_free else 1):
        fit = optimize.least_squares(
            lambda v, g=gamma: res_fn(v[None, :], g)[0],
            z,
            jac=lambda v, g=gamma: res_fn.jac(v, g),
            bounds=(w.lo_z, w.hi_z),
            method="trf",
            x_scale=1.0,
            max_nfev=max_nfev,
        )
        z, msg = fit.x, fit.message
        if not w.g_free:
            break
        S_eff = expected_roughness(res_fn, w.idx, w.gmrf_cols, z, gamma)
        new = gamma_update(res_fn.space, w.gamma_name, w.n_gmrf, S_eff)
        history.append((gamma, new, S_eff))
        done = abs(np.log(new / gamma)) < em_tol
        gamma = new
        if done:
            break
    return z, gamma, msg, history


def _gauss_newton_covariance(res_fn, w: _Working, z, gamma):
    """``(K, B, cov_z, cov, note)`` at ``z``: the Gauss–Newton precision of ``z``, its
    derivative in gamma, the (regularised) covariance of ``z`` and that of theta by the delta
    method (the gamma entry is left 0)."""
    J = res_fn.jac(z, gamma)
    K = J.T @ J
    k = w.idx.size
    dz = res_fn.dtheta_dz(z)
    B = np.zeros((k, k))
    if w.gmrf_cols is not None:
        D = np.diff(np.eye(w.n_gmrf), axis=0) * dz[w.gmrf_cols][None, :]
        B[np.ix_(w.gmrf_cols, w.gmrf_cols)] = D.T @ D
    cov_z, note = regularised_inverse(K)
    n_free = len(res_fn.space.free)
    cov = np.zeros((n_free, n_free))
    cov[np.ix_(w.idx, w.idx)] = cov_z * np.outer(dz, dz)
    return K, B, cov_z, cov, note


#: eigenvalues of a Laplace precision below this fraction of the largest are raised to it
EIG_FLOOR = 1e-10


def regularised_inverse(K: np.ndarray) -> tuple[np.ndarray, str]:
    """``(K^-1, note)`` for a symmetric precision ``K``; eigenvalues below :data:`EIG_FLOOR`
    times the largest (directions the data and priors do not pin, e.g. a parameter at its bound,
    or round-off making ``J^T J`` indefinite) are raised to that floor, and ``note`` says so
    (``""`` when nothing was changed)."""
    k = K.shape[0]
    if k == 0:
        return np.zeros((0, 0)), ""
    w, V = np.linalg.eigh(0.5 * (K + K.T))
    floor = EIG_FLOOR * max(float(w.max()), 1e-300)
    bad = w < floor
    note = ""
    if bad.any():
        note = (f"Laplace precision not positive definite: {int(bad.sum())} of {k} eigenvalues "
                f"raised to {EIG_FLOOR:g} x the largest (directions the data and priors do not "
                "pin, e.g. a parameter at its bound); the covariance is regularised there")
    w = np.maximum(w, floor)
    return (V / w) @ V.T, note


def psd_factor(cov: np.ndarray) -> np.ndarray:
    """A factor ``L`` with ``L L^T = cov`` (Cholesky; the symmetric square root with negative
    round-off eigenvalues set to 0 when Cholesky fails)."""
    k = cov.shape[0]
    try:
        return np.linalg.cholesky(cov + 1e-14 * np.trace(cov) / k * np.eye(k))
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(0.5 * (cov + cov.T))
        return V * np.sqrt(np.maximum(w, 0.0))
