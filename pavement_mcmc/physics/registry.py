"""Extensions by name: pick one by name, import one by ``module:Class``, or pass an instance."""

from __future__ import annotations

import importlib

from .base import Extension

_REGISTRY: dict[str, type[Extension]] = {}


def register_extension(cls: type[Extension]) -> type[Extension]:
    """Class decorator: make ``cls`` selectable by its ``name`` in configs and ``--add``."""
    if not (isinstance(cls, type) and issubclass(cls, Extension)):
        raise TypeError(f"{cls!r} is not an Extension subclass")
    if cls.name in _REGISTRY and _REGISTRY[cls.name] is not cls:
        raise ValueError(f"an extension named {cls.name!r} is already registered")
    _REGISTRY[cls.name] = cls
    return cls


def extension_names() -> list[str]:
    """Names of the registered extensions (the shipped catalogue is registered when
    :mod:`pavement_mcmc.physics` is imported)."""
    return sorted(_REGISTRY)


def candidate_names() -> list[str]:
    """Names of the registered extensions the criticism tries by default (``candidate``)."""
    return [n for n in extension_names() if _REGISTRY[n].candidate]


def get_extension(spec) -> Extension:
    """An :class:`Extension` instance from a name, a ``"module:Class"`` path, a class or an instance.

    Unknown names raise ``ValueError`` listing the valid ones.
    """
    if isinstance(spec, Extension):
        return spec
    if isinstance(spec, type) and issubclass(spec, Extension):
        return spec()
    if not isinstance(spec, str):
        raise TypeError(f"cannot make an extension from {spec!r}")
    if ":" in spec:
        mod, _, attr = spec.partition(":")
        try:
            cls = getattr(importlib.import_module(mod), attr)
        except (ImportError, AttributeError) as err:
            raise ValueError(f"cannot import extension {spec!r}: {err}") from None
        return get_extension(cls)
    names = extension_names()
    if spec not in _REGISTRY:
        raise ValueError(f"unknown extension {spec!r}; valid: {', '.join(names)} "
                         "(or 'module:Class' for your own)")
    return _REGISTRY[spec]()
