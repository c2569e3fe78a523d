"""Progress of a fit toward its stopping rule (min ESS so far / target), drawn by the command
line from the run loop's callback (library code prints nothing).

On a terminal one line is rewritten in place; into a file or a pipe a plain line is written at
most every ``every`` seconds (and at the end), so a redirected log stays readable.
"""

from __future__ import annotations

import sys
import time


def describe(info: dict) -> str:
    """One line: the phase, the minimum ESS against its target, steps, acceptance, time."""
    n = info["n_steps"]
    tail = f"acceptance {info['acceptance']:.2f}, {info['elapsed']:.0f} s"
    if info["adapting"]:
        return f"adapting the proposal: step {n}/{info['n_adapt']}; {tail}"
    ess, target = info.get("min_ess"), info["ess_target"]
    if ess is None:
        return f"sampling: step {n}, ESS not checked yet (target {target:g}); {tail}"
    pct = min(100.0, 100.0 * ess / target)
    held = info.get("held")
    wait = f"; held by {held}" if held and not held.startswith("ESS") else ""
    return f"min ESS {ess:.0f}/{target:g} ({pct:.0f}%){wait} at step {n}; {tail}"


class Progress:
    """A callback for :func:`~pavement_mcmc.runs.fit` / ``resume`` that shows progress."""

    def __init__(self, stream=None, every: float = 10.0, clock=time.monotonic):
        self.stream = stream if stream is not None else sys.stderr
        isatty = getattr(self.stream, "isatty", None)
        self.tty = bool(isatty and isatty())
        self.every, self.clock = float(every), clock
        self._last_time = None
        self._last_text = ""
        self._width = 0

    def __call__(self, info: dict) -> None:
        text = describe(info)
        self._last_text = text
        if self.tty:
            self.stream.write("\r" + text.ljust(self._width))
            self._width = len(text)
            self.stream.flush()
            return
        now = self.clock()
        if self._last_time is None or now - self._last_time >= self.every:
            self._last_time = now
            self.stream.write(text + "\n")
            self.stream.flush()
            self._last_text = ""

    def close(self) -> None:
        """End the line on a terminal; elsewhere write the last state if not yet written."""
        if self.tty and self._width:
            self.stream.write("\n")
        elif not self.tty and self._last_text:
            self.stream.write(self._last_text + "\n")
        self.stream.flush()
