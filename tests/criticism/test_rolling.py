"""``pavement-mcmc rolling``: next-day forecasts a day apart over a record, a law named by the
sign test (criticism/rolling.py). Twins from the independent simulator: a wind-driven h, which
the law ``energy_balance_window`` contains, and a clean h drawn day by day, which no law makes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pavement_mcmc.cli import main
from pavement_mcmc.criticism import rolling
from pavement_mcmc.criticism.rolling import LEVEL, Day, Rolling, origins, rolling_forecast
from pavement_mcmc.data import ConfigError
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin
from pavement_mcmc.synthetic.io import drop_columns

LAW = "energy_balance_window"
#: 8 days: five 72 h windows, each with the next day (5 of 5 is the fewest days a sign test
#: at 0.05 can name: p = 1/32)
HOURS = 8 * 24.0


def _case(tmp_path, effect, seed):
    twin = forecast_twins((effect,) if effect else (), (seed,), hours=HOURS, input_sigma=True)[0]
    return write_twin(twin, tmp_path / twin.name)


def _day(base, law, F=0.0):
    return Day(0.0, "t", base, law, 0.1, 0.1, F, 5.0)


def test_sign_test_and_naming():
    r = Rolling("b", "l", 72.0, 24.0, [_day(1.0, 0.5, 3.0)] * 11 + [_day(0.5, 1.0, -1.0)] * 4)
    assert r.wins == 11 and r.p_value == pytest.approx(0.059235, abs=1e-6)  # 1941 / 32768
    assert not r.named  # 11 of 15: p > 0.05
    r.days.append(_day(1.0, 0.5, 3.0))
    assert r.wins == 12 and r.p_value == pytest.approx(0.038406, abs=1e-6) and r.named
    neg = Rolling("b", "l", 72.0, 24.0, [_day(1.0, 0.9, -1.0)] * 12)  # wins but F summed < 0
    assert neg.p_value <= LEVEL and not neg.named and "not positive" in neg.verdict()
    tie = Rolling("b", "l", 72.0, 24.0, [_day(0.5, 0.5)] * 6)
    assert tie.wins == 0 and tie.p_value == 1.0  # a tie is not a win


def test_origins_fit_in_the_record_on_its_rows(tmp_path):
    case = _case(tmp_path, None, 600)
    assert origins(case) == [0.0, 24.0, 48.0, 72.0, 96.0]
    assert origins(case, step_h=48.0, start_h=24.0) == [24.0, 72.0]
    assert origins(case, days=2) == [0.0, 24.0]
    assert origins(case, start_h=0.2, days=2) == [0.5, 24.5]  # 30 min rows: the next row
    with pytest.raises(ConfigError, match="do not fit"):
        origins(case, window_h=180.0)
    with pytest.raises(ConfigError, match="overlap"):
        origins(case, step_h=6.0)  # forecast days a quarter day apart would overlap
    for bad in ({"days": 0}, {"days": -1}, {"start_h": float("nan")}, {"window_h": float("inf")}):
        with pytest.raises(ConfigError):
            origins(case, **bad)


def test_two_cases_on_different_records_are_refused_before_any_fit(tmp_path, monkeypatch):
    a, b = _case(tmp_path, None, 600), _case(tmp_path, None, 601)
    longer = forecast_twins((), (602,), hours=HOURS + 24.0, input_sigma=True)[0]
    c = write_twin(longer, tmp_path / "longer")
    built = []  # building a twin's model fits a MAP (its inputs' noise is linearised there)
    monkeypatch.setattr(rolling, "case_problem", lambda *a, **k: built.append(a))
    for law in (b, c):  # the same times, other data; other times
        with pytest.raises(ConfigError, match="different records or sensors"):
            rolling_forecast(a, law)
    assert not built


def test_a_wind_driven_h_is_named_and_a_clean_one_is_not(tmp_path):
    wind = rolling_forecast(_case(tmp_path, "wind_convection", 700),
                            f"{_case(tmp_path, 'wind_convection', 700)}+{LAW}")
    assert wind.n == 5 and wind.wins == 5 and wind.named, wind.text()
    assert np.median([d.law_rmse / d.base_rmse for d in wind.days]) < 0.8
    clean_case = _case(tmp_path, None, 601)
    clean = rolling_forecast(clean_case, f"{clean_case}+{LAW}")
    assert clean.n == 5 and not clean.named, clean.text()


def test_cli_writes_the_figure_and_refuses_bad_input_before_any_fit(tmp_path, capsys):
    case = _case(tmp_path, "wind_convection", 702)
    fig = tmp_path / "r.png"
    assert main(["rolling", str(case), f"{case}+{LAW}", "--days", "1", "--figure", str(fig),
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["n"] == 1 and len(out["days"]) == 1 and fig.stat().st_size > 10_000
    api = rolling_forecast(case, f"{case}+{LAW}", days=1).to_dict()  # the same from Python
    assert out["days"] == api["days"] and out["p_value"] == api["p_value"]
    bad = tmp_path / "bad.png"
    for args in ([str(case), f"{case}+no_such_law"], [str(case), str(tmp_path / "none.toml")],
                 [str(case), str(case), "--days", "0"], [str(case), str(case), "--window", "300h"],
                 [str(tmp_path), str(case)]):  # a directory: a traceback before
        assert main(["rolling", *args, "--figure", str(bad)]) == 2
        assert not bad.exists()


def test_a_ground_effect_the_law_adds_and_the_base_lacks_is_named_in_the_verdict(tmp_path):
    """The count credits everything the law's case adds: a layer added with the law is listed,
    with the base that tests the surface law alone; with the layer in both, nothing is."""
    case = _case(tmp_path, "wind_convection", 703)
    both = rolling_forecast(case, f"{case}+{LAW}+two_layer+sensor_bias", days=1)
    assert both.also_added == ["two_layer", "sensor_bias"]
    assert "also adds two_layer, sensor_bias" in both.verdict()
    assert f"{case}+two_layer+sensor_bias" in both.verdict()  # the base as given, extended
    assert both.to_dict()["also_added"] == ["two_layer", "sensor_bias"]
    assert not both.windless and "no wind" not in both.verdict()  # the wind drives its H
    fair = rolling_forecast(f"{case}+two_layer", f"{case}+{LAW}+two_layer", days=1)
    assert fair.also_added == [] and "also adds" not in fair.verdict()
    assert fair.also_observed == [] and "also fits" not in fair.verdict()  # the same streams


def test_streams_the_law_fits_and_the_base_does_not_are_listed():
    """A law case that also fits the infrared surface temperature or a plate says so; streams
    and columns both cases fit are not listed."""
    from types import SimpleNamespace as NS

    def post(*streams):
        return NS(streams=[NS(name=n, labels=labs) for n, labs in streams])

    base = post(("temperatures", ["2cm", "5cm"]), ("plates", ["G5cm"]))
    law = post(("temperatures", ["2cm", "5cm"]), ("plates", ["G5cm", "G10cm"]), ("surface_ir", ["IR"]))
    assert rolling._also_observed(base, law) == ["plates (G10cm)", "surface_ir (IR)"]
    assert rolling._also_observed(law, base) == [] and rolling._also_observed(base, base) == []
    r = Rolling("b", "l", 72.0, 24.0, [_day(1.0, 0.5)], also_observed=["surface_ir (IR)"])
    assert "also fits surface_ir (IR), which the base does not" in r.verdict()
    assert r.to_dict()["also_observed"] == ["surface_ir (IR)"]


@pytest.mark.slow
def test_false_naming_rate_on_fresh_clean_twins_and_power_on_wind_twins(tmp_path):
    """``make validate``: fresh seeds (the shipped null used 600-639 and 700-709), 18-day
    twins, 15 windows each: at most 1 of 12 clean twins named (the rule asks <= 1 in 20; 40
    clean twins gave 0), every wind-driven one named."""
    def named(effect, seed):
        twin = forecast_twins((effect,) if effect else (), (seed,), hours=18 * 24.0,
                              input_sigma=True)[0]
        case = write_twin(twin, tmp_path / twin.name)
        return rolling_forecast(case, f"{case}+{LAW}").named

    clean = [named(None, s) for s in range(640, 652)]
    assert sum(clean) <= 1, clean
    assert all(named("wind_convection", s) for s in range(710, 713))


def test_diagnose_points_a_surface_verdict_at_the_rolling_test():
    """When nothing is claimed and the evidence points at the surface energy balance, the next
    step names ``pavement-mcmc rolling`` (it named only the extension template before)."""
    from types import SimpleNamespace

    from pavement_mcmc.cli.diagnose import next_step
    from pavement_mcmc.criticism.entries import ENERGY

    def ranking(points_at, replaces_h=False, tried=()):
        model = SimpleNamespace(replaces_h=replaces_h)
        return SimpleNamespace(best=None, unexplained=None, points_at=points_at,
                               entries=[SimpleNamespace(name=n) for n in tried],
                               base=SimpleNamespace(problem=SimpleNamespace(
                                   model=model, meas=SimpleNamespace(extras={}))))

    surface = ranking({"where": "surface energy balance", "candidates": []})
    assert "pavement-mcmc rolling <case.toml> <case.toml>+energy_balance_window" in \
        " ".join(next_step(surface))
    assert not any("rolling" in x for x in next_step(ranking(None, tried=["two_layer"])))
    # the energy check named the surface (so the balance was tried) while the best-scoring
    # candidate acts below it (the desert base fit: two_layer first, h 476 W m-2 K-1)
    assert any("rolling" in x for x in next_step(ranking(None, tried=["two_layer", ENERGY])))
    # a model whose h(t) is already a law (energy_balance): adding another is no next step
    assert not any("rolling" in x for x in next_step(ranking(surface.points_at, replaces_h=True)))


def test_the_refits_run_with_one_blas_thread_whatever_the_caller_allows(tmp_path):
    """BLAS threads fight the compiled solver for the cores (the API outside the CLI had
    whatever OMP_NUM_THREADS gave: a day 1.6x slower on an idle machine, minutes under load)."""
    from threadpoolctl import threadpool_info, threadpool_limits

    case = _case(tmp_path, None, 600)
    seen = []
    with threadpool_limits(limits=2, user_api="blas"):
        blas = [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]
        if not blas:
            pytest.skip("no BLAS library found by threadpoolctl")
        assert set(blas) == {2}  # the caller allows two
        rolling_forecast(case, f"{case}+{LAW}", days=1, progress=lambda *a: seen.extend(
            p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"))
    assert seen and set(seen) == {1}, seen



def test_the_refits_keep_the_start_with_the_lowest_training_objective(monkeypatch):
    """``forecast_from_starts`` chooses by the training objective, not by the held-out error
    it is about to score (choosing by that would be fitting to the forecast day)."""
    from types import SimpleNamespace

    from pavement_mcmc.criticism import forecast as fc

    made = {None: (50.0, 0.2), "a": (10.0, 0.9), "b": (30.0, 0.1)}  # start -> objective, rmse

    def fake(problem, start, **kw):
        obj, rmse = made[start]
        return SimpleNamespace(start=start, rmse=rmse,
                               fits=[SimpleNamespace(objective=obj)])

    monkeypatch.setattr(fc, "forecast", fake)
    assert fc.forecast_from_starts(None, [None, "a", "b"]).start == "a"


def test_the_starts_of_a_window(tmp_path):
    """The case's values, the previous fit, and every extension's starts given that fit (a
    layer's below-layer kappa scales off the fitted kappa); a start that sets no free parameter
    is dropped."""
    case = _case(tmp_path, "wind_convection", 704)
    pb, _ = rolling.case_problem(f"{case}+two_layer+{LAW}")
    warm = {"kappa": 2.0, "C": 1.0e6}
    starts = rolling.fit_starts(pb, warm)
    assert starts[:2] == [None, warm]
    layer = [s for s in starts[2:] if "kappa2" in s]
    assert [s["kappa2"] for s in layer] == pytest.approx([0.7 * 2.0, 1.3 * 2.0])
    assert any("eb_h0" in s for s in starts[2:])
    fixed = rolling.case_problem(f"{case}+two_layer+{LAW}", {"parameters": {
        "eb_h0": {"value": 4.0, "vary": False}, "eb_h1": {"value": 3.0, "vary": False}}})[0]
    assert not any("eb_h0" in s for s in rolling.fit_starts(fixed)[1:])
    assert rolling.fit_starts(pb)[0] is None and None not in rolling.fit_starts(pb)[1:]


def test_a_window_one_side_fits_far_worse_is_marked():
    ok, odd = Day(0.0, "a", 1.0, 0.5, 0.1, 0.4, 1.0, 5.0), Day(0.0, "b", 1.0, 0.5, 1.2, 0.2, 1.0, 5.0)
    assert not ok.fit_suspect and odd.fit_suspect
    r = Rolling("base", "law", 72.0, 24.0, days=[ok, odd])
    assert "On 1 of the 2 windows (marked fit?)" in r.verdict() and "the law wins 1" in r.verdict()
    assert r.to_dict()["fit_suspect"] == ["b"] and "fit?" in r.text().splitlines()[-2]
    assert "fit?" not in Rolling("base", "law", 72.0, 24.0, days=[ok]).verdict()


REPO = Path(__file__).resolve().parents[2]
DESERT = REPO.parent / "shared" / "data" / "soilvue_utah" / "measurements.csv"


@pytest.mark.skipif(not DESERT.is_file(), reason=f"the shared desert record is not here ({DESERT})")
def test_a_window_the_cases_values_fit_badly_is_fitted_from_the_other_starts():
    """The desert base with its layer on the windows of 10 and 11 September 2025 (from hour
    4632): from the case's values alone its MAP stops at an in-sample RMSE of 1.455 and 1.327
    degC (the earlier rule), from the other starts (the second window's include the first's
    fit) it reaches about 0.16 degC; the count must not credit a law with a base fit that
    failed (module doc, *Starts*)."""
    base = str(REPO / "runs" / "desert.toml") + "+two_layer"
    one = rolling_forecast(base, base, start_h=4632, days=2, one_start=True)
    best = rolling_forecast(base, base, start_h=4632, days=2)
    assert [d.base_fit > 1.0 for d in one.days] == [True, True]
    assert [d.base_fit < 0.3 for d in best.days] == [True, True]


def test_a_balance_on_a_record_without_wind_says_what_the_count_can_show(tmp_path):
    """Without a wind column the Priestley-Taylor balance's H is one coefficient and it adds no
    forcing to a free h(t)'s: the verdict says so, with the rule's power at the still twins'
    rate (197 of 300 days) for its own number of days (module doc, *A still record*)."""
    case = _case(tmp_path, None, 501)
    drop_columns(case.parent / "measurements.csv", ("wind",))
    still = rolling_forecast(case, f"{case}+{LAW}+two_layer", days=1)  # a ground effect aside
    assert still.windless and not still.named and still.to_dict()["windless"]
    assert "The record has no wind" in still.verdict() and "197 of 300" in still.verdict()
    assert "1 days are too few for the sign test to name it" in still.verdict()
    same = rolling_forecast(f"{case}+{LAW}", f"{case}+{LAW}", days=1)
    assert not same.windless and "no wind" not in same.verdict()
    # 13 wins of 27 (the desert's July count): power 0.39 at 0.657 a day, P(<= 13) 0.046
    r = Rolling("b", "l", 72.0, 24.0, [_day(1.0, 0.5, 3.0)] * 13 + [_day(0.5, 1.0, -1.0)] * 14,
                windless=True)
    assert "over 27 days names it with probability 0.39" in r.verdict()
    assert "13 or fewer wins have probability 0.046" in r.verdict()


def test_the_still_line_is_only_for_the_plain_balance_against_a_free_h():
    """Not for a base whose h is not one value per interval (a constant h: the law then has
    more parameters), a record with wind, a law with one alpha a day, or a law that reads more
    than the net radiation and the air temperature (a shadow, the soil water): the still
    twins' figures are of energy_balance_window against Case C's h."""
    from types import SimpleNamespace as NS

    from pavement_mcmc.physics import get_extension

    def model(*names, per_interval=True, wind=None, replaces=False):
        return NS(extensions=[get_extension(n) for n in names], replaces_h=replaces,
                  h_basis=NS(identity=per_interval), meas=NS(wind=wind))

    base = model()
    assert rolling._windless(base, model(LAW))
    assert rolling._windless(base, model(LAW, "two_layer"))
    assert rolling._windless(model("shading"), model(LAW, "shading"))  # the shadow in both
    assert not rolling._windless(model(per_interval=False), model(LAW))  # a few pieces of h
    assert not rolling._windless(base, model("energy_balance"))  # one alpha a day
    assert not rolling._windless(base, model(LAW, wind=np.ones(3)))
    assert not rolling._windless(base, model(LAW, "shading"))
    assert not rolling._windless(base, model("energy_balance_swc"))
    assert not rolling._windless(model(LAW, replaces=True), model(LAW))
