r"""A scale move of h's rough part on the gamma-marginal target (Case C): one solve, no gradient.

On Case C ``hmc``'s stopping rule waits for gamma: drawn exactly given h, its chain follows the
roughness :math:`S = \lVert Dh\rVert^2`, which the Hamiltonian trajectories move slowly (a
slow random walk of the log-density's level along the "scale" of h's high-frequency part;
longer trajectories do not help). This move changes that scale directly.

In the orthonormal DCT-II basis :math:`B` (the eigenvectors of :math:`D^TD`, eigenvalues
:math:`\lambda_k = 2 - 2\cos(\pi k/N)`, so that :math:`S = \sum_k \lambda_k c_k^2` with
:math:`c = B^T h`), the *rough* modes :math:`R` are those above a cut, ``k >= cut N``
(``hmc``'s option ``rough_cut``): at the posterior they are close to their GMRF prior (the data
inform the slow part of h), and they carry most of :math:`S` in the posterior (at the smooth
MAP only a fifth of it on Case C). With :math:`P = B_R B_R^T` the proposal is

.. math:: h' = h + (e^{\varepsilon} - 1) P h, \qquad \varepsilon \sim N(0, s^2),

a bijection for each :math:`\varepsilon` whose inverse is the same map at :math:`-\varepsilon`,
with Jacobian :math:`e^{|R|\varepsilon}`; so (Green 1995) the Metropolis ratio on the marginal
target (:class:`.target.MarginalTarget`) is

.. math:: \log a = \Delta\log L + \Delta\log F(S) + \Delta \textstyle\sum_i\log\pi_i(h_i)
          + |R|\,\varepsilon .

Proposals outside the bounds (an h below 0) are rejected without a solve. ``s`` is tuned
during adaptation towards an acceptance of :data:`TARGET_ACCEPTANCE` (a one-dimensional
random walk's), then frozen; ``hmc`` drops the move if ``s`` ends below :data:`MIN_STEP`
(night-time h piled against 0 make a scale of the rough part leave the bounds).
"""

from __future__ import annotations

import numpy as np

#: acceptance the step ``s`` is tuned towards
TARGET_ACCEPTANCE = 0.44
#: a tuned ``s`` below this changes S by a few per cent a move: not worth its solves (Case C
#: tunes 0.17-0.19; the Göttingen window, with 65 of 144 h piled at 0, 0.007)
MIN_STEP = 0.05


def dct_basis(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The orthonormal DCT-II basis ``B`` (n, n), column ``k`` the mode ``k``, and the
    eigenvalues ``2 - 2 cos(pi k / n)`` of ``D^T D`` (D the first-difference matrix) it
    diagonalises."""
    j, k = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    B = np.sqrt(2.0 / n) * np.cos(np.pi * k * (j + 0.5) / n)
    B[:, 0] = 1.0 / np.sqrt(n)
    return B, 2.0 - 2.0 * np.cos(np.pi * np.arange(n) / n)


class RoughScale:
    """The scale move of the rough modes (see the module docstring).

    Parameters
    ----------
    rough : (n,) bool, the rough modes.
    step : the initial ``s``.
    """

    def __init__(self, rough: np.ndarray, step: float = 0.1):
        self.modes = rough = np.asarray(rough, bool)
        B = dct_basis(rough.size)[0][:, rough]
        self.P = B @ B.T
        self.n_rough = int(rough.sum())
        self.log_step = float(np.log(step))
        self.k = 0

    @classmethod
    def above(cls, n: int, cut: float) -> RoughScale:
        """The move of the modes ``k >= cut n`` of ``n`` values of h (``0 < cut < 1``)."""
        return cls(np.arange(n) >= max(1, int(np.ceil(cut * n))))

    def state(self) -> tuple[list, np.ndarray]:
        """``([log s, adaptation steps], modes as floats)`` for the run state."""
        return [self.log_step, self.k], self.modes.astype(float)

    @classmethod
    def restored(cls, scalars, modes) -> RoughScale:
        """The move of a saved :meth:`state`."""
        self = cls(np.asarray(modes) > 0.5)
        self.log_step, self.k = float(scalars[0]), int(scalars[1])
        return self

    def propose(self, rng: np.random.Generator, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Proposals ``H'`` (m, n) from ``H`` (m, n) and their log Jacobians (m,)."""
        eps = np.exp(self.log_step) * rng.standard_normal(H.shape[0])
        return H + np.expm1(eps)[:, None] * (H @ self.P), self.n_rough * eps

    def useful(self) -> bool:
        """Whether the tuned step is at least :data:`MIN_STEP`."""
        return bool(np.exp(self.log_step) >= MIN_STEP)

    def adapt(self, accept_rate: float) -> None:
        """Robbins–Monro on ``log s`` towards :data:`TARGET_ACCEPTANCE`."""
        self.k += 1
        self.log_step += (accept_rate - TARGET_ACCEPTANCE) / np.sqrt(self.k)


def scale_moves(move: RoughScale, rng: np.random.Generator, target, theta: np.ndarray,
                loglik: np.ndarray, blobs: np.ndarray, n_moves: int, adapt: bool):
    """``n_moves`` scale moves of every chain on the marginal target.

    Parameters
    ----------
    move : the :class:`RoughScale`; target : the :class:`.target.MarginalTarget`.
    theta, loglik, blobs : the chains' full rows (m, n_free), log-likelihoods and blobs.

    Returns
    -------
    (theta, loglik, blobs, moved, n_solved) : new arrays, the chains that moved, the solves.
    """
    theta, loglik, blobs = theta.copy(), loglik.copy(), blobs.copy()
    hc = target.hcols
    lo, hi = target.lo[hc], target.hi[hc]
    moved = np.zeros(theta.shape[0], bool)
    n_solved = 0
    lp = target.uni_logp(theta) + target.log_prior_h(theta)  # the current log-prior
    for _ in range(n_moves):
        hp, log_jac = move.propose(rng, theta[:, hc])
        prop = theta.copy()
        prop[:, hc] = hp
        inside = np.all((hp >= lo) & (hp <= hi), axis=1)
        ll, bl, uni, n = target.score(prop, inside, blobs, None)
        n_solved += n
        lp_p = uni + target.log_prior_h(prop)
        with np.errstate(invalid="ignore"):
            log_a = ll + lp_p + log_jac - loglik - lp
        acc = inside & (np.log(rng.uniform(size=theta.shape[0])) < log_a)
        theta[acc], loglik[acc], blobs[acc], lp[acc] = prop[acc], ll[acc], bl[acc], lp_p[acc]
        moved |= acc
        if adapt:
            move.adapt(float(np.mean(np.exp(np.minimum(np.nan_to_num(log_a, nan=-np.inf), 0.0)))))
    return theta, loglik, blobs, moved, n_solved
