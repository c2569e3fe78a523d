"""Calibrating the forecast rule's margin on stored campaign records (no refit, no solve).

A record of :func:`~.campaign.diagnose_twin` keeps, for every candidate, what the claim rule
reads (forecast gain ``F``, in-sample score ``S``, parameters at a bound, a coherent per-sensor
profile, whether it explains the misfit or removes enough of the forecast error to be claimed
"partly"). :func:`claim_at` re-applies the rule of :mod:`.entries` at another margin, so the
margin can be chosen on one half of the clean twins and its false-claim rate measured on the
other (:func:`calibrate`), each rate with its exact binomial interval
(:func:`binomial_interval`).

:func:`claim_at` keeps the record's own choice among look-alikes (the leave-one-sensor-out
tie-break between candidates of almost equal gain) when that candidate is still claimable, and
never claims a candidate that failed the out-of-sensor check (``unpredicted``; a candidate the
live run did not check, e.g. one claimable only at another margin, is taken as passing).

``ground``: the rule with the ground forecast (:mod:`.ground`) as well, for records that hold
its gain ``G``: ``"either"`` credits a ground or sensor candidate when its forcing gain ``F`` or
its ground gain ``G`` passes the margin (gain: the larger); ``"only"`` reads ``G`` alone for
those candidates. Surface candidates keep ``F`` in both. One margin for both forecasts, chosen
by :func:`calibrate` on clean twins like the forcing rule's (two tests: the false claims of
both count).
"""

from __future__ import annotations

import re

from scipy import stats

from .entries import DATA_THRESHOLD, THRESHOLD

#: the margins tried, smallest first (the rule's :data:`~.entries.FORECAST_THRESHOLD` is 15)
MARGINS = (10.0, 15.0, 20.0, 30.0, 40.0)
#: the margin of the records made before entries carried the ``plausibility`` flag
UNFLAGGED_MARGIN = 10.0
#: the catalogue effects that act at the surface (issue 22: claimed >= 80 % together)
SURFACE = ("wind_convection", "evaporation", "evapotranspiration", "radiation_factor",
           "conductivity_temperature")
#: hidden effect -> the claims that find it: the twins' layer over the soil stores heat (1.5 cm
#: of thatch, 4.5 kJ m-2 K-1), which ``canopy`` models and ``surface_layer`` (a pure resistance)
#: approximates; either names the layer
FOUND_AS = {"surface_layer": ("surface_layer", "canopy")}


def found(claim: str | None, hidden: str) -> bool:
    """Whether the claim ``claim`` names the hidden effect ``hidden`` (:data:`FOUND_AS`)."""
    return claim is not None and claim in FOUND_AS.get(hidden, (hidden,))


