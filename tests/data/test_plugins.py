"""The one plugin loader (:class:`pavement_mcmc.data.plugins.Registry`) that physics extensions
and samplers are picked through: by name, by ``module:Class``, refusing what is not a plug-in."""

from __future__ import annotations

import sys
import types

import pytest

from pavement_mcmc.data.plugins import Registry
from pavement_mcmc.physics import Extension, get_extension
from pavement_mcmc.samplers import MHSampler, sampler_class


class Base:
    name = "base"


class One(Base):
    name = "one"


def test_by_name_path_and_class(monkeypatch):
    reg = Registry(Base, "widget")
    assert reg.register(One) is One and reg.register(One) is One  # idempotent
    mod = types.ModuleType("my_widgets")
    mod.One, mod.Other = One, int
    monkeypatch.setitem(sys.modules, "my_widgets", mod)
    assert reg.get("one") is reg.get("my_widgets:One") is reg.get(One) is One
    with pytest.raises(ValueError, match=r"unknown widget 'two'; valid: one \(or 'module:Class'"):
        reg.get("two")
    with pytest.raises(ValueError, match="cannot import widget 'my_widgets:Nope'"):
        reg.get("my_widgets:Nope")
    with pytest.raises(ValueError, match="'my_widgets:Other' is not a .*Base subclass"):
        reg.get("my_widgets:Other")

    class Clash(Base):
        name = "one"

    with pytest.raises(ValueError, match="a widget named 'one' is already registered"):
        reg.register(Clash)
    with pytest.raises(TypeError, match="is not a Base subclass"):
        reg.register(int)


def test_extensions_and_samplers_refuse_a_path_to_the_wrong_kind(monkeypatch):
    """A ``module:Class`` path to a sampler given where an extension is expected (and back) is a
    user error naming the base class, not a TypeError from deep inside."""
    mod = types.ModuleType("my_plugins")
    mod.Mine = MHSampler
    mod.Ext = type("Ext", (Extension,), {"name": "ext_of_mine"})
    monkeypatch.setitem(sys.modules, "my_plugins", mod)
    with pytest.raises(ValueError, match="is not a pavement_mcmc.physics.base.Extension subclass"):
        get_extension("my_plugins:Mine")
    with pytest.raises(ValueError, match="is not a pavement_mcmc.samplers.base.Sampler subclass"):
        sampler_class("my_plugins:Ext")
    assert isinstance(get_extension("my_plugins:Ext"), mod.Ext)
    assert sampler_class("my_plugins:Mine") is MHSampler
