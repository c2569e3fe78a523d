"""A corpus of malformed case inputs (issue 11, item 2): each entry turns the shipped Case A
(its CSV or its TOML) into one broken input and says whether the command line must refuse it
(exit 2, one message naming the file and the column / row where they apply, no traceback, no
output folder) or accept it (a BOM, CRLF line ends, shuffled or extra columns).

Used by ``tests/data/test_malformed.py``; run it as a script for the tally::

    python tests/data/malformed_corpus.py      # clean errors / tracebacks / wrongly accepted / ...
"""

from __future__ import annotations

import contextlib
import io
import re
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
CSV_NAME = "measurements.csv"
TOML_NAME = "case.toml"


@dataclass(frozen=True)
class Entry:
    """One malformed input. ``csv``/``toml`` rewrite the text (CSV: a list of rows of cells;
    ``raw`` gives the file's bytes directly); ``refuse``: must the CLI refuse it; ``names``:
    what the message must name besides the file (column, row, ...); ``file``: the file the
    message must name."""

    name: str
    refuse: bool
    names: tuple[str, ...] = ()
    csv: Callable[[list[list[str]]], list[list[str]]] | None = None
    raw: Callable[[bytes], bytes] | None = None
    toml: Callable[[str], str] | None = None
    file: str = CSV_NAME
    note: str = field(default="", compare=False)


def _rows() -> list[list[str]]:
    text = (REPO / "data" / "reference_case" / CSV_NAME).read_text()
    return [line.split(",") for line in text.splitlines()]


def _col(rows, name):
    return rows[0].index(name)


def drop(name):
    def f(rows):
        k = _col(rows, name)
        return [r[:k] + r[k + 1:] for r in rows]
    return f


def rename(old, new):
    def f(rows):
        rows[0][_col(rows, old)] = new
        return rows
    return f


def cell(col, row, value):
    """Set data row ``row`` (1-based) of column ``col``."""
    def f(rows):
        rows[row][_col(rows, col)] = value
        return rows
    return f




def _duplicate(rows):
    k = _col(rows, "T_1cm")
    return [r + [r[k]] for r in rows]


def _shuffle(rows):
    order = [0, 5, 1, 7, 2, 10, 3, 9, 4, 8, 6]
    return [[r[i] for i in order] for r in rows]


def _extra(rows):
    return [r + (["battery_V"] if i == 0 else ["12.6"]) for i, r in enumerate(rows)]


def _swap_times(rows):
    rows[10][0], rows[11][0] = rows[11][0], rows[10][0]
    return rows


def _repeat_time(rows):
    rows[11][0] = rows[10][0]
    return rows


def _irregular(rows):
    rows[20][0] = rows[20][0].replace(":00:00Z", ":05:00Z").replace(":15:00Z", ":20:00Z") \
        .replace(":30:00Z", ":35:00Z").replace(":45:00Z", ":50:00Z")
    return rows


def _mixed_zones(rows):
    for r in rows[40:]:
        r[0] = r[0].replace("Z", "+02:00")  # the same wall-clock labels, now two hours earlier
    return rows


def _kelvin(rows):
    for j, name in enumerate(rows[0]):
        if name.startswith("T_"):
            for r in rows[1:]:
                r[j] = f"{float(r[j]) + 273.15:.2f}"
    return rows


def _text(rows) -> bytes:
    return ("\n".join(",".join(r) for r in rows) + "\n").encode()


def _decimal_comma_semicolon(_raw):
    rows = _rows()
    return ("\n".join(";".join(c.replace(".", ",") for c in r) for r in rows) + "\n").encode()


def _decimal_comma(_raw):
    rows = _rows()
    return ("\n".join(",".join(r[:1] + [c.replace(".", ",") for c in r[1:]]) for r in rows)
            + "\n").encode()


def _sep(sep):
    return lambda raw: raw.replace(b",", sep)


def _set_toml(old, new):
    def f(text):
        assert old in text, old
        return text.replace(old, new)
    return f


