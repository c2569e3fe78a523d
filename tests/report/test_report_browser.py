"""The HTML report opened in a real browser (headless Chromium, driven through the DevTools
protocol on a pipe): it loads with no console error, every figure decodes, every link of its
table of contents resolves, and its captions state the run's own stopping rule.

``make test`` installs Debian's ``chromium`` where it can (``make chromium``: root and apt-get);
elsewhere these tests skip, saying so. The page is loaded as written, not modified: the checks
run in the browser after its load event (``Runtime.evaluate``).
"""

from __future__ import annotations

import fcntl
import json
import os
import re
import select
import shutil
import subprocess
import time
from pathlib import Path

import pytest

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--remote-debugging-pipe"]
TIMEOUT = 45.0  # seconds for the whole browser session (about 3 s on an idle machine)

#: what the page shows, computed in the browser after its load event
CHECKS = """(() => ({
  images: [...document.images].map(i => ({alt: i.alt, complete: i.complete,
                                          width: i.naturalWidth, height: i.naturalHeight})),
  toc: [...document.querySelectorAll('nav a')].map(a => ({href: a.getAttribute('href'),
    target: (a.getAttribute('href') || '').startsWith('#')
      && !!document.getElementById(decodeURIComponent(a.getAttribute('href').slice(1)))})),
  text: document.body.innerText,
}))()"""


def _browser() -> str:
    for name in BROWSERS:
        if path := shutil.which(name):
            return path
    pytest.skip(f"no headless browser ({' / '.join(BROWSERS)}) on PATH: `make chromium` installs "
                "Debian's chromium where apt-get can (root)")


