"""Corner plot of the posterior (with the ``corner`` package)."""

from __future__ import annotations

import warnings

import numpy as np
from matplotlib.figure import Figure

from ._base import default_selection, display, select

__all__ = ["plot_corner"]


def plot_corner(
    samples: np.ndarray,
    names: list[str],
    subset: list[str] | None = None,
    truths: dict[str, float] | None = None,
    fig: Figure | None = None,
) -> Figure:
    """Corner plot of posterior draws.

    Parameters
    ----------
    samples : (n_draws, n_params) flat posterior draws (after burn-in).
    names : parameter names (columns of ``samples``).
    subset : names to show; default every non-h parameter plus four evenly spaced h pieces
        (for Case C: kappa, C, gamma and a handful of h values).
    truths : optional true values by name (drawn where known).
    fig : an empty figure (or one with exactly ``k*k`` axes) or None.

    Returns
    -------
    Figure
    """
    with warnings.catch_warnings():  # corner imports arviz if installed; arviz 0.2x warns
        warnings.simplefilter("ignore", FutureWarning)
        import corner

    samples = np.asarray(samples, float)
    subset = default_selection(list(names)) if subset is None else list(subset)
    idx = select(list(names), subset)
    scale = np.array([display(names[j])[0] for j in idx])
    labels = [display(names[j])[1] for j in idx]
    data = samples[:, idx] * scale
    tr = None
    if truths:
        tr = [truths[names[j]] * s if names[j] in truths else None for j, s in zip(idx, scale)]
        if all(v is None for v in tr):
            tr = None
    k = len(idx)
    outside = []
    if tr is not None:
        for i, v in enumerate(tr):
            if v is not None and not data[:, i].min() <= v <= data[:, i].max():
                outside.append(names[idx[i]])
    if fig is None:
        fig = Figure(figsize=(max(2.0 * k, 4), max(2.0 * k, 4)))
    elif fig.axes and len(fig.axes) != k * k:
        fig.clear()
    fig = corner.corner(
        data, labels=labels, truths=tr, truth_color="C3", fig=fig, quantiles=[0.025, 0.5, 0.975],
        show_titles=True, title_fmt=".3g", title_kwargs={"fontsize": 8},
        titles=[lab.split(" (")[0] for lab in labels],
        label_kwargs={"fontsize": 8}, plot_datapoints=data.shape[0] < 4000,
    )
    handles = [fig.axes[0].plot([], [], color="k", label="posterior (2.5, 50, 97.5 %)")[0]]
    if tr is not None:
        note = f" (outside the axes: {', '.join(outside)})" if outside else ""
        handles.append(fig.axes[0].plot([], [], color="C3", label="truth" + note)[0])
    fig.legend(handles=handles, loc="upper right", fontsize=9)
    return fig
