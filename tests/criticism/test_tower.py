"""A flux tower's H and LE as a check of the surface energy balance (criticism/tower.py): twins
from the independent simulator with a tower that closes 85 % of the balance
(``SyntheticSpec.tower``), fitted by the inversion's own laws."""

from __future__ import annotations

import numpy as np
import pytest

from pavement_mcmc.criticism import refit
from pavement_mcmc.criticism.energy import EnergyBalance, _verdict, energy_balance
from pavement_mcmc.criticism.point import case_problem
from pavement_mcmc.criticism.tower import TOL, tower_check, tower_fluxes, tower_ground_share
from pavement_mcmc.physics.catalogue.energy import Partition, energy_partition
from pavement_mcmc.synthetic.corpus import forecast_twins, write_twin

NO_LE = {"parameters": {"eb_alpha": {"value": 0.0, "vary": False}}}


def _tower_twin(tmp_path, effects, seed):
    twin = forecast_twins(effects, (seed,), hours=72.0,
                          spec={"tower": 0.85, "et_available": "net"})[0]
    return write_twin(twin, tmp_path / twin.name)


def _partition_at_map(case, overrides=None):
    pb, _ = case_problem(f"{case}+energy_balance_window", overrides)
    v = {**pb.space.value_dict(), **refit(pb).values()}
    return pb, energy_partition(pb.model, {k: np.array([x]) for k, x in v.items()})


def test_shares_closure_and_agreement_by_hand():
    Rn = np.array([[0.0, 100.0, 400.0, 300.0, 0.0]])
    H, LE, G = (np.array([[0.0, 10.0, k * 100.0, k * 75.0, 0.0]]) for k in (1.0, 2.0, 0.6))
    part = Partition(np.arange(5.0), Rn, H, LE, G)

    class Meas:  # midday rows: 400 and 300 W m-2
        q_net = Rn[0]
        extras = {"H": np.array([0.0, 5.0, 80.0, 60.0, np.nan]),
                  "LE": np.array([0.0, 5.0, 200.0, 150.0, 0.0])}

    tc = tower_check(part, Meas)
    # closure (80 + 60 + 200 + 150) / (700 - 105) over the midday rows
    assert tc.closure == pytest.approx(490.0 / 595.0)
    h = tc.fluxes["H"]
    assert h["implied"] == pytest.approx(175.0 / 700.0) and h["measured"] == pytest.approx(0.2)
    assert h["closed"] == pytest.approx(0.2 / tc.closure) and h["agrees"]
    assert h["bias"] == pytest.approx(np.mean([0.0, 5.0, 20.0, 15.0]))  # the NaN row left out
    assert tc.fluxes["LE"]["implied"] == pytest.approx(0.5) and tc.fluxes["LE"]["agrees"]
    assert tower_ground_share(Meas) == pytest.approx((700.0 - 490.0) / 700.0)
    Meas.extras = {"LE": Meas.extras["LE"] * 0.3}  # a tower that sees a third of it
    far = tower_check(part, Meas)
    assert far.closure is None and set(far.fluxes) == {"LE"} and not far.agrees
    assert tower_ground_share(Meas) is None  # needs both
    Meas.extras = {}
    assert tower_check(part, Meas) is None


def test_the_tower_agrees_with_the_law_that_made_the_twin_and_refutes_a_fit_without_latent_heat(tmp_path):
    case = _tower_twin(tmp_path, ("evapotranspiration",), 1)
    pb, part = _partition_at_map(case)
    assert set(tower_fluxes(pb.meas)) == {"H", "LE"}
    tc = tower_check(part, pb.meas)
    assert tc.agrees, tc.text()
    assert 0.75 < tc.closure < 0.95  # the twin's tower closes 85 %
    dry_pb, dry = _partition_at_map(case, NO_LE)
    wrong = tower_check(dry, dry_pb.meas)
    assert not wrong.fluxes["LE"]["agrees"] and not wrong.fluxes["H"]["agrees"], wrong.text()
    assert wrong.fluxes["LE"]["bias"] < -50  # the latent heat it leaves out, W m-2
    assert "DISAGREES" in wrong.text() and "DISAGREES" not in tc.text()


