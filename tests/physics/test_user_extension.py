"""The README's user-extension example, extracted from README.md and run as written."""

from __future__ import annotations

import re
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.data import load_case
from pavement_mcmc.parameters import Parameter
from pavement_mcmc.physics import extension_names, get_extension
from pavement_mcmc.posterior import build_problem

README = Path(__file__).resolve().parents[2] / "README.md"


def _readme_example() -> types.ModuleType:
    """Execute the README's extension example (the python block defining ShadedSurface)."""
    text = README.read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    code = next(b for b in blocks if "class ShadedSurface(Extension)" in b)
    mod = types.ModuleType("my_effects")
    exec(compile(code, str(README), "exec"), mod.__dict__)
    return mod


ShadedSurface = _readme_example().ShadedSurface


@pytest.fixture(scope="module")
def cfg():
    return load_case(README.parent / "runs" / "hidden.toml")


@pytest.fixture(scope="module")
def module_with_class():
    mod = types.ModuleType("my_effects")
    mod.ShadedSurface = ShadedSurface
    sys.modules["my_effects"] = mod
    yield "my_effects:ShadedSurface"
    del sys.modules["my_effects"]


def test_instance_and_module_path(cfg, module_with_class):
    for spec in (ShadedSurface(), ShadedSurface, module_with_class):
        pb = build_problem(cfg, extensions=[spec])
        assert "shade" in pb.space.free
        theta = pb.space.initial()
        T0 = pb.posterior.predict(theta[None, :])
        theta2 = theta.copy()
        theta2[pb.space.free.index("shade")] = 0.5
        T1 = pb.posterior.predict(theta2[None, :])
        assert np.all(T1[0, :, 0] <= T0[0, :, 0] + 1e-9)  # shade cools the surface
        assert np.max(T0 - T1) > 0.5


def test_unknown_name_lists_valid(cfg):
    with pytest.raises(ValueError) as err:
        get_extension("two_layers")
    for name in extension_names():
        assert name in str(err.value)


def test_name_clash_refused(cfg):
    class Clash(ShadedSurface):
        name = "clash"

        def parameters(self, meas):
            return [Parameter("kappa2", 1.0, 0.1, 5.0)]

    with pytest.raises(ValueError, match="kappa2"):
        build_problem(cfg, extensions=["two_layer", Clash()])
    with pytest.raises(ValueError, match="listed twice"):
        build_problem(cfg, extensions=[ShadedSurface(), ShadedSurface()])


def test_user_extension_is_a_candidate(cfg):
    from pavement_mcmc.criticism import rank_missing_effects, refit

    pb = build_problem(cfg)
    rk = rank_missing_effects(
        pb, refit(pb).values(), candidates=[ShadedSurface(), "two_layer"], holdout=False
    )
    names = [e.name for e in rk.entries]
    assert set(names) == {"shaded_surface", "two_layer"}
    assert rk.best is not None and rk.best.name == "two_layer"
