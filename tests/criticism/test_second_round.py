"""Diagnosis in rounds: twin data with TWO hidden effects.

Round 1 diagnoses the base model and ranks one of the hidden effects first; the model is refitted
with the winner (``CASE.toml+winner``, the MAP route of ``pavement-mcmc diagnose`` /
``compare``) and diagnosed again: round 2 tries only the catalogue entries not yet in the model
and ranks the other hidden effect first; with both added, round 3 claims no missing effect. The
RMSE falls at every round (or is already within 10 % of the true model's) and ends within 10 %
of the true model at the true parameters.

Data: :mod:`pavement_mcmc.synthetic`, sigma = 0.2 degC, default effect strengths; model and
priors as in ``test_hidden_effects.py`` (h(t) in 28 pieces of 1 h, kappa/C priors +-5 %, 3 % off).
"""

from __future__ import annotations

import json

import pytest
from test_hidden_effects import CASE, scaled, true_rmse

from pavement_mcmc.criticism import diagnose
from pavement_mcmc.criticism.point import load_point
from pavement_mcmc.criticism.ranking import FINER_H
from pavement_mcmc.data import load_case
from pavement_mcmc.physics import candidate_names
from pavement_mcmc.synthetic import SyntheticSpec, write_case


def make_case(tmp_path, effects: tuple[str, ...], seed: int):
    d = tmp_path / f"{'-'.join(effects)}_{seed}"  # no '+': it separates extensions
    write_case(SyntheticSpec(seed=seed, sigma=0.2, effects={e: scaled(e, 1.0) for e in effects}), d)
    toml = d / "case.toml"
    toml.write_text(CASE.format(kappa=1.35, C=1.02e6))
    return toml


def rounds(toml, n_rounds: int = 3) -> list[dict]:
    """Diagnose, add the winner, diagnose again ... (at most ``n_rounds``, stops at no winner)."""
    out, added = [], []
    for _ in range(n_rounds):
        problem, values, _how, _label = load_point("+".join([str(toml), *added]))
        rk = diagnose(problem, values).ranking
        out.append(
            {
                "model": [e.name for e in problem.model.extensions],
                "rmse": rk.residuals.rmse,
                "tried": sorted(e.name for e in rk.entries) + sorted(rk.skipped),
                "best": None if rk.best is None else rk.best.name,
                "promised_rmse": None if rk.best is None else rk.best.rmse,
                "scores": {e.name: round(e.score, 1) for e in rk.entries},
                "verdict": rk.verdict,
            }
        )
        if rk.best is None or rk.best.name == FINER_H:
            break
        added.append(rk.best.name)
    return out


def check_rounds(tmp_path, effects: tuple[str, ...], seed: int) -> list[dict]:
    toml = make_case(tmp_path, effects, seed)
    res = rounds(toml)
    target = true_rmse(load_case(toml), list(effects))
    print("ROUNDS", json.dumps({"effects": effects, "seed": seed, "true_rmse": target, "rounds": res}))
    everything = {FINER_H, *candidate_names()}
    for r in res:  # each round tries exactly the default candidates not yet in the model
        assert set(r["tried"]) == everything - set(r["model"]), r
    assert len(res) == 3, res
    first, second, third = res
    assert first["best"] in effects, first["verdict"]
    assert second["model"] == [first["best"]]
    assert second["best"] in effects and second["best"] != first["best"], second["verdict"]
    assert third["best"] is None and third["verdict"].startswith("No missing effect"), third["verdict"]
    for a, b in zip(res[:-1], res[1:]):
        # the RMSE falls, or is already within 10 % of the true model's: wind_convection replaces
        # 28 h pieces by 2 parameters, which may raise the in-sample RMSE a little (measured:
        # two_layer + wind_convection, seed 3: 0.219 -> 0.227 with the truth at 0.230)
        assert b["rmse"] < a["rmse"] or b["rmse"] <= 1.10 * target, res
        assert b["rmse"] <= 1.02 * a["promised_rmse"], (a, b)  # the refit keeps the promise
    assert third["rmse"] <= 1.10 * target, (third["rmse"], target)
    return res


def test_second_round_finds_the_second_effect(tmp_path):
    """two_layer + sensor_bias (+0.5 degC at 2 cm): two_layer first, then sensor_bias, then none."""
    res = check_rounds(tmp_path, ("two_layer", "sensor_bias"), seed=1)
    assert [r["best"] for r in res] == ["two_layer", "sensor_bias", None]