def test_the_report_and_the_fit_line_show_the_tower(tmp_path):
    from types import SimpleNamespace

    from pavement_mcmc.cli.fit import _energy_line
    from pavement_mcmc.report.energy import energy_section

    case = _tower_twin(tmp_path, ("evapotranspiration",), 1)
    pb, _ = _partition_at_map(case)
    th = pb.space.initial()[None, :].repeat(3, axis=0)

    class View:
        def draws(self, n):
            return th[:n]

    frag, (fig,) = energy_section(pb, View(), n_draws=3)
    assert "flux tower" in frag
    labels = [ln.get_label() for ln in fig.axes[0].get_lines()]
    assert "H measured (flux tower)" in labels and "LE measured (flux tower)" in labels
    line = _energy_line(SimpleNamespace(problem=pb, table=[]))
    assert "flux tower at midday" in line and "LE/Rn" in line.splitlines()[-1]


def test_the_energy_check_reads_the_tower(tmp_path):
    """The base fit (free h) of twins with a tower: the fitted ground flux at midday stays under
    what the tower leaves for it (an upper bound; no alarm), and a fit that pushes far more
    into the ground is named at the surface by the tower alone."""
    for effects, seed in ((("evapotranspiration",), 1), ((), 3)):
        pb, _ = case_problem(_tower_twin(tmp_path, effects, seed))
        eb = energy_balance(pb, refit(pb).values(), top_fit=False)
        assert eb.tower_share is not None and eb.fit_share <= eb.tower_share + TOL, eb.text()
        assert not eb.surface_wrong and "flux tower" in eb.text() and "flux tower" in eb.verdict
    grassy = EnergyBalance(np.zeros(3), 1.07, 4.8e-7, 12.8, None, {}, [], tower_share=0.18)
    grassy.verdict = _verdict(grassy)
    assert grassy.surface_wrong and "107 %" in grassy.verdict and "18 %" in grassy.verdict


def test_the_ranking_scores_the_energy_balance_against_the_tower(tmp_path):
    """diagnose tries the surface energy balance as a candidate: its implied partition is
    checked against the tower the fit never saw, and the verdict says so."""
    from pavement_mcmc.criticism.entries import ENERGY
    from pavement_mcmc.criticism.ranking import rank_missing_effects

    pb, _ = case_problem(_tower_twin(tmp_path, ("evapotranspiration",), 1))
    rk = rank_missing_effects(pb, refit(pb).values(), candidates=[ENERGY])
    (e,) = rk.entries
    assert e.name == ENERGY and e.tower["agrees"] and set(e.tower["fluxes"]) == {"H", "LE"}
    assert "agrees with the flux tower's" in rk.verdict, rk.verdict
    assert rk.to_dict()["candidates"][0]["tower"]["agrees"]


@pytest.mark.slow
def test_rates_on_fresh_seeds(tmp_path):
    """``make validate``: seeds 20-29 (the recorded rates used 10-19, benchmarks/tower_rates.py):
    the law that made a twin agrees with its tower, the law without latent heat disagrees on
    LE, and no base fit (free h) raises the energy check's tower alarm."""
    agree, refuted, alarms, n = 0, 0, 0, 0
    for seed in range(20, 30):
        for effects in (("evapotranspiration",), ("wind_convection",)):
            case = _tower_twin(tmp_path, effects, seed)
            pb, part = _partition_at_map(case)
            agree += tower_check(part, pb.meas).agrees
            if effects == ("evapotranspiration",):
                dry_pb, dry = _partition_at_map(case, NO_LE)
                refuted += not tower_check(dry, dry_pb.meas).fluxes["LE"]["agrees"]
            base, _ = case_problem(case)
            eb = energy_balance(base, refit(base).values(), top_fit=False)
            alarms += eb.fit_share > eb.tower_share + TOL
            n += 1
    print(f"the law agrees {agree} of {n}; LE at 0 refuted {refuted} of 10; tower alarms on base "
          f"fits {alarms} of {n}")
    assert agree >= n - 1 and refuted == 10 and alarms == 0


def test_the_ranking_tries_penman_monteith_where_the_record_has_rh(tmp_path):
    """With RH the energy candidate is the Penman-Monteith law (the air's dryness in LE), else
    Priestley-Taylor; the verdict names the one it tried."""
    from pavement_mcmc.criticism.entries import ENERGY, ENERGY_PM, energy_law
    from pavement_mcmc.criticism.ranking import rank_missing_effects

    wet = forecast_twins(("wind_convection",), (1,), hours=72.0,
                         spec={"tower": 0.85, "vapour_kPa": 1.0, "surface_resistance": 150.0})[0]
    pb, _ = case_problem(write_twin(wet, tmp_path / wet.name))
    assert energy_law(pb.meas) == ENERGY_PM
    rk = rank_missing_effects(pb, refit(pb).values(), candidates=[energy_law(pb.meas)])
    assert f"({ENERGY_PM}: eb_h0, eb_h1, eb_rs in place" in rk.verdict, rk.verdict
    assert rk.entries[0].tower["agrees"], rk.entries[0].tower["text"]
    dry, _ = case_problem(_tower_twin(tmp_path, (), 3))
    assert energy_law(dry.meas) == ENERGY


