"""Physics: the base conduction model and the catalogue of extensions (effects it may miss)."""

from . import catalogue  # noqa: F401  (registers the shipped extensions)
from .base import Extension
from .hbasis import HBasis
from .model import LITERATURE, Model
from .registry import candidate_names, extension_names, get_extension, register_extension

__all__ = [
    "Extension", "HBasis", "LITERATURE", "Model",
    "candidate_names", "extension_names", "get_extension", "register_extension",
]
