"""Where MAP fits start: :meth:`ParameterSpace.start_vector` and the one multi-start rule
(:mod:`pavement_mcmc.posterior.starts`) shared by ``fit --add`` and the criticism's refits."""

from __future__ import annotations

import numpy as np

from pavement_mcmc.parameters import Parameter
from pavement_mcmc.parameters.space import ParameterSpace
from pavement_mcmc.posterior.starts import best_start, extension_starts


def test_start_vector_takes_finite_values_by_name_inside_the_bounds():
    space = ParameterSpace([Parameter("a", 1.0, 0.0, 10.0), Parameter("b", 2.0, -np.inf, np.inf),
                            Parameter("c", 3.0, 0.0, 4.0), Parameter("d", 5.0, vary=False)])
    x = space.start_vector({"a": 20.0, "b": np.nan, "c": 0.0, "d": 9.0, "zz": 1.0})
    np.testing.assert_allclose(x, [10.0 - 1e-5, 2.0, 4e-6], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(space.start_vector(None), [1.0, 2.0, 3.0])


class _Ext:
    def __init__(self, null, starts):
        self._null, self._starts = null, starts

    def null_values(self, meas):
        return self._null

    def start_values(self, meas, values):
        assert values == {"k": 1.0, "x": 0.0}  # proposed from the base fit, not a combination
        return self._starts


def test_extension_starts_combine_every_proposal_over_the_null_values():
    base = {"k": 1.0, "x": 0.0}
    one = _Ext({"x": 5.0, "y": 0.0}, [{"y": 1.0}, {"y": 2.0}])
    two = _Ext(None, None)  # proposes nothing: one start, at its null values (none here)
    three = _Ext({"z": 0.0}, [{"z": -1.0}, {"z": 1.0}])
    starts = extension_starts([one, two, three], None, base)
    assert starts == [{"k": 1.0, "x": 5.0, "y": y, "z": z} for y in (1.0, 2.0) for z in (-1.0, 1.0)]
    assert extension_starts([], None, base) == [base]


def test_best_start_keeps_the_first_of_the_best():
    fits = best_start(lambda s: (s["i"], s["score"]), [{"i": i, "score": v} for i, v in
                                                       enumerate([1.0, 3.0, np.nan, 3.0, 2.0])],
                      score=lambda f: f[1])
    assert fits == (1, 3.0)
