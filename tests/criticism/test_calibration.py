"""Calibrating the forecast rule's margin on stored records (criticism/calibration.py)."""

from __future__ import annotations

import pytest

from pavement_mcmc.criticism.calibration import binomial_interval, calibrate, claim_at, rates_at


def test_the_exact_binomial_interval():
    """Clopper-Pearson in closed form at the ends: 0 of n gives [0, 1 - (a/2)^(1/n)]."""
    lo, hi = binomial_interval(0, 20)
    assert lo == 0.0 and hi == pytest.approx(1 - 0.025 ** (1 / 20), rel=1e-9)
    lo, hi = binomial_interval(20, 20)
    assert hi == 1.0 and lo == pytest.approx(0.025 ** (1 / 20), rel=1e-9)
    lo, hi = binomial_interval(1, 20)
    assert lo < 0.05 < hi and hi == pytest.approx(0.2487, abs=1e-4)
    with pytest.raises(ValueError, match="0 <= k <= n"):
        binomial_interval(3, 2)


def _entry(F, S=0.0, at_bound=(), profile=False, explains=True, partial=False, D=0.0):
    return {"F": F, "S": S, "D": D, "at_bound": list(at_bound), "profile": profile,
            "explains": explains, "partial": partial, "detected": False}


def _rec(twin, category, hidden, **entries):
    return {"twin": twin, "category": category, "hidden": hidden, "entries": entries}


def test_a_claim_needs_the_margin_a_no_worse_fit_and_no_bound():
    r = _rec("t", "clean", [], a=_entry(25.0, S=-30.0), b=_entry(18.0, at_bound=["x"]),
             c=_entry(12.0), d=_entry(11.0, explains=False))
    assert claim_at(r, 10.0) == "c"  # a fits worse in sample, b sits at a bound
    assert claim_at(r, 15.0) is None
    r["entries"]["d"]["F"] = 13.0  # the largest gain, but it neither explains nor is partial
    assert claim_at(r, 10.0) is None
    r["entries"]["d"]["partial"] = True
    assert claim_at(r, 10.0) == "d"
    r.update(claimed="c", lookalikes=["d", "c"])  # the tie-break chose c among look-alikes
    assert claim_at(r, 10.0) == "c"


def test_the_margin_is_chosen_on_even_seeds_and_measured_on_odd_ones():
    clean = [_rec(f"forecast-clean-s{600 + k}", "clean", [], a=_entry(12.0 if k in (0, 2) else 3.0),
                  b=_entry(25.0 if k == 1 else 1.0)) for k in range(8)]
    wind = [_rec(f"forecast-wind_convection-s{700 + k}", "catalogue", ["wind_convection"],
                 wind_convection=_entry(40.0 - 15 * k)) for k in range(3)]
    off = [_rec("forecast-sensor_sun-s800", "off_catalogue", ["sensor_sun"], two_layer=_entry(16.0))]
    got = calibrate(clean + wind + off, margins=(10.0, 15.0, 30.0), max_false=1 / 20)
    assert got["calibration_false"][10.0] == (2, 4) and got["calibration_false"][15.0] == (0, 4)
    assert got["margin"] == 15.0
    assert got["evaluation_false"]["k"] == 1 and got["evaluation_false"]["n"] == 4  # seed 601
    at = rates_at(clean + wind + off, 15.0)
    assert at["effects"]["wind_convection"]["k"] == 2 and at["off_no_claim"]["k"] == 0
    assert at["off_claims"] == {"forecast-sensor_sun-s800": "two_layer"}


def _cand(name, F, *, restores=False, S=20.0):
    from pavement_mcmc.criticism.entries import Entry

    return Entry(name=name, description="", reference="base", score=S, data_score=S,
                 delta_chi2=S, delta_prior=0.0, added_params=1.0, rho=0.1, rmse=0.2,
                 rmse_sigma=1.0, rmse_sensors=[], evidence=[], values={},
                 restores_plausibility=restores, forecast_gain=F, forecast_share=0.5)


def test_under_the_forecast_rule_a_better_forecast_ranks_before_a_plausibility_claim():
    """A campaign twin with a hidden surface layer: kappa(T) brought an impossible base kappa
    and C into range (a plausibility claim) but forecast no better (F = 1.0), surface_layer
    forecast better (F = 18.8): prediction comes first. The in-sample rule keeps the
    plausibility claim first, and so does the forecast rule when nothing forecasts better."""
    from pavement_mcmc.criticism.ranking import claim_order

    kt, sl = _cand("conductivity_temperature", 1.0, restores=True), _cand("surface_layer", 18.8)
    assert kt.detected and sl.detected
    assert [e.name for e in claim_order([kt, sl])] == ["surface_layer", "conductivity_temperature"]
    sl.forecast_gain = 5.0
    assert [e.name for e in claim_order([sl, kt])][0] == "conductivity_temperature"
    for e in (kt, sl):
        e.forecast_gain = None
    assert [e.name for e in claim_order([sl, kt])][0] == "conductivity_temperature"


