"""ArviZ export (optional extra): groups, dims, and a clear error without ArviZ."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.runs import export, load_view

REPO = Path(__file__).resolve().parents[2]


def test_missing_arviz_gives_a_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "arviz", None)
    with pytest.raises(ImportError, match=r"pavement_mcmc\[arviz\]"):
        export.import_arviz()


def test_export_round_trip(tiny_run, tmp_path):
    az = pytest.importorskip("arviz")
    view = load_view(tiny_run)
    out = export.export_netcdf(view, tmp_path / "run.nc", thin=5)
    data = az.from_netcdf(str(out))
    groups = set(data.groups() if callable(getattr(data, "groups", None)) else data.children)
    groups = {g.strip("/") for g in groups}
    assert {"posterior", "sample_stats", "log_likelihood", "posterior_predictive",
            "observed_data"} <= groups
    n_kept = view.kept.shape[0]
    n_draw = len(range(0, n_kept, 5))
    post = data["posterior"] if not hasattr(data, "posterior") else data.posterior
    assert post["kappa"].shape == (12, n_draw)
    assert post["h"].shape == (12, n_draw, 3)
    ll = data.log_likelihood["T"]
    assert ll.shape == (12, n_draw, view.problem.meas.n_obs - 1, 5)
    # the pointwise log-likelihood sums to the stored log-likelihood: log post - log prior
    theta = view.run.chain[view.burn_in, 0][None, :]
    total = view.problem.posterior.log_prob(theta)[0] - view.problem.space.log_prior(theta)[0]
    assert float(ll.values[0, 0].sum()) == pytest.approx(total, rel=1e-9)
    np.testing.assert_allclose(data.observed_data["T"].values, view.problem.meas.T_obs[1:])
    assert data.sample_stats["lp"].shape == (12, n_draw)
    assert set(np.unique(data.sample_stats["acceptance_rate"].values)) <= {0.0, 1.0}
