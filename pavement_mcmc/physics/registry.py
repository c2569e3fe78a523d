"""Extensions by name: pick one by name, import one by ``module:Class``, or pass an instance
(the package's one plugin loader, :class:`~pavement_mcmc.data.plugins.Registry`)."""

from __future__ import annotations

from ..data.plugins import Registry
from .base import Extension

_EXTENSIONS: Registry[type[Extension]] = Registry(Extension, "extension")


def register_extension(cls: type[Extension]) -> type[Extension]:
    """Class decorator: make ``cls`` selectable by its ``name`` in configs and ``--add``."""
    return _EXTENSIONS.register(cls)


def extension_names() -> list[str]:
    """Names of the registered extensions (the shipped catalogue is registered when
    :mod:`pavement_mcmc.physics` is imported)."""
    return _EXTENSIONS.names()


def candidate_names() -> list[str]:
    """Names of the registered extensions the criticism tries by default (``candidate``)."""
    return [n for n in extension_names() if _EXTENSIONS.get(n).candidate]


def get_extension(spec) -> Extension:
    """An :class:`Extension` instance from a name, a ``"module:Class"`` path, a class or an instance.

    Unknown names raise ``ValueError`` listing the valid ones.
    """
    if isinstance(spec, Extension):
        return spec
    if not isinstance(spec, str | type):
        raise TypeError(f"cannot make an extension from {spec!r}")
    return _EXTENSIONS.get(spec)()
