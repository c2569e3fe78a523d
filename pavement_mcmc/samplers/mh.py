r"""The paper's random-walk Metropolis–Hastings, many independent chains stepped together.

Proposal (per parameter, independent uniforms):

.. math:: P^* = P + s\,\omega \odot U(-1, 1),

with :math:`\omega_i` the scale of parameter ``i`` (the Laplace sd when a MAP is available, else
the prior sd or 1 % of the value) times :math:`\sqrt3 \cdot 2.38/\sqrt d` (a uniform step of
the same variance as the classic optimal Gaussian step), and :math:`s` a global factor. During
burn-in only, :math:`\log s` follows a Robbins–Monro recursion towards the target acceptance
(default 0.25: the optimal rate of a random walk in d >= 5 dimensions, Roberts, Gelman & Gilks
1997; the paper's ~70 % comes from too small steps); afterwards it is frozen, so the kept chain
is a valid (non-adaptive) MH chain. Randomness: one :class:`numpy.random.Generator`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import Block, Sampler, start_points


@dataclass(frozen=True)
class MHOptions:
    """Options of the ``mh`` sampler.

    target_acceptance : acceptance rate the burn-in tunes ``s`` towards.
    proposal_scale : initial global factor ``s`` (default 1).
    """

    target_acceptance: float = 0.25
    proposal_scale: float | None = None


class MHSampler(Sampler):
    """Random-walk MH with uniform steps (paper parity); the Laplace sds, when given to
    :meth:`prepare`, set the step sizes and start points."""

    name = "mh"
    adaptive = True
    Options = MHOptions

    @staticmethod
    def default_chains(ndim: int) -> int:
        return 32

    def adapt_length(self) -> int:
        return max(2000, 50 * self.ndim)

    def prepare(self, theta0=None, laplace=None) -> None:
        self.theta, sd = start_points(self, theta0, laplace)
        self.logp, self.blobs = self.evaluate(self.theta)
        self.n_prep_evals += self.n_chains
        self.omega = np.sqrt(3.0) * 2.38 / np.sqrt(self.ndim) * sd
        self.log_s = float(np.log(self.options.proposal_scale or 1.0))
        self.k_adapt = 0

    def step(self, n_steps: int, adapt: bool = False) -> Block:
        target = self.options.target_acceptance
        rows = []
        m, d = self.theta.shape
        for _ in range(n_steps):
            u = self.rng.uniform(-1.0, 1.0, size=(m, d))
            prop = self.theta + np.exp(self.log_s) * self.omega * u
            lp, bl = self.evaluate(prop)
            logu = np.log(self.rng.uniform(size=m))
            acc = logu < lp - self.logp
            self.theta = np.where(acc[:, None], prop, self.theta)
            self.logp = np.where(acc, lp, self.logp)
            self.blobs = np.where(acc[:, None], bl, self.blobs)
            if adapt:
                self.k_adapt += 1
                self.log_s += (acc.mean() - target) / (1.0 + self.k_adapt) ** 0.6 * 2.0
            rows.append((self.theta.copy(), self.logp.copy(), self.blobs.copy(), acc, m))
        return Block.stack(rows)

    def _extra_state(self):
        return {"log_s": self.log_s, "k_adapt": self.k_adapt}, {"omega": self.omega}

    def _load_extra_state(self, extra, arrays):
        self.log_s = float(extra["log_s"])
        self.k_adapt = int(extra["k_adapt"])
        self.omega = np.array(arrays["omega"])