CORPUS: list[Entry] = [
    # --- columns
    Entry("missing_T_air", True, ("'T_air'", "missing"), csv=drop("T_air")),
    Entry("missing_q_net", True, ("'q_net'", "missing"), csv=drop("q_net")),
    Entry("misspelt_T_air", True, ("'T_air'", "did you mean 'Tair'"), csv=rename("T_air", "Tair")),
    Entry("missing_bottom_sensor", True, ("T_5cm",), csv=drop("T_5cm")),
    Entry("duplicated_column", True, ("'T_1cm'", "duplicate"), csv=_duplicate),
    Entry("shuffled_columns", False, csv=_shuffle),
    Entry("extra_column", False, ("battery_V",), csv=_extra, note="a warning line, no source"),
    Entry("unnamed_column", True, ("unnamed",), csv=rename("wind", "")),
    # --- dialects
    Entry("semicolon_separated", True, ("';'-separated",), raw=_sep(b";")),
    Entry("semicolon_decimal_comma", True, ("';'-separated with decimal commas",),
          raw=_decimal_comma_semicolon),
    Entry("decimal_comma", True, ("decimal comma",), raw=_decimal_comma),
    Entry("tab_separated", True, ("tab-separated",), raw=_sep(b"\t")),
    # --- cells
    Entry("nan_cell", True, ("'T_2cm'", "data row 10"), csv=cell("T_2cm", 10, "NaN")),
    Entry("inf_cell", True, ("'T_2cm'", "data row 10"), csv=cell("T_2cm", 10, "inf")),
    Entry("empty_cell", True, ("'q_net'", "data row 7"), csv=cell("q_net", 7, "")),
    Entry("non_numeric_cell", True, ("'T_air'", "data row 3", "abc"), csv=cell("T_air", 3, "abc")),
    Entry("implausible_temperature", True, ("'T_3cm'", "data row 30"),
          csv=cell("T_3cm", 30, "500")),
    Entry("implausible_q_net", True, ("'q_net'", "data row 30"), csv=cell("q_net", 30, "1e5")),
    Entry("kelvin_temperatures", True, ("kelvin",), csv=_kelvin),
    # --- times
    Entry("non_increasing_time", True, ("'time'", "data row 11"), csv=_swap_times),
    Entry("duplicated_time", True, ("'time'", "data row 11", "repeats"), csv=_repeat_time),
    Entry("unparseable_time", True, ("'time'", "data row 5", "yesterday"),
          csv=cell("time", 5, "yesterday")),
    Entry("mixed_time_zones", True, ("'time'", "data row 40"), csv=_mixed_zones),
    Entry("irregular_time", False, csv=_irregular, note="one step of 20 min among 15 min"),
    # --- shape of the file
    Entry("header_only", True, ("no data rows",), raw=lambda raw: raw.split(b"\n")[0] + b"\n"),
    Entry("one_row", True, ("",), raw=lambda raw: b"\n".join(raw.split(b"\n")[:2]) + b"\n"),
    Entry("empty_file", True, ("empty",), raw=lambda raw: b""),
    Entry("binary_file", True, ("cannot read",), raw=lambda raw: bytes(range(256)) * 8),
    Entry("truncated_last_line", True, ("data row 113", "fields"),
          raw=lambda raw: raw.rstrip(b"\n")[:-30] + b"\n"),
    Entry("utf8_bom", False, raw=lambda raw: b"\xef\xbb\xbf" + raw),
    Entry("crlf_line_ends", False, raw=lambda raw: raw.replace(b"\n", b"\r\n")),
    Entry("latin1_bytes", True, ("UTF-8",), raw=lambda raw: raw.replace(b"wind", b"vent\xe9")),
    # --- the case TOML
    Entry("unknown_prior_dist", True, ("kappa", "gaussian"), file=TOML_NAME,
          toml=_set_toml('dist = "truncnormal", mean = 2.27', 'dist = "gaussian", mean = 2.27')),
    Entry("prior_missing_sd", True, ("kappa", "sd"), file=TOML_NAME,
          toml=_set_toml("mean = 2.27, sd = 0.1135", "mean = 2.27")),
    Entry("negative_prior_sd", True, ("kappa", "sd"), file=TOML_NAME,
          toml=_set_toml("sd = 0.1135", "sd = -0.1135")),
    Entry("negative_sigma", True, ("sigma",), file=TOML_NAME,
          toml=_set_toml("sigma = 0.25", "sigma = -0.25")),
    Entry("observed_beyond_bottom", True, ("T_6cm",),
          toml=_set_toml("observed_cm = [0, 1, 2, 3, 4]", "observed_cm = [0, 1, 2, 3, 4, 6]")),
    Entry("bottom_not_in_file", True, ("T_10cm", "bottom"),
          toml=_set_toml("bottom_cm = 5", "bottom_cm = 10")),
    Entry("window_outside_data", True, ("window_hours",),
          toml=_set_toml("window_hours = [0, 28]", "window_hours = [30, 40]")),
    Entry("misspelt_key", True, ("sigmaa", "did you mean 'sigma'"), file=TOML_NAME,
          toml=_set_toml("sigma = 0.25", "sigmaa = 0.25")),
    Entry("unknown_parameter", True, ("kapa",), file=TOML_NAME,
          toml=_set_toml("[parameters.kappa]", "[parameters.kapa]")),
    Entry("unknown_extension", True, ("two_layr",), file=TOML_NAME,
          toml=_set_toml("extensions = []", 'extensions = ["two_layr"]')),
    Entry("unknown_sampler_option", True, ("strech",), file=TOML_NAME,
          toml=_set_toml("max_seconds = 600", "max_seconds = 600\noptions = { strech = 2.0 }")),
    Entry("invalid_toml", True, ("invalid TOML",), file=TOML_NAME,
          toml=_set_toml("sigma = 0.25", "sigma = 0.25 0.3")),
    Entry("missing_csv", True, ("nope.csv",), file=TOML_NAME,
          toml=_set_toml('csv = "data/measurements.csv"', 'csv = "data/nope.csv"')),
    Entry("string_for_number", True, ("ess_target",), file=TOML_NAME,
          toml=_set_toml("ess_target = 1000", 'ess_target = "many"')),
]


