"""The log-likelihood gradient of a plain model without the generic path's glue (``hmc``'s hot
loop on Case C).

A *plain* model has no extension, a Robin top (no measured top), an h(t) of its own pieces, and
the buried sensors' temperatures as its only stream, on the compiled path (``sigma``, nominal
depths). Its gradient is :meth:`.logpost.LogPosterior.loglik_and_grad` →
:meth:`.Model.solve_vjp` → :func:`pavement_mcmc.solver.adjoint.solve_vjp` with every generic
step known in advance: no surface hook, no finite differences, no other stream, one layout. This
module runs the same steps with the same functions on arrays of the same layout (so the numbers
are the same to the bit: ``tests/posterior/test_plain_gradient.py``), keeping per number of sets
what does not change between calls (the kernels' forcing, ``q``, the work buffers).

Measured on Case C (16 sets, ``benchmarks/bench_gradient.py``): see docs/VALIDATION.md §9.
Anything else, and any set the solver's checks would refuse (not finite, kappa or C <= 0), goes
the generic way (:meth:`PlainGradient.__call__` returns None).
"""

from __future__ import annotations

import numpy as np

from ..solver import adjoint as _adj
from ..solver import forward as _fwd
from ..solver.kernels import adjoint as _K


class PlainGradient:
    """``(ll, G, rmse)`` of a plain model (see the module docstring), ``G`` (n_sets, 2 + K)
    the gradient in ``kappa``, ``C`` and the K pieces of h, as :meth:`.Model.solve_vjp` gives it."""

    names: list[str]

    def __init__(self, model, temps):
        self.model, self.temps = model, temps
        self.names = ["kappa", "C", *model.h_basis.names]
        self._work: dict[int, tuple] = {}

    @staticmethod
    def applies(model) -> bool:
        """Whether ``model`` is plain (the stream's own condition is checked per call)."""
        return (not model.extensions and not model.replaces_h and not model.top_measured
                and not model.plates and model.has_gradient and model.scheme == "cn"
                and getattr(model.forcing, "T_top", None) is None)

    def _workspace(self, kappa, C, h):
        """Per number of sets: the kernels' problem (its forcing, ``q`` and geometry), the
        adjoint's state store and block, and ``q`` as the solver's coefficients hold it."""
        S = kappa.shape[0]
        ws = self._work.get(S)
        if ws is None:
            m = self.model
            q = np.broadcast_to(m.meas.q_net, (S, m.meas.n_obs)).copy()
            P0 = _fwd._problem(m.grid, m.forcing, kappa, C, h, q, None, 20.0, False)
            n_slots = _adj._n_slots(m.grid, P0)
            N = kappa.shape[1]
            if (8 * S * n_slots * N > _adj._STORE_MAX or S <= _fwd._SCALAR_MAX
                    or not _fwd._all_finite(q)):
                ws = False  # recomputed intervals or the scalar kernels: the generic path
            else:
                parallel = _fwd._parallel(S, m.grid)
                ws = (P0, q, n_slots, parallel, _fwd._block(S, parallel))
            self._work[S] = ws
        return ws

    def __call__(self, p: dict):
        m, temps = self.model, self.temps
        if not temps.compiled_applies(m):
            return None
        kappa1, C1 = np.asarray(p["kappa"], float), np.asarray(p["C"], float)
        n = m.grid.x.size
        if kappa1.ndim != 1 or C1.shape != kappa1.shape:
            return None
        h = m.h_basis.evaluate(p)
        # Model.coefficients' arrays, then solver._check's refusals (the generic path raises)
        kappa = np.repeat(kappa1[:, None], n - 1, axis=1)
        C = np.repeat(C1[:, None], n, axis=1)
        if not (_fwd._all_finite(kappa1) and _fwd._all_finite(C1) and _fwd._all_finite(h)
                and kappa1.min() > 0 and C1.min() > 0):  # (their repeats: the same values)
            return None
        ws = self._workspace(kappa, C, h)
        if not ws:
            return None
        P0, q, n_slots, parallel, block = ws
        S, N = kappa.shape
        P = P0._replace(kappaT=np.ascontiguousarray(kappa.T), CT=np.ascontiguousarray(C.T),
                        hT=np.ascontiguousarray(h.T))
        buf = np.empty(S * n_slots * N)
        outT = np.empty((m.grid.n_obs, N + 1, S))
        (_K.fwd_parallel if parallel else _K.fwd_serial)(P, block, outT, buf)
        out = outT.transpose(2, 0, 1)
        ll, rmse, G = temps.compiled_terms(m, out, True)
        if not _fwd._all_finite(G):
            return None
        acc = (np.empty((N, S)), np.empty((N, S)), np.empty((m.grid.n_obs - 1, S)),
               np.empty((m.grid.n_obs, S)))
        (_K.vjp_parallel if parallel else _K.vjp_serial)(P, outT, G, True, buf, block, acc)
        g = _adj._gradients(m.grid, kappa, C, h, q, *(a.T for a in acc))
        h_block = m.h_basis.grad(g["h"])
        out_g = np.empty((S, 2 + h_block.shape[1]))
        out_g[:, 0] = g["kappa"].sum(axis=1)
        out_g[:, 1] = g["C"][:, :-1].sum(axis=1)
        out_g[:, 2:] = h_block
        return ll, out_g, rmse
