"""The one plugin loader: classes picked by name, by ``"module:Class"`` path, or given directly.

Every plug-in point of the package (physics extensions, samplers, the twin simulator's hidden
effects) keeps one :class:`Registry` of subclasses of its base class. It lives in the first
step of the pipeline so every later step, the independent twin simulator included, can use it
without importing anything downstream::

    widgets = Registry(Widget, "widget")
    widgets.register(MyWidget)              # or @widgets.register on the class
    widgets.get("mywidget"), widgets.get("my_pkg.mod:Other"), widgets.get(MyWidget)
"""

from __future__ import annotations

import importlib
from typing import Generic, TypeVar

T = TypeVar("T", bound=type)


class Registry(Generic[T]):
    """Subclasses of ``base`` by their ``name`` attribute.

    Parameters
    ----------
    base : the class every entry must subclass.
    kind : what an entry is called in messages ("extension", "sampler", ...).
    classes : the initial entries by name (the dict is kept and updated, not copied).
    """

    def __init__(self, base: type, kind: str, classes: dict[str, T] | None = None):
        self.base, self.kind = base, kind
        self.classes: dict[str, T] = {} if classes is None else classes

    def _check(self, cls, what) -> T:
        if not (isinstance(cls, type) and issubclass(cls, self.base)):
            raise ValueError(f"{what!r} is not a {self.base.__module__}.{self.base.__qualname__} "
                             "subclass")
        return cls

    def register(self, cls: T) -> T:
        """Class decorator: make ``cls`` selectable by its ``name``. A second class under a name
        already taken is refused (ValueError); re-registering the same class is a no-op."""
        if not (isinstance(cls, type) and issubclass(cls, self.base)):
            raise TypeError(f"{cls!r} is not a {self.base.__name__} subclass")
        if cls.name in self.classes and self.classes[cls.name] is not cls:
            raise ValueError(f"a {self.kind} named {cls.name!r} is already registered")
        self.classes[cls.name] = cls
        return cls

    def names(self) -> list[str]:
        """The registered names, sorted."""
        return sorted(self.classes)

    def __contains__(self, name) -> bool:
        return name in self.classes

    def get(self, spec) -> T:
        """The class for ``spec``: a registered name, a ``"module:Class"`` path or a subclass.

        An unknown name raises ``ValueError`` listing the valid ones; a path that cannot be
        imported or names no subclass of the base raises ``ValueError`` saying so.
        """
        if isinstance(spec, type):
            return self._check(spec, spec)
        if isinstance(spec, str) and ":" in spec:
            mod, _, attr = spec.partition(":")
            try:
                cls = getattr(importlib.import_module(mod), attr)
            except (ImportError, AttributeError) as err:
                raise ValueError(f"cannot import {self.kind} {spec!r}: {err}") from None
            return self._check(cls, spec)
        if isinstance(spec, str) and spec in self.classes:
            return self.classes[spec]
        raise ValueError(f"unknown {self.kind} {spec!r}; valid: {', '.join(self.names())} "
                         "(or 'module:Class' for your own)")
