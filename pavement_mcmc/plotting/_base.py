"""Shared helpers of the plotting package: figure creation, labels and units for display."""

from __future__ import annotations

import re

import numpy as np
from matplotlib.figure import Figure

#: parameter -> (factor applied before display, axis label with units)
_DISPLAY = {
    "kappa": (1.0, "κ (W m⁻¹ K⁻¹)"),
    "C": (1e-6, "C (MJ m⁻³ K⁻¹)"),
    "gamma": (1.0, "γ (m⁴ K² W⁻²)"),
    "kappa2": (1.0, "κ₂ (W m⁻¹ K⁻¹)"),
    "C2": (1e-6, "C₂ (MJ m⁻³ K⁻¹)"),
    "d_layer": (100.0, "top layer thickness (cm)"),
    "h_a": (1.0, "h_a (W m⁻² K⁻¹)"),
    "h_b": (1.0, "h_b (J m⁻³ K⁻¹)"),
}
_H_RE = re.compile(r"^h_(\d+)$")

#: colours of the sensors (cycled), measured vs predicted share the colour
SENSOR_COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2"]


def new_figure(fig: Figure | None, figsize: tuple[float, float]) -> Figure:
    """Return ``fig`` cleared (if given) or a new :class:`Figure` of ``figsize`` inches.

    No pyplot state is used: the figure is not registered with any GUI manager.
    """
    if fig is None:
        return Figure(figsize=figsize, layout="constrained")
    fig.clear()
    return fig


def display(name: str, unit: str = "") -> tuple[float, str]:
    """Scale factor and axis label (with units) of parameter ``name``."""
    if name in _DISPLAY:
        return _DISPLAY[name]
    m = _H_RE.match(name)
    if m:
        return 1.0, f"h{_sub(m.group(1))} (W m⁻² K⁻¹)"
    return 1.0, f"{name} ({unit})" if unit else name


def _sub(digits: str) -> str:
    return digits.translate(str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉"))


def default_selection(names: list[str], n_h: int = 4) -> list[str]:
    """Every non-h parameter plus ``n_h`` evenly spaced h pieces (all of them if few)."""
    hs = [n for n in names if _H_RE.match(n)]
    others = [n for n in names if not _H_RE.match(n)]
    if len(hs) <= n_h + 1:
        return others + hs
    idx = np.unique(np.linspace(0, len(hs) - 1, n_h).round().astype(int))
    return others + [hs[i] for i in idx]


def select(names: list[str], subset: list[str] | None) -> list[int]:
    """Indices of ``subset`` in ``names`` (all if None); unknown names raise ``ValueError``."""
    if subset is None:
        return list(range(len(names)))
    missing = [s for s in subset if s not in names]
    if missing:
        raise ValueError(f"unknown parameter(s) {missing}; valid: {', '.join(names)}")
    return [names.index(s) for s in subset]


def hours(t: np.ndarray) -> np.ndarray:
    """Seconds -> hours."""
    return np.asarray(t, float) / 3600.0


def time_label(time0: str | None = None) -> str:
    return f"time since {time0} (h)" if time0 else "time (h)"