def test_a_fit_that_sends_nothing_into_the_ground_disagrees_with_the_tower():
    """The closure must not come from the fit under test: with the fit's own G, the 'closed'
    shares are the tower's Bowen split of the fit's own H + LE, so any fit with the tower's
    Bowen ratio agrees, however much it sends into the ground. Tower: H 0.2, LE 0.3 of Rn (a
    loam's midday G/Rn about 0.4 at 85 % closure); the fit: G = 0, H 0.4, LE 0.6."""
    Rn = np.array([[0.0, 400.0, 500.0, 400.0, 0.0]])
    part = Partition(np.arange(5.0), Rn, 0.4 * Rn, 0.6 * Rn, np.zeros_like(Rn))

    class Meas:
        q_net = Rn[0]
        extras = {"H": 0.2 * Rn[0], "LE": 0.3 * Rn[0]}

    tc = tower_check(part, Meas)
    assert not tc.fluxes["H"]["agrees"] and not tc.fluxes["LE"]["agrees"], tc.text()


def test_a_flux_measured_only_at_night_is_not_called_a_disagreement():
    Rn = np.array([[-50.0, 400.0, 500.0, 400.0, -50.0]])
    part = Partition(np.arange(5.0), Rn, 0.2 * Rn, 0.5 * Rn, 0.3 * Rn)

    class Meas:
        q_net = Rn[0]
        extras = {"H": np.array([-10.0, np.nan, np.nan, np.nan, -12.0])}

    tc = tower_check(part, Meas)
    assert tc is None or ("H" not in tc.fluxes and tc.agrees), tc.text()


def test_the_next_step_names_penman_monteith_where_the_record_has_rh():
    """diagnose's next step after a 'points at the surface' verdict with no energy candidate
    tried names the law the record supports (Penman-Monteith with RH), not always
    Priestley-Taylor."""
    from types import SimpleNamespace

    from pavement_mcmc.cli.diagnose import next_step
    from pavement_mcmc.criticism.entries import ENERGY, ENERGY_PM

    def rk(extras):
        meas = SimpleNamespace(extras=extras)
        model = SimpleNamespace(replaces_h=False)
        return SimpleNamespace(best=None, unexplained=None, entries=[], points_at={"x": 1},
                               base=SimpleNamespace(problem=SimpleNamespace(meas=meas, model=model)))

    assert f"+{ENERGY_PM} " in next_step(rk({"RH": np.full(4, 60.0)}))[-1]
    assert f"+{ENERGY} " in next_step(rk({}))[-1]


def test_the_tower_alarm_compares_ratios_of_sums_over_the_tower_rows():
    """The fit's share beside the tower's is taken the tower's way (a ratio of sums over the
    rows it measured), not as the energy check's median of G/Rn: a fit whose midday median is
    modest but whose sums are not is caught."""
    Rn = np.array([0.0, 400.0, 500.0, 600.0, 300.0])

    class Meas:
        q_net = Rn
        extras = {"H": np.array([0.0, 200.0, 250.0, 300.0, 150.0]),
                  "LE": np.array([0.0, 150.0, 200.0, 250.0, 120.0])}

    G = np.array([0.0, 20.0, 50.0, 400.0, 20.0])  # midday rows 400-600: G/Rn 0.05, 0.1, 0.67
    tower, fit = tower_ground_share(Meas, G)
    assert tower == pytest.approx((1500 - 750 - 600) / 1500.0)  # 0.10
    assert fit == pytest.approx(470.0 / 1500.0)  # 0.31, where the median share is 0.10
    eb = EnergyBalance(G, float(np.median(G[1:4] / Rn[1:4])), 4.8e-7, 1.0, None, {}, [],
                       tower_share=tower, fit_share=fit)
    eb.verdict = _verdict(eb)
    assert eb.midday_share <= tower + TOL and eb.surface_wrong and "31 %" in eb.verdict
