"""Every figure returns a Figure with labelled axes (units) and legends."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from pavement_mcmc import plotting as pl
from pavement_mcmc.analysis.sensitivity import identifiability, reduced_sensitivity
from pavement_mcmc.analysis.urban import compare
from pavement_mcmc.data import load_case
from pavement_mcmc.parameters import parameter_values
from pavement_mcmc.posterior import build_problem

REPO = Path(__file__).resolve().parents[2]
NAMES = ["kappa", "C", "gamma", "h_1", "h_2", "h_3", "h_4", "h_5", "h_6", "h_7"]


@pytest.fixture(scope="module")
def problem():
    return build_problem(load_case(REPO / "runs" / "caseA.toml"))


@pytest.fixture(scope="module")
def chain():
    """AR(1) walkers around plausible values, (n_steps, n_chains, n_params)."""
    rng = np.random.default_rng(1)
    n, m, p = 400, 8, len(NAMES)
    x = np.zeros((n, m, p))
    for i in range(1, n):
        x[i] = 0.8 * x[i - 1] + rng.normal(size=(m, p))
    centre = np.array([1.3, 1.0e6, 2.0] + [10.0] * 7)
    scale = np.array([0.02, 2e4, 0.3] + [1.0] * 7)
    return centre + scale * x


def _labelled(fig: Figure, need_legend: bool = True):
    axes = [ax for ax in fig.axes if ax.get_visible() and ax.axison]
    assert axes
    for ax in axes:
        if ax.has_data():
            assert ax.get_ylabel() or ax.get_xlabel(), ax
    if need_legend:
        assert any(ax.get_legend() is not None for ax in fig.axes) or fig.legends


def test_chain_figures(chain):
    f = pl.plot_chains(chain, NAMES, burn_in=50, subset=["kappa", "C", "h_3"],
                       truths={"kappa": 1.31})
    assert isinstance(f, Figure)
    _labelled(f)
    assert f.axes[0].get_ylabel().startswith("κ (W m⁻¹ K⁻¹)")
    assert f.axes[2].get_ylabel().startswith("C (MJ")
    f = pl.plot_logp(chain[:, :, 0] * -100, burn_in=50)
    assert f.axes[0].get_xlabel() == "step" and "log posterior" in f.axes[0].get_ylabel()
    _labelled(f)
    acc = np.random.default_rng(0).random((400, 8)) < 0.3
    f = pl.plot_acceptance(acc, burn_in=50)
    assert f.axes[0].get_ylabel() == "acceptance fraction"
    _labelled(f)
    f = pl.plot_autocovariance(chain[50:], tau=5.0)
    assert f.axes[0].get_xlabel() == "lag (steps)"
    _labelled(f)
    f = pl.plot_geweke(chain[50:], NAMES, subset=["kappa", "C"])
    _labelled(f)
    f = pl.plot_segments(chain[50:], NAMES, subset=["kappa", "C", "gamma"])
    _labelled(f)
    assert f.axes[0].get_xlabel() == "segment (early → late)"


def test_corner_default_subset_and_reuse(chain):
    flat = chain[50:].reshape(-1, len(NAMES))
    f = pl.plot_corner(flat, NAMES, truths={"kappa": 1.31, "C": 0.99e6})
    k = len(pl.default_selection(NAMES))
    assert k == 3 + 4  # kappa, C, gamma and four h pieces
    assert len(f.axes) == k * k
    assert f.axes[-1].get_xlabel().startswith("h")
    assert f.legends
    assert pl.plot_corner(flat, NAMES, subset=["kappa", "C"], fig=Figure()).axes
    with pytest.raises(ValueError, match="unknown parameter"):
        pl.plot_corner(flat, NAMES, subset=["nope"])


def test_fit_h_flux_figures(problem):
    meas = problem.meas
    p = {k: np.array([v]) for k, v in parameter_values(problem.space, {"kappa": 1.3}).items()}
    pred = problem.model.predict(p)[0]
    f = pl.plot_fit(meas, pred, band=(pred - 0.1, pred + 0.1), literature=pred + 0.5)
    _labelled(f)
    labels = [ax.get_ylabel() for ax in f.axes]
    assert "temperature (°C)" in labels and "pred − meas (°C)" in labels
    assert f.axes[1].get_xlabel() == "time (h)"
    h = np.random.default_rng(0).normal(10, 1, (20, meas.n_obs - 1))
    f = pl.plot_h(meas.t, h, wind=meas.wind, truth=np.full(meas.n_obs, 10.0))
    assert f.axes[0].get_ylabel() == "h (W m⁻² K⁻¹)"
    assert f.axes[1].get_ylabel() == "wind speed (m s⁻¹)"
    _labelled(f)
    dT = np.random.default_rng(0).normal(0, 1, (20, meas.n_obs))
    f = pl.plot_fluxes(meas.t, 10 * dT, meas.q_net, dT)
    assert f.axes[0].get_ylabel() == "flux into the ground (W m⁻²)"
    assert f.axes[1].get_ylabel() == "T_air − T_s (°C)"
    _labelled(f)


def test_sensitivity_and_urban_figures(problem):
    vals = parameter_values(problem.space, {"kappa": 1.3, "C": 1.0e6})
    sens = reduced_sensitivity(problem.model, vals, ["kappa", "C", "h_1", "h_2", "h_3"])
    f = pl.plot_sensitivity(sens, sigma=0.25)
    assert f.axes[0].get_ylabel() == "p ∂T/∂p (°C)"
    _labelled(f)
    f = pl.plot_identifiability(identifiability(sens, 0.25))
    _labelled(f)
    c = compare(problem.model, vals)
    f = pl.plot_urban(c)
    assert "surface temperature (°C)" in [ax.get_ylabel() for ax in f.axes]
    _labelled(f)


def test_figures_save_without_pyplot(tmp_path, chain):
    f = pl.plot_logp(chain[:, :, 0], burn_in=10)
    f.savefig(tmp_path / "x.png")
    assert (tmp_path / "x.png").stat().st_size > 1000
