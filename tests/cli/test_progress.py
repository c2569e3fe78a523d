"""Issue 11, item 6: progress is shown toward the stopping rule (min ESS / target), not toward
max_steps; a redirected log gets plain lines, at most one every few seconds; the library prints
nothing."""

from __future__ import annotations

import io

from conftest import REPO

from pavement_mcmc.cli import main
from pavement_mcmc.cli.progress import Progress, describe


def _info(n, ess=None, adapting=False):
    return {"n_steps": n, "n_adapt": 150, "max_steps": 200000, "ess_target": 1000.0,
            "acceptance": 0.5, "adapting": adapting, "min_ess": ess, "elapsed": n / 10}


class _Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        self.t += 1.0  # one second per block
        return self.t


def test_describe_shows_ess_against_target():
    assert "min ESS 250/1000 (25%)" in describe(_info(400, 250.0))
    assert "adapting" in describe(_info(20, adapting=True))
    assert "200000" not in describe(_info(400, 250.0))


def test_the_line_says_what_holds_a_run_whose_ess_is_met():
    """With the ESS met a run may wait on R-hat, drift or Geweke: the line says which (the
    grass energy case waited thousands of steps on Geweke while its line showed only ESS)."""
    held = "Geweke: 2 of 13 principal components differ (about 0.7 expected by chance)"
    line = describe({**_info(9000, 7000.0), "held": held})
    assert "min ESS 7000/1000 (100%); held by Geweke: 2 of 13" in line
    assert "held by" not in describe({**_info(400, 250.0), "held": "ESS 250 < 1000 (kappa)"})
    assert "held by" not in describe(_info(400, 250.0))


def test_the_run_loop_passes_the_last_checks_failure_to_the_callback():
    from types import SimpleNamespace as NS

    import numpy as np

    from pavement_mcmc.diagnostics.stopping import StoppingRule
    from pavement_mcmc.runs.loop import _progress

    b = NS(accepted=np.array([1.0, 0.0]))
    failed = NS(failures=["R-hat 1.020 >= 1.01 (C)"])
    assert _progress(StoppingRule(), 50.0, b, 1.0, failed)["held"] == "R-hat 1.020 >= 1.01 (C)"
    assert _progress(StoppingRule(), 50.0, b, 1.0, NS(failures=[]))["held"] is None
    assert _progress(StoppingRule(), None, b, 1.0)["held"] is None


def test_non_tty_stream_gets_sparse_plain_lines():
    stream = io.StringIO()
    bar = Progress(stream, every=10.0, clock=_Clock())
    for k in range(100):
        bar(_info(200 + 10 * k, float(k)))
    bar.close()
    text = stream.getvalue()
    assert "\r" not in text
    lines = text.splitlines()
    assert 9 <= len(lines) <= 12  # one every 10 s over 100 s, and the last state
    assert lines[-1].startswith("min ESS 99/1000")


def test_tty_stream_rewrites_one_line():
    class Tty(io.StringIO):
        def isatty(self):
            return True

    stream = Tty()
    bar = Progress(stream)
    for k in range(5):
        bar(_info(200 + k, float(k)))
    bar.close()
    assert stream.getvalue().count("\r") == 5 and stream.getvalue().endswith("\n")


def test_library_prints_nothing_and_cli_log_is_readable(tmp_path, capsys):
    from pavement_mcmc.runs import fit

    fit(REPO / "runs" / "caseA.toml", tmp_path / "lib", seed=1,
        overrides={"sampler": {"kind": "fast", "max_steps": 170}})
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err == ""
    main(["fit", str(REPO / "runs" / "caseA.toml"), "--out", str(tmp_path / "cli"), "--set",
          "sampler.max_steps=170"])
    err = capsys.readouterr().err  # captured: not a terminal
    assert "\r" not in err and ("adapting" in err or "min ESS" in err)
    assert "/200000" not in err and "it/s" not in err
