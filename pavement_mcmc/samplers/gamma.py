r"""The exact draw of the smoothness precision gamma from its full conditional (no solve).

With the first-order GMRF prior on h and a Rayleigh hyperprior,

.. math:: \pi(\gamma \mid h) \propto \gamma^{(N-1)/2} e^{-\gamma \lVert Dh\rVert^2/2}\,
          \gamma\, e^{-(\gamma/\gamma_0)^2/2},

drawn by rejection (vectorised over chains) from the envelope Gamma(shape (N+3)/2,
rate ||Dh||^2/2 + gamma*/gamma_0^2), gamma* the target's mode, accepted with probability
exp(-(gamma - gamma*)^2 / (2 gamma_0^2)); for a flat hyperprior the Gamma draw is exact; for
another hyperprior, ten random-walk MH steps on log gamma. Used by the samplers that integrate
gamma out of their moves (``fast``'s moves, ``hmc``) after every step.
"""

from __future__ import annotations

import numpy as np

from ..parameters.priors import Flat, Rayleigh


def draw_gamma(rng: np.random.Generator, space, theta: np.ndarray, gi: int,
               hcols: np.ndarray) -> np.ndarray:
    """``(n_chains,)`` draws of gamma | h (see the module docstring).

    Parameters
    ----------
    rng : the sampler's Generator.
    space : the :class:`~pavement_mcmc.parameters.ParameterSpace` (gamma's prior and bounds).
    theta : (n_chains, n_free) current positions; ``gi`` gamma's column, ``hcols`` the h columns.
    """
    name = space.free[gi]
    prior, lo, hi = space[name].prior, space[name].lower, space[name].upper
    h = theta[:, hcols]
    S = np.sum(np.diff(h, axis=1) ** 2, axis=1)
    N = hcols.size
    m = theta.shape[0]
    if isinstance(prior, Rayleigh | Flat):
        shape = 0.5 * (N - 1) + (2.0 if isinstance(prior, Rayleigh) else 1.0)
        b = 0.5 * S
        if isinstance(prior, Rayleigh):
            # envelope Gamma(shape, b + mode/g0^2) has the target's mode; accept with
            # exp(-(g - mode)^2 / (2 g0^2)) (<= 1 by completing the square)
            q = 1.0 / prior.scale**2
            mode = (-b + np.sqrt(b * b + 4.0 * (shape - 1.0) * q)) / (2.0 * q)
            rate = b + mode * q
        else:
            rate = b
        out = np.empty(m)
        todo = np.arange(m)
        for _ in range(10_000):
            g = rng.gamma(shape, 1.0 / rate[todo])
            ok = (g > lo) & (g < hi)
            if isinstance(prior, Rayleigh):
                u = rng.uniform(size=todo.size)
                ok &= u < np.exp(-0.5 * q * (g - mode[todo]) ** 2)
            out[todo[ok]] = g[ok]
            todo = todo[~ok]
            if todo.size == 0:
                return out
        raise RuntimeError("gamma rejection sampler did not finish")
    g = theta[:, gi].copy()

    def f(x):
        with np.errstate(divide="ignore", invalid="ignore"):
            val = 0.5 * (N - 1) * np.log(x) - 0.5 * x * S + prior.logpdf(x) + np.log(x)
        return np.where((x > lo) & (x < hi), val, -np.inf)

    fg = f(g)
    for _ in range(10):
        prop = g * np.exp(0.3 * rng.standard_normal(m))
        fp = f(prop)
        acc = np.log(rng.uniform(size=m)) < fp - fg
        g, fg = np.where(acc, prop, g), np.where(acc, fp, fg)
    return g