class DevTools:
    """Chromium with ``--remote-debugging-pipe``: commands go in on its fd 3 and replies and
    events come out on its fd 4, one JSON message each, ended by a NUL byte."""

    def __init__(self, exe: str, profile: Path, log: Path):
        self.deadline = time.monotonic() + TIMEOUT
        cmd_r, self._cmd_w = os.pipe()
        self._out_r, out_w = os.pipe()

        def onto_3_and_4() -> None:  # in the child: the pipe ends become its fds 3 and 4
            high = [fcntl.fcntl(fd, fcntl.F_DUPFD, 10) for fd in (cmd_r, out_w)]
            os.dup2(high[0], 3)
            os.dup2(high[1], 4)

        with log.open("wb") as err:
            self.proc = subprocess.Popen(
                [exe, *FLAGS, f"--user-data-dir={profile}", "about:blank"], pass_fds=(3, 4),
                preexec_fn=onto_3_and_4, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                stderr=err)
        os.close(cmd_r)
        os.close(out_w)
        self.log, self._buf, self._id, self.events = log, b"", 0, []

    def _message(self) -> dict:
        while b"\0" not in self._buf:
            left = self.deadline - time.monotonic()
            if left <= 0 or not select.select([self._out_r], [], [], left)[0]:
                raise TimeoutError(f"the browser did not answer within {TIMEOUT:g} s; its log: "
                                   f"{self.log.read_text(errors='replace')[-2000:]}")
            chunk = os.read(self._out_r, 1 << 20)
            if not chunk:
                raise RuntimeError(f"the browser exited ({self.proc.poll()}); its log: "
                                   f"{self.log.read_text(errors='replace')[-2000:]}")
            self._buf += chunk
        msg, self._buf = self._buf.split(b"\0", 1)
        return json.loads(msg)

    def send(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        """Run one command; events that arrive meanwhile are kept in :attr:`events`."""
        self._id += 1
        msg = {"id": self._id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self._cmd_w, json.dumps(msg).encode() + b"\0")
        while True:
            reply = self._message()
            if reply.get("id") == self._id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply["result"]
            self.events.append(reply)

    def wait_for(self, event: str) -> None:
        while not any(e.get("method") == event for e in self.events):
            self.events.append(self._message())

    def close(self) -> None:
        try:
            self.send("Browser.close")
        except (OSError, RuntimeError, TimeoutError):
            pass
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        os.close(self._cmd_w)
        os.close(self._out_r)


def open_in_browser(page: Path, tmp: Path) -> tuple[dict, list[str]]:
    """Load ``page`` in headless Chromium; return what :data:`CHECKS` finds after the load
    event and the console errors (console.error / assert, uncaught exceptions, and the
    browser's own error entries: failed loads, refused resources)."""
    dt = DevTools(_browser(), tmp / "profile", tmp / "chromium.log")
    try:
        target = dt.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        s = dt.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        for domain in ("Runtime", "Log", "Page"):
            dt.send(f"{domain}.enable", session=s)
        nav = dt.send("Page.navigate", {"url": page.resolve().as_uri()}, session=s)
        assert "errorText" not in nav, nav
        dt.wait_for("Page.loadEventFired")
        found = dt.send("Runtime.evaluate", {"expression": CHECKS, "returnByValue": True},
                        session=s)["result"]["value"]
    finally:
        dt.close()
    errors = []
    for e in dt.events:
        p = e.get("params", {})
        if e.get("method") == "Runtime.consoleAPICalled" and p["type"] in ("error", "assert"):
            errors.append(" ".join(str(a.get("value", a.get("description"))) for a in p["args"]))
        elif e.get("method") == "Runtime.exceptionThrown":
            errors.append(p["exceptionDetails"].get("text", "exception"))
        elif e.get("method") == "Log.entryAdded" and p["entry"]["level"] == "error":
            errors.append(f"{p['entry']['source']}: {p['entry']['text']} {p['entry'].get('url', '')}")
    return found, errors


def rule_numbers(text: str) -> dict[str, set[str]]:
    """Every ESS target, R-hat bound and IACT length the page's text states."""
    return {"ess": set(re.findall(r"ESS (?:≥|>=) ?(\d+(?:\.\d+)?)", text)),
            "rhat": set(re.findall(r"R(?:\u0302|-hat) < ?(\d+(?:\.\d+)?)", text)),
            "tau": set(re.findall(r"(\d+(?:\.\d+)?) IACT", text))}


def test_the_checks_catch_a_broken_page(tmp_path):
    """The harness sees a console error, a figure that does not decode and a dead contents link
    (so the report test below can fail)."""
    page = tmp_path / "broken.html"
    page.write_text('<!DOCTYPE html><html><body><nav><a href="#s0">ok</a><a href="#s9">dead</a>'
                    '</nav><h2 id="s0">A</h2><img alt="bad" src="data:image/png;base64,AAAA">'
                    '<script>console.error("boom")</script></body></html>', encoding="utf-8")
    found, errors = open_in_browser(page, tmp_path)
    assert any("boom" in e for e in errors), errors
    assert [i["width"] for i in found["images"]] == [0]
    assert [t["target"] for t in found["toc"]] == [True, False]


@pytest.fixture(scope="module")
def report_page(finished_run, tmp_path_factory) -> Path:
    """The report of the conftest's finished Case A run (its rule: ESS >= 30, R-hat < 1.01)."""
    from pavement_mcmc.report import build_report
    from pavement_mcmc.runs import load_view

    _browser()  # skip before building the report when there is no browser
    return build_report(load_view(finished_run), tmp_path_factory.mktemp("report") / "report.html",
                        dpi=40, n_draws=20)


def test_report_loads_in_a_browser_with_every_figure_and_link(report_page, finished_run, tmp_path):
    found, errors = open_in_browser(report_page, tmp_path)
    assert errors == [], errors
    images = found["images"]
    assert len(images) >= 5, images
    broken = [i["alt"] for i in images if not (i["complete"] and i["width"] > 0 and i["height"] > 0)]
    assert not broken, f"figures that do not decode: {broken}"
    assert len(found["toc"]) >= 5
    dead = [t["href"] for t in found["toc"] if not t["target"]]
    assert not dead, f"table-of-contents links without a target: {dead}"
    # the captions and the verdict state the rule the run was held to (result.json), and no other
    result = json.loads((finished_run / "result.json").read_text())["rule"]
    stated = rule_numbers(found["text"])
    assert stated["ess"] == {f"{result['ess_target']:g}"}, stated
    assert stated["rhat"] == {f"{result['rhat_max']:g}"}, stated
    assert stated["tau"] == {f"{result['min_tau_lengths']:g}"}, stated