def binomial_interval(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) interval of a binomial rate ``k / n``."""
    if n <= 0 or not 0 <= k <= n:
        raise ValueError(f"need 0 <= k <= n and n > 0; got k={k}, n={n}")
    a = (1.0 - level) / 2.0
    lo = 0.0 if k == 0 else float(stats.beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(stats.beta.ppf(1.0 - a, k + 1, n - k))
    return lo, hi


#: the ground-forecast variants of the rule (module doc)
GROUND_RULES = ("either", "only")


def gain(e: dict, ground: str | None = None) -> float:
    """The gain the rule reads of candidate record ``e`` (module doc: ``ground``)."""
    if ground is None or not e.get("ground") or "G" not in e:
        return e["F"]
    if ground not in GROUND_RULES:
        raise ValueError(f"unknown ground rule {ground!r}; valid: {', '.join(GROUND_RULES)}")
    return e["G"] if ground == "only" else max(e["F"], e["G"])


def _forecasts_better(e: dict, margin: float, ground: str | None = None) -> bool:
    return (gain(e, ground) > margin and e["S"] >= -THRESHOLD and not e["at_bound"]
            and not e["profile"] and not e.get("unpredicted"))


def _plausibility(e: dict) -> bool:
    """A plausibility claim (:attr:`~.entries.Entry.plausibility_claim`); records without the
    flag (the first campaign's): claimable but not by its forecast at the margin they were
    made with, :data:`UNFLAGGED_MARGIN` (their ``detected`` was computed at it)."""
    if e.get("unpredicted"):  # stopped by the out-of-sensor check
        return False
    if "plausibility" in e:
        return bool(e["plausibility"])
    return bool(e["detected"]) and not _forecasts_better(e, UNFLAGGED_MARGIN)


def _insample(e: dict) -> bool:
    """The in-sample rule's test, with a forecast that is no worse (the variant of
    :func:`claim_at`): S and D pass their thresholds, F >= -THRESHOLD, nothing at a bound, no
    coherent offset profile, and it explains the misfit or removes enough of it."""
    return (e["S"] > THRESHOLD and e["D"] > DATA_THRESHOLD and e["F"] >= -THRESHOLD
            and not e["at_bound"] and not e["profile"] and (e["explains"] or e["partial"]))


def claim_at(record: dict, margin: float, insample: bool = False,
             ground: str | None = None) -> str | None:
    """The candidate the forecast rule claims in ``record`` with margin ``margin`` (None: no
    claim): the largest gain ``F > margin`` among candidates that fit no worse in sample (``S
    >= -THRESHOLD``), with no own parameter at a bound and no coherent offset profile, kept if
    it explains the misfit or is a partial claim; without such a candidate, a plausibility
    claim (the forecast rule of :func:`~.ranking.claim_order`).

    ``insample``: the variant measured, not adopted (docs/VALIDATION.md section 4): without a
    forecast claim, the candidate of largest in-sample score that passes the in-sample rule and
    forecasts no worse is claimed before a plausibility claim."""
    ok = {n: e for n, e in record["entries"].items() if _forecasts_better(e, margin, ground)}
    if not ok and insample:
        ins = {n: e for n, e in record["entries"].items() if _insample(e)}
        if ins:
            return max(ins, key=lambda n: ins[n]["S"])
    if not ok:  # a plausibility claim (an impossible base fit brought into range) decides
        return next((n for n, e in record["entries"].items() if _plausibility(e)), None)
    name = max(ok, key=lambda n: gain(ok[n], ground))
    if record.get("claimed") in ok and record["claimed"] in record.get("lookalikes", ()):
        name = record["claimed"]  # the tie-break's choice among look-alikes
    return name if ok[name]["explains"] or ok[name]["partial"] else None


def _rate(k: int, n: int) -> dict:
    lo, hi = binomial_interval(k, n) if n else (float("nan"), float("nan"))
    return {"k": k, "n": n, "ci95": [round(lo, 3), round(hi, 3)]}


def row_key(record: dict) -> str:
    """The row a catalogue twin's record counts in: its hidden effect, and the tag its name
    carries when the twin is of another strength or simulator setting
    (``conductivity_temperature-kappa_beta-0.015``; :func:`~pavement_mcmc.synthetic.corpus.
    forecast_twins`), so that pooled campaigns keep them apart."""
    return record["hidden"][0] + re.sub(r"^.*?-s\d+", "", record["twin"])


def rates_at(records: list[dict], margin: float, insample: bool = False,
             ground: str | None = None) -> dict:
    """False claims on clean twins, claims of the hidden effect per catalogue effect and for the
    surface family, and off-catalogue twins without a catalogue claim, at ``margin`` (and with
    the in-sample variant of :func:`claim_at` when ``insample``)."""
    def claim(r):
        return claim_at(r, margin, insample, ground)

    by = {c: [r for r in records if r["category"] == c]
          for c in ("clean", "catalogue", "off_catalogue")}
    false = [r["twin"] for r in by["clean"] if claim(r) is not None]
    effects = {}
    for key in sorted({row_key(r) for r in by["catalogue"]}):
        rs = [r for r in by["catalogue"] if row_key(r) == key]
        effects[key] = _rate(sum(found(claim(r), r["hidden"][0]) for r in rs), len(rs))
    surf = [r for r in by["catalogue"] if row_key(r) in SURFACE]  # at their default strength
    off = by["off_catalogue"]
    return {
        "margin": margin,
        "false_claims": _rate(len(false), len(by["clean"])),
        "false_claim_twins": false,
        "effects": effects,
        "surface": _rate(sum(found(claim(r), r["hidden"][0]) for r in surf), len(surf)),
        "off_no_claim": _rate(sum(claim(r) is None for r in off), len(off)),
        "off_claims": {r["twin"]: claim(r) for r in off
                       if claim(r) is not None},
    }


def calibrate(records: list[dict], margins=MARGINS, max_false: float = 1 / 20,
              ground: str | None = None) -> dict:
    """Choose the margin on the clean twins of even seed, measure it on the rest.

    The margin is the smallest of ``margins`` whose false claims on the calibration half are at
    most ``max_false`` of it; the evaluation half's false-claim rate, and every rate at that
    margin (:func:`rates_at`, all twins), are then reported with exact 95 % intervals.
    """
    clean = [r for r in records if r["category"] == "clean"]
    seed = {r["twin"]: int(r["twin"].rsplit("-s", 1)[1]) for r in clean}
    half = {"calibration": [r for r in clean if seed[r["twin"]] % 2 == 0],
            "evaluation": [r for r in clean if seed[r["twin"]] % 2 == 1]}
    cal = half["calibration"]
    false_cal = {m: sum(claim_at(r, m, ground=ground) is not None for r in cal) for m in margins}
    chosen = next((m for m in margins if false_cal[m] <= max_false * len(cal)), margins[-1])
    ev = half["evaluation"]
    return {
        "calibration_false": {m: (k, len(cal)) for m, k in false_cal.items()},
        "margin": chosen,
        "evaluation_false": _rate(sum(claim_at(r, chosen, ground=ground) is not None for r in ev),
                                  len(ev)),
        "largest_clean_gain": sorted(
            (max((gain(e, ground) for e in r["entries"].values()), default=0.0), r["twin"])
            for r in clean
        )[-5:],
        "at_margin": rates_at(records, chosen, ground=ground),
    }
