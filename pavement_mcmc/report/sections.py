"""The registry of report sections (see the contract in :mod:`pavement_mcmc.report`)."""

from __future__ import annotations

from collections.abc import Callable

from ..runs.view import RunView

SectionBuilder = Callable[[object, RunView], "tuple[str, list] | None"]
_SECTIONS: list[tuple[float, int, str, SectionBuilder]] = []


def register_section(title: str, func: SectionBuilder | None = None, *, order: float = 100.0):
    """Add a report section ``func(problem, view) -> (html_fragment, [figures]) | None``.

    Usable as ``register_section("Title", func)`` or as a decorator
    ``@register_section("Title")``. Registering the same title again replaces the section.
    See the :mod:`pavement_mcmc.report` docstring for the contract.
    """

    def add(f: SectionBuilder) -> SectionBuilder:
        unregister_section(title)
        _SECTIONS.append((float(order), len(_SECTIONS), title, f))
        return f

    return add if func is None else add(func)


def unregister_section(title: str) -> None:
    """Remove the section ``title`` if registered."""
    _SECTIONS[:] = [s for s in _SECTIONS if s[2] != title]


def registered_sections() -> list[tuple[str, SectionBuilder]]:
    """``(title, builder)`` of the registered sections, in report order."""
    return [(t, f) for _, _, t, f in sorted(_SECTIONS, key=lambda s: (s[0], s[1]))]


def _register_builtin_sections() -> None:
    from .criticism import TITLE, criticism_section
    from .energy import TITLE as ENERGY_TITLE
    from .energy import energy_section

    register_section(TITLE, criticism_section, order=50)
    register_section(ENERGY_TITLE, energy_section, order=40)


_register_builtin_sections()
