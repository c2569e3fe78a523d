r"""The smoothness precision integrated out: the marginal GMRF prior of h, tabulated once.

With the first-order GMRF prior :math:`\pi(h\mid\gamma) \propto \gamma^{(N-1)/2}
e^{-\gamma S/2}`, :math:`S = \lVert Dh \rVert^2`, and a hyperprior :math:`\pi(\gamma)` on
``[lower, upper]``, the marginal prior of ``h`` is (up to a constant; the
:math:`(2\pi)^{-(N-1)/2}` of the GMRF does not depend on :math:`\gamma`)

.. math:: \pi(h) \propto F(S) = \int \gamma^{(N-1)/2} e^{-\gamma S/2}\, \pi(\gamma)\,d\gamma ,

a smooth, decreasing, log-convex function of the single number ``S``. Moments of the full
conditional :math:`\gamma \mid h` are derivatives of it:
:math:`\tfrac{d}{dS}\log F = -E[\gamma\mid S]/2`, :math:`\tfrac{d^2}{dS^2}\log F =
\mathrm{Var}[\gamma\mid S]/4`.

:class:`MarginalGMRF` evaluates :math:`\log F`, :math:`E[\gamma\mid S]` and
:math:`\mathrm{Var}[\gamma\mid S]` on a log-spaced grid of ``S`` once (the trapezoid rule in
``u = log gamma`` on a fine grid: the integrand is smooth and decays like a Gaussian in ``u``,
so the rule converges geometrically; relative error < 1e-9 against adaptive quadrature) and
interpolates them with cubic splines in ``log S``, vectorised, so the marginal log-prior costs
nothing per step. Beyond the grid: :math:`\log F` is extrapolated with its end slopes (for large
``S`` the exact asymptote is :math:`-\nu \log S`, :math:`\nu` = the power of :math:`\gamma`
plus one; below the grid :math:`F` is flat to ~1e-9).

:func:`find_marginal_map` finds the mode of the *marginal* posterior of the other free
parameters (kappa, C, h, ...; gamma integrated out) by least squares in the original
coordinates (bounds honoured by the trust-region solver) with gamma set by the EM-style update
:math:`\gamma \leftarrow E[\gamma \mid S(\hat h)]` — at its fixed point the gradient of the
marginal log-posterior vanishes exactly — and returns its Laplace precision: the Gauss–Newton
:math:`J^T J` of the data and Gaussian-prior residuals plus the exact Hessian of
:math:`-\log F(S(h))`, :math:`E[\gamma] D^TD - \mathrm{Var}[\gamma] (D^TDh)(D^TDh)^T`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize
from scipy.interpolate import CubicSpline

from . import marginal_compiled as _mc
from .map import ScaledResiduals, parameter_scales

__all__ = ["MarginalGMRF", "MarginalMAP", "find_marginal_map", "gmrf_of"]


#: the table's quadrature keeps the points of the log-gamma grid within e^-_DROP of an
#: integrand's peak, found on every _COARSE-th point
_DROP, _COARSE = 60.0, 25


class MarginalGMRF:
    """Tabulated :math:`\\log F(S)`, :math:`E[\\gamma|S]`, :math:`Var[\\gamma|S]`.

    Parameters
    ----------
    n : number N of smoothed values (the power of gamma is (N-1)/2).
    prior : the hyperprior (anything with a vectorised ``logpdf``).
    lower, upper : bounds of gamma.
    s_range : (min, max) of the tabulated S; n_grid : number of grid points in log S.
    """

    def __init__(self, n: int, prior, lower: float = 0.0, upper: float = np.inf,
                 s_range=(1e-8, 1e10), n_grid: int = 1200):
        self.n = int(n)
        self.prior = prior
        self.lower, self.upper = float(lower), float(upper)
        self.a = 0.5 * (self.n - 1)
        ls = np.linspace(np.log(s_range[0]), np.log(s_range[1]), n_grid)
        self.log_s_lo, self.log_s_hi = float(ls[0]), float(ls[-1])
        logF, m1, var = self._integrate(np.exp(ls))
        self._logF = CubicSpline(ls, logF)
        self._m1 = CubicSpline(ls, np.log(m1))
        self._var = CubicSpline(ls, np.log(var))
        self._ends = (float(logF[0]), float(logF[-1]))
        # slope d log F / d log S at the upper end: -S E[gamma] / 2
        self._slope_hi = float(-0.5 * np.exp(ls[-1]) * m1[-1])

    # -- numerics ----------------------------------------------------------------------------
    def _log_integrand(self, u: np.ndarray, S: np.ndarray) -> np.ndarray:
        """log of gamma^a e^{-gamma S/2} pi(gamma) * gamma (Jacobian of u = log gamma)."""
        g = np.exp(u)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            lp = np.asarray(self.prior.logpdf(g), float)
            out = (self.a + 1.0) * u - 0.5 * g[None, :] * S[:, None] + lp[None, :]
        inside = (g > self.lower) & (g < self.upper)
        return np.where(inside[None, :] & np.isfinite(out), out, -np.inf)

    def _integrate(self, S: np.ndarray, du: float = 2e-3, chunk: int = 64):
        lo = np.log(max(self.lower, 1e-16)) if self.lower > 0 else np.log(1e-16)
        hi = np.log(min(self.upper, 1e12))
        u = np.arange(lo, hi + du, du)
        g = np.exp(u)
        logF, m1, var = (np.empty(S.size) for _ in range(3))
        coarse = np.arange(0, u.size, _COARSE)
        for i in range(0, S.size, chunk):
            # the grid points where any of the chunk's integrands is within e^-_DROP of its
            # peak, found on every _COARSE-th point and widened by two of those steps: the rest
            # add below 1e-26 of the integral (the full grid cost Case C's table 0.26 s)
            fc = self._log_integrand(u[coarse], S[i:i + chunk])
            near = np.nonzero(np.any(fc > fc.max(axis=1, keepdims=True) - _DROP, axis=0))[0]
            a = coarse[max(near[0] - 2, 0)] if near.size else 0
            b = coarse[min(near[-1] + 2, coarse.size - 1)] + _COARSE if near.size else u.size
            f = self._log_integrand(u[a:b], S[i:i + chunk])
            mx = f.max(axis=1, keepdims=True)
            w = np.exp(f - mx)
            z = w.sum(axis=1)
            logF[i:i + chunk] = mx[:, 0] + np.log(z * du)
            e1 = (w @ g[a:b]) / z
            e2 = (w @ (g[a:b] * g[a:b])) / z
            m1[i:i + chunk] = e1
            var[i:i + chunk] = np.maximum(e2 - e1 * e1, 1e-300)
        return logF, m1, var

    def direct(self, S: float) -> float:
        """log F(S) by adaptive quadrature (for tests), around the integrand's mode."""
        from scipy import integrate

        S = float(S)

        def f(u):
            return float(self._log_integrand(np.array([u]), np.array([S]))[0, 0])

        lo = np.log(max(self.lower, 1e-300)) if self.lower > 0 else np.log(1e-16)
        hi = np.log(min(self.upper, 1e12))
        res = optimize.minimize_scalar(lambda u: -f(u), bounds=(lo, hi), method="bounded",
                                       options={"xatol": 1e-10})
        u0, f0 = float(res.x), -float(res.fun)
        val = integrate.quad(lambda u: np.exp(f(u) - f0), lo, hi, points=[u0], limit=500,
                             epsabs=0.0, epsrel=1e-12)[0]
        return f0 + np.log(val)

    # -- vectorised evaluation ---------------------------------------------------------------
    def log_f(self, S: np.ndarray) -> np.ndarray:
        """log F(S) (up to the table's constant), any shape."""
        S = np.asarray(S, float)
        with np.errstate(divide="ignore"):
            ls = np.log(np.maximum(S, 0.0))
        out = self._logF(np.clip(ls, self.log_s_lo, self.log_s_hi))
        out = np.where(ls < self.log_s_lo, self._ends[0], out)
        return np.where(ls > self.log_s_hi,
                        self._ends[1] + self._slope_hi * (ls - self.log_s_hi), out)

    def mean_gamma(self, S: np.ndarray) -> np.ndarray:
        """E[gamma | S]."""
        ls = np.clip(np.log(np.maximum(np.asarray(S, float), 1e-300)), self.log_s_lo, self.log_s_hi)
        return np.exp(self._m1(ls))

    def var_gamma(self, S: np.ndarray) -> np.ndarray:
        """Var[gamma | S]."""
        ls = np.clip(np.log(np.maximum(np.asarray(S, float), 1e-300)), self.log_s_lo, self.log_s_hi)
        return np.exp(self._var(ls))

    def terms(self, H: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(log F(S), E[gamma | S], D^T D h)`` of rows of h (n, N), S = ||D h||^2: what
        :meth:`log_f` and :meth:`mean_gamma` give, to the bit, in two compiled calls
        (:mod:`.marginal_compiled`); the gradient of log F in h is ``-E[gamma|S] D^T D h``."""
        H = np.asarray(H, dtype=float)
        if not (H.flags.c_contiguous or H.flags.f_contiguous) or H.ndim != 2:  # NumPy's order unknown:
            dh = np.diff(H, axis=-1)                                           # NumPy's own steps
            DtDh = np.zeros_like(H)
            DtDh[..., :-1] -= dh
            DtDh[..., 1:] += dh
            S = np.sum(dh * dh, axis=-1)
            return self.log_f(S), self.mean_gamma(S), DtDh
        S, DtDh = _mc.rows(H, H.flags.c_contiguous)
        with np.errstate(divide="ignore"):
            ls = np.log(np.maximum(S, 0.0))
        f, m1 = _mc.splines(self._logF.x, self._logF.c, self._m1.c,
                            np.clip(ls, self.log_s_lo, self.log_s_hi))
        f = np.where(ls < self.log_s_lo, self._ends[0], f)
        f = np.where(ls > self.log_s_hi, self._ends[1] + self._slope_hi * (ls - self.log_s_hi), f)
        return f, np.exp(m1), DtDh

    def log_prior_h(self, H: np.ndarray) -> np.ndarray:
        """Marginal log-prior of rows of h (n, N): log F(||D h||^2)."""
        return self.log_f(np.sum(np.diff(H, axis=-1) ** 2, axis=-1))

    def hessian_h(self, h: np.ndarray) -> np.ndarray:
        """Hessian of -log F(||Dh||^2) at h (N,): E[g] D^T D - Var[g] (D^T D h)(D^T D h)^T."""
        N = h.size
        D = np.diff(np.eye(N), axis=0)
        S = float(np.sum(np.diff(h) ** 2))
        v = D.T @ (D @ h)
        return float(self.mean_gamma(S)) * (D.T @ D) - float(self.var_gamma(S)) * np.outer(v, v)


def gmrf_of(space):
    """(gamma name, h names) of the free-gamma smoothness prior of ``space``, or None."""
    free, jp = space.free, space.smoothness()
    if jp is not None and jp.gamma_name in free and all(n in free for n in jp.names):
        return jp.gamma_name, list(jp.names)
    return None


@dataclass
class MarginalMAP:
    """Mode of the gamma-marginalised posterior and its Laplace approximation.

    Attributes
    ----------
    theta : (n_free,) the mode (``gamma`` column: E[gamma | S(h_hat)]).
    idx : free indices of the sampled parameters (all but gamma).
    cov : (len(idx), len(idx)) Laplace covariance of theta[idx] (original coordinates).
    precision : its inverse (Gauss–Newton data part + exact marginal-prior Hessian).
    gamma_index : index of gamma; hcols : free indices of h_1..h_N.
    n_evals : solves spent.
    """

    theta: np.ndarray
    idx: np.ndarray
    cov: np.ndarray
    precision: np.ndarray
    gamma_index: int
    hcols: np.ndarray
    n_evals: int
    history: list
    message: str = ""


#: tolerance (``xtol``, ``ftol``) of each least-squares fit at fixed gamma: the EM update of gamma
#: stops at a relative change ``em_tol`` (1e-3), so fitting h to 1e-12 was precision the
#: gamma of the fit does not have; at 1e-8 the Case C MAP takes 14 k solves instead of 25 k and
#: moves by 0.2 % of a posterior sd (kappa), 0.1 % in gamma
XTOL = 1e-8


def find_marginal_map(posterior, table: MarginalGMRF, theta0=None, *, em_max_iter: int = 60,
                      em_tol: float = 1e-3, max_nfev: int = 100,
                      laplace_em: bool = True) -> MarginalMAP:
    """Least-squares fit at fixed gamma with gamma set by EM, and a Laplace covariance.

    ``laplace_em`` (default): gamma <- E[gamma | S_eff], S_eff = ||D h_hat||^2 +
    tr(D Sigma_hh D^T) (Sigma from the Gauss-Newton covariance at the current fit), i.e. the
    expected roughness under the Laplace approximation rather than the plug-in value; the
    covariance is then (J^T J)^-1 including gamma D^T D. The plug-in mode (``False``: the exact
    marginal mode, exact Hessian of -log F) sits at far too smooth an h where the data say little
    (Case C: gamma 6.9 against a posterior mean ~0.8), so its covariance is far too narrow there
    for a random-walk proposal.
    """
    space = posterior.space
    free = space.free
    gname, hnames = gmrf_of(space)
    gi = free.index(gname)
    idx = np.array([i for i in range(len(free)) if i != gi], dtype=int)
    pos = {free[i]: j for j, i in enumerate(idx)}
    gcols = np.array([pos[n] for n in hnames])
    theta = np.asarray(space.initial() if theta0 is None else theta0, float).copy()
    scale = parameter_scales(space, idx, theta)
    lo, hi = space.bounds()
    res_fn = ScaledResiduals(posterior, theta, idx, scale, np.zeros(idx.size, bool))
    lo_z, hi_z = lo[idx] / scale, hi[idx] / scale
    z = np.clip(theta[idx] / scale, lo_z, hi_z)
    gamma = float(theta[gi])
    history = []
    msg = ""
    D = np.diff(np.eye(gcols.size), axis=0)
    steps: list = []  # (log gamma, log T(gamma)) of the plain EM steps since the last jump
    for it in range(em_max_iter):
        fit = optimize.least_squares(
            lambda v, g=gamma: res_fn(v[None, :], g)[0], z,
            jac=lambda v, g=gamma: res_fn.jac(v, g), bounds=(lo_z, hi_z),
            method="trf", x_scale=1.0, max_nfev=max_nfev if it else 4 * max_nfev,
            xtol=XTOL, ftol=XTOL)
        z, msg = fit.x, fit.message
        h = z[gcols] * scale[gcols]
        J = res_fn.jac(z, gamma)
        cov = _cov_z(J.T @ J) * np.outer(scale, scale)
        Sig = cov[np.ix_(gcols, gcols)]
        S_eff = float(np.sum(np.diff(h) ** 2) + np.trace(D @ Sig @ D.T))
        new = float(table.mean_gamma(S_eff)) if laplace_em else float(
            table.mean_gamma(np.sum(np.diff(h) ** 2)))
        history.append((gamma, new, S_eff))
        done = abs(np.log(new / gamma)) < em_tol
        steps.append((np.log(gamma), np.log(new)))
        if done:
            gamma = new
            break
        gamma = _aitken(steps, table.lower, table.upper)
    else:
        gamma = new  # out of iterations: the last plain step, not an untried jump
    # Laplace at that gamma: Gauss-Newton of data + Gaussian priors + gamma D^T D (with
    # ``laplace_em``), else the exact Hessian of -log F at the marginal mode
    J = res_fn.jac(z, gamma if laplace_em else 0.0)
    if laplace_em:
        Pz = J.T @ J
    else:
        J = J[: -(gcols.size - 1)]
        Pz = J.T @ J
        h = z[gcols] * scale[gcols]
        Pz[np.ix_(gcols, gcols)] += table.hessian_h(h) * np.outer(scale[gcols], scale[gcols])
    e, V = np.linalg.eigh(0.5 * (Pz + Pz.T))
    e = np.maximum(e, 1e-10 * e.max())
    cov = ((V / e) @ V.T) * np.outer(scale, scale)
    prec = ((V * e) @ V.T) / np.outer(scale, scale)
    th = res_fn.theta(z)[0]
    th[gi] = gamma
    return MarginalMAP(theta=th, idx=idx, cov=0.5 * (cov + cov.T), precision=prec,
                       gamma_index=gi, hcols=idx[gcols], n_evals=res_fn.n_evals,
                       history=history, message=str(msg))


def _aitken(steps: list, lower: float, upper: float) -> float:
    """The next gamma of the EM fixed-point iteration ``u <- T(u)`` (``u = log gamma``).

    The plain iteration converges linearly and slowly (ratio ~0.84 per step on Case C: 33
    steps to 1e-3); after two plain steps ``u0 -> u1 -> u2`` (``steps`` holds the plain steps
    since the last jump) it jumps to Aitken's extrapolation
    ``u0 - (u1 - u0)^2 / (u2 - 2 u1 + u0)`` if that stays within a factor 10 of ``gamma(u2)``
    and inside ``(lower, upper)``, and starts over. Convergence is still judged by a plain
    step's change."""
    if len(steps) >= 2:
        (u0, u1), (_, u2) = steps[-2], steps[-1]
        den = u2 - 2.0 * u1 + u0
        if abs(den) > 1e-12:
            jump = u0 - (u1 - u0) ** 2 / den
            if abs(jump - u2) < np.log(10.0) and lower < np.exp(jump) < upper:
                steps.clear()
                return float(np.exp(jump))
    return float(np.exp(steps[-1][1]))


def _cov_z(P: np.ndarray) -> np.ndarray:
    e, V = np.linalg.eigh(0.5 * (P + P.T))
    e = np.maximum(e, 1e-10 * e.max())
    return (V / e) @ V.T