@pytest.mark.slow
@pytest.mark.parametrize("seed", [2, 3])
@pytest.mark.parametrize(
    "effects",
    [("two_layer", "sensor_bias"), ("sensor_depth", "sensor_bias"), ("two_layer", "wind_convection")],
)
def test_second_round_matrix(tmp_path, request, effects, seed):
    if effects == ("two_layer", "wind_convection") and seed == 3:
        request.applymarker(
            pytest.mark.xfail(
                reason="the second round does not claim wind_convection (data part D = -40: the "
                "1 h pieces of h(t) absorb it, see test_hidden_effects' seed 3)",
                strict=False,
            )
        )
    check_rounds(tmp_path, effects, seed)


def test_sensor_depth_after_sensor_bias_keeps_the_bias(tmp_path):
    """Extensions compose: sensor_depth's ``observe`` adds its depth change to what earlier
    hooks made, so at zero offsets [sensor_bias, sensor_depth] predicts what [sensor_bias] does
    (it used to re-interpolate the nodes and drop the biases)."""
    import numpy as np

    from pavement_mcmc.posterior import build_problem

    cfg = load_case(make_case(tmp_path, (), seed=1))
    preds = []
    for exts in (["sensor_bias"], ["sensor_bias", "sensor_depth"]):
        pb = build_problem(cfg, extensions=exts)
        p = {k: v.copy() for k, v in pb.space.values().items()}
        p.update({k: np.zeros(1) for k in p if k.startswith("dz_")}, bias_2cm=np.array([0.5]))
        preds.append(pb.model.predict(p)[0])
    np.testing.assert_allclose(preds[1], preds[0], atol=1e-9)
    assert np.ptp(preds[0][:, 2] - build_problem(cfg).model.predict(p)[0][:, 2]) < 1e-9  # +0.5


def test_second_round_with_sensor_bias_already_in_the_model(tmp_path):
    """sensor_bias already in the model, sensor_depth missing: appended, sensor_depth is ranked
    first and the refit reaches the true model's RMSE."""
    toml = make_case(tmp_path, ("sensor_depth", "sensor_bias"), seed=1)
    problem, values, _how, _label = load_point(f"{toml}+sensor_bias")
    rk = diagnose(problem, values, candidates=["sensor_depth"], holdout=False).ranking
    e = rk.best
    assert e is not None and e.name == "sensor_depth", rk.verdict
    assert [x.name for x in e.fit.problem.model.extensions] == ["sensor_bias", "sensor_depth"]
    target = true_rmse(load_case(toml), ["sensor_depth", "sensor_bias"])
    assert e.rmse <= 1.10 * target, (e.rmse, target)


def test_a_hook_that_overwrites_earlier_ones_is_placed_first(tmp_path):
    """A user extension whose ``observe`` recomputes the predictions from the nodes (dropping
    what sensor_bias added) does not nest the current model when appended; the ranking puts it
    first, where it does, and says so."""
    import numpy as np

    from pavement_mcmc.parameters import Parameter, Uniform
    from pavement_mcmc.physics import Extension

    class Overwrite(Extension):
        name = "overwrite_offset"

        def parameters(self, meas):
            return [Parameter("dz_all", 0.0, -0.01, 0.01, prior=Uniform(-0.01, 0.01), unit="m")]

        def null_values(self, meas):
            return {"dz_all": 0.0}

        def observe(self, pred, T_nodes, p, model):
            from pavement_mcmc.physics.observe import interpolation_weights

            z = model.meas.depths[None, :] + np.asarray(p["dz_all"])[:, None]
            i, w = interpolation_weights(model.grid.x, z)
            rows = np.arange(T_nodes.shape[0])[:, None, None]
            t = np.arange(T_nodes.shape[1])[None, :, None]
            return (T_nodes[rows, t, i[:, None, :]] * (1 - w[:, None, :])
                    + T_nodes[rows, t, i[:, None, :] + 1] * w[:, None, :])

    toml = make_case(tmp_path, ("sensor_bias",), seed=1)
    problem, values, _how, _label = load_point(f"{toml}+sensor_bias")
    rk = diagnose(problem, values, candidates=[Overwrite()], holdout=False).ranking
    (e,) = rk.entries
    assert [x.name for x in e.fit.problem.model.extensions] == ["overwrite_offset", "sensor_bias"]
    assert "listed before sensor_bias" in e.description
    assert e.score < 10  # the data do not need it: sensor_bias already explains them