def build(entry: Entry, root: Path) -> Path:
    """Write the entry's case (TOML + CSV) under ``root``; return the TOML's path."""
    data = root / "data"
    data.mkdir(parents=True)
    raw = _text(_rows())
    if entry.csv is not None:
        raw = _text(entry.csv(_rows()))
    if entry.raw is not None:
        raw = entry.raw(raw)
    (data / CSV_NAME).write_bytes(raw)
    text = (REPO / "runs" / "caseA.toml").read_text().replace("../data/reference_case/", "data/")
    text = text.replace('truth = "data/truth.json"\n', "")
    if entry.toml is not None:
        text = entry.toml(text)
    (root / TOML_NAME).write_text(text)
    return root / TOML_NAME


#: a fit that is accepted stops at once: emcee, 12 walkers, 4 steps
QUICK = ["--sampler", "emcee", "--no-progress", "--set", "sampler.max_steps=4",
         "sampler.n_walkers=12"]


def run(entry: Entry, root: Path) -> tuple[int, str, bool]:
    """Fit the entry's case through the CLI: (exit code, stderr, output folder left?)."""
    from pavement_mcmc.cli import main

    case = build(entry, root)
    out = root / "run"
    err, std = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(std):
        try:
            code = main(["fit", str(case), "--out", str(out), *QUICK])
        except SystemExit as exc:  # argparse
            code = int(exc.code or 0)
        except Exception:  # an exception that escaped cli.main: a traceback all the same
            traceback.print_exc()
            code = 1
    return code, err.getvalue(), out.exists()


def classify(entry: Entry, code: int, err: str, left: bool) -> list[str]:
    """The outcome's categories: 'clean error', 'traceback', 'wrongly accepted', 'wrongly
    rejected', 'folder left', 'accepted', and 'vague message' (file or names missing)."""
    out = []
    if "Traceback" in err:
        out.append("traceback")
    if entry.refuse:
        if code != 2:
            out.append("wrongly accepted")
        elif "Traceback" not in err:
            vague = entry.file not in err or any(n.lower() not in err.lower() for n in entry.names)
            out.append("vague message" if vague else "clean error")
        if left:
            out.append("folder left")
    else:
        out.append("accepted" if code in (0, 1) and "Traceback" not in err else "wrongly rejected")
        if "UserWarning" in err or re.search(r"^\s*warnings\.warn\(", err, re.M):
            out.append("raw warning")
        if any(n not in err for n in entry.names):
            out.append("vague message")
    return out


if __name__ == "__main__":  # pragma: no cover
    import tempfile
    from collections import Counter

    tally: Counter = Counter()
    with tempfile.TemporaryDirectory() as tmp:
        for k, e in enumerate(CORPUS):
            code, err, left = run(e, Path(tmp) / f"{k:02d}_{e.name}")
            cats = classify(e, code, err, left)
            tally.update(cats)
            last = err.strip().splitlines()[-1] if err.strip() else ""
            print(f"{e.name:28s} exit {code}  {', '.join(cats):22s} {last[:150]}")
    print(f"\n{len(CORPUS)} inputs:", dict(tally))
