"""The report's figures follow the model: the plates and the infrared temperature are drawn
against their predictions, and the 'Surface fluxes' figure (h (T_air - T_s) + q_net) is not
drawn for a model whose flux into the ground is an energy balance (it showed the whole net
radiation entering the ground beside the energy-balance figure's G = Rn - H - LE)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.report.builtin import _figures
from pavement_mcmc.runs import fit, load_view
from pavement_mcmc.synthetic import SyntheticSpec, simulate
from pavement_mcmc.synthetic.io import write_case

OFFSET = 1.5


def _case(tmp_path: Path, model: str) -> Path:
    """A 12-h twin with a plate at 3 cm and an IR reading (the simulator's surface + OFFSET)."""
    spec = SyntheticSpec(hours=12, step_minutes=15, seed=3, flux_depths_cm=(3.0,))
    write_case(spec, tmp_path)
    cols, truth = simulate(spec)
    ir = truth.profiles[:, 0] + OFFSET
    (tmp_path / "extras.csv").write_text(
        "time,T_surf_IR\n" + "".join(f"{s},{v:.3f}\n" for s, v in zip(cols["time"], ir, strict=True)))
    toml = tmp_path / "case.toml"
    toml.write_text(f'[data]\ncsv = "measurements.csv"\nsigma = {spec.sigma}\nplates = true\n'
                    'extras = "extras.csv"\nir_sigma = 0.3\n'
                    f'[model]\n{model}\n'
                    '[sampler]\nkind = "emcee"\nn_walkers = 24\nmax_steps = 30\n')
    return toml


@pytest.mark.parametrize("model, energy", [('h = { kind = "uniform", n = 4 }', False),
                                           ('extensions = ["energy_balance_window"]', True)])
def test_the_figures_follow_the_models_observations_and_fluxes(tmp_path, model, energy):
    run = tmp_path / "run"
    fit(_case(tmp_path, model), run, seed=1)
    view = load_view(run)
    figs = {title: build for title, build, _ in _figures(view, 8)}
    assert ("Surface fluxes" in figs) is not energy
    assert "Heat-flux plates and infrared temperature" in figs
    pr = view.predictive(8)
    (plates, g), (ir, t_ir) = pr.others
    assert (plates.name, ir.name) == ("plates", "surface_ir")
    assert g.shape == (8, view.problem.meas.n_obs, 1) and t_ir.shape == g.shape
    if not energy:  # no skin layer: the IR reads the top node plus each draw's own offset
        offset = pr.theta[:, view.names.index("ir_offset")]
        np.testing.assert_allclose(t_ir[..., 0], pr.T_surface + offset[:, None], atol=1e-9)
    fig = figs["Heat-flux plates and infrared temperature"]()
    tops = [ax for ax in fig.axes if ax.get_title()]
    assert [ax.get_title() for ax in tops] == ["heat-flux plate G3cm", "infrared surface temperature IR"]
    assert "W m⁻²" in tops[0].get_ylabel() and "°C" in tops[1].get_ylabel()
    measured = tops[1].lines[0].get_ydata()
    np.testing.assert_allclose(measured, ir.data[:, 0])