def test_a_stored_plausibility_claim_decides_only_without_a_better_forecast():
    r = _rec("t", "catalogue", ["surface_layer"],
             conductivity_temperature={**_entry(1.0), "plausibility": True},
             surface_layer=_entry(18.8))
    assert claim_at(r, 10.0) == "surface_layer"
    assert claim_at(r, 20.0) == "conductivity_temperature"


def test_a_seed_offset_gives_a_fresh_campaign_of_the_same_kinds():
    """The replication campaign (``--seed-offset 1000``) holds the same kinds in the same order
    and shares no twin (no seed) with the calibration campaign."""
    from pavement_mcmc.criticism.campaign import forecast_campaign_twins

    a = forecast_campaign_twins(4, 1, 1)
    b = forecast_campaign_twins(4, 1, 1, seed_offset=1000)
    kind = [t.name.rsplit("-s", 1)[0] for t in a]
    assert kind == [t.name.rsplit("-s", 1)[0] for t in b]
    assert not {t.name for t in a} & {t.name for t in b}
    assert [t.spec.seed + 1000 for t in a] == [t.spec.seed for t in b]


def test_the_in_sample_variant_claims_only_what_forecasts_no_worse():
    """The variant (measured, not adopted): without a forecast claim, the largest in-sample
    score that passes S > 10 and D > 20 and forecasts no worse (F >= -10) is claimed."""
    r = _rec("t", "catalogue", ["sensor_bias"], sensor_bias=_entry(0.5, S=300.0, D=290.0),
             two_layer=_entry(-12.0, S=400.0, D=380.0), sensor_depth=_entry(2.0, S=50.0, D=15.0))
    assert claim_at(r, 10.0) is None  # the adopted rule: no forecast gain passes the margin
    assert claim_at(r, 10.0, insample=True) == "sensor_bias"  # two_layer forecasts worse
    r["entries"]["sensor_bias"]["at_bound"] = ["bias_1"]
    assert claim_at(r, 10.0, insample=True) is None  # sensor_depth's D is below 20
    r["entries"]["wind"] = _entry(14.0, S=1.0)  # a forecast claim always comes first
    assert claim_at(r, 10.0, insample=True) == "wind"


def test_an_unflagged_records_forecast_detection_is_no_plausibility_claim_at_a_wider_margin():
    """Records made before entries carried ``plausibility`` have ``detected`` computed at margin
    10: an entry detected by F = 12 is no claim at margin 15 (it read as a plausibility claim
    when the fallback used the rule's current margin)."""
    e = _entry(12.0)
    e["detected"] = True
    r = _rec("t", "clean", [], evaporation=e)
    assert claim_at(r, 10.0) == "evaporation"
    assert claim_at(r, 15.0) is None


def test_the_shipped_campaign_records_choose_the_rules_margin():
    """The two campaigns behind docs/VALIDATION.md section 4 (docs/campaign/, 284 twins),
    re-read by today's rule code: the calibration chooses the rule's margin, with no false claim
    on the 80 clean twins and wind convection claimed on all 20 of its twins."""
    import gzip
    import json
    from pathlib import Path

    from pavement_mcmc.criticism.entries import FORECAST_THRESHOLD

    docs = Path(__file__).resolve().parents[2] / "docs" / "campaign"
    records = []
    for name in ("forecast_s0.jsonl.gz", "forecast_s1000.jsonl.gz"):
        with gzip.open(docs / name, "rt", encoding="utf-8") as f:
            records += [json.loads(line) for line in f if line.strip()]
    got = calibrate(records)
    assert got["margin"] == FORECAST_THRESHOLD, got["calibration_false"]
    at = got["at_margin"]
    assert (at["false_claims"]["k"], at["false_claims"]["n"]) == (0, 80)
    wind = at["effects"]["wind_convection"]
    assert (wind["k"], wind["n"]) == (20, 20)


def test_a_candidate_the_out_of_sensor_check_stopped_is_not_claimed_offline():
    """A record's candidate that failed the out-of-sensor check (``unpredicted``) was not
    claimed live; re-read offline it was (claim_at knew only F, S, bounds and profiles), so the
    report's calibration and rates counted the stopped sun-warmed-sensor claims again (7 of the
    142 fresh campaign records disagreed with their live claim). The next candidate decides."""
    r = _rec("forecast-sensor_sun-s3800", "off_catalogue", ["sensor_sun"],
             two_layer={**_entry(40.0), "unpredicted": ["0cm", 3.1]}, sensor_bias=_entry(20.0))
    assert claim_at(r, 15.0) == "sensor_bias"
    r["entries"]["sensor_bias"]["unpredicted"] = ["0cm", 2.4]
    assert claim_at(r, 15.0) is None and claim_at(r, 15.0, ground="either") is None
    assert rates_at([r], 15.0)["off_no_claim"]["k"] == 1
    r["entries"]["sensor_bias"].update(F=2.0, plausibility=True)  # a stopped plausibility claim
    assert claim_at(r, 15.0) is None
