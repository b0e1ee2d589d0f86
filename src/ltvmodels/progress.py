"""A one-line progress indicator for long work, drawn only on a terminal.

At the bottom of the layers (it uses only the standard library): the command
line and :func:`ltvmodels.fit_many` draw it.
"""

from __future__ import annotations

import sys
import threading
import time
from typing import Any

__all__ = ["Progress"]


def _is_terminal(stream: Any) -> bool:
    isatty = getattr(stream, "isatty", None)
    try:
        return bool(isatty and isatty())
    except ValueError:  # closed stream
        return False


class Progress:
    """A one-line progress indicator on stderr, drawn only when stderr is a terminal.

    Without ``total`` a spinner with the elapsed time; with ``total`` a bar
    advanced by :meth:`advance`. Nothing is drawn during the first ``delay``
    seconds, so quick work shows nothing; the line is erased at the end. With
    ``unit`` (e.g. "units") the bar adds the rate and the time left.

    The line is redrawn by a thread every ``interval`` seconds, or, with
    ``threaded=False``, by :meth:`advance` itself (at most every ``interval``
    seconds): then the caller's process runs no extra thread, which a caller
    that forks worker processes needs.
    """

    WIDTH = 24
    SPIN = "|/-\\"

    def __init__(
        self,
        label: str,
        total: int | None = None,
        *,
        stream: Any = None,
        delay: float = 0.5,
        interval: float = 0.1,
        unit: str = "",
        threaded: bool = True,
    ) -> None:
        self.label = label
        self.threaded = threaded
        self._last_draw = 0.0
        self._last_text = ""
        self.unit = unit
        self.total = total
        self.done = 0
        self.stream = sys.stderr if stream is None else stream
        self.enabled = _is_terminal(self.stream)
        self.delay = delay
        self.interval = interval
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._start = 0.0
        self._drawn = 0

    def __enter__(self) -> Progress:
        self._start = time.perf_counter()
        if self.enabled and self.threaded:
            self._thread = threading.Thread(target=self._run, daemon=True)
            self._thread.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._thread is not None:
            self._stop.set()
            self._thread.join()
        if self.enabled:
            if self._drawn:
                self.stream.write("\r" + " " * self._drawn + "\r")
                self.stream.flush()

    def advance(self, step: int = 1) -> None:
        """Count ``step`` more units of work done."""
        self.done += step
        if self.enabled and not self.threaded:
            now = time.perf_counter()
            if now - self._start >= self.delay and now - self._last_draw >= self.interval:
                self._last_draw = now
                self._draw()

    def line(self) -> str:
        """The text of the indicator now."""
        elapsed = time.perf_counter() - self._start
        if self.total:
            filled = int(self.WIDTH * min(self.done, self.total) / self.total)
            bar = "#" * filled + "." * (self.WIDTH - filled)
            text = f"{self.label} [{bar}] {self.done}/{self.total} {elapsed:.0f} s"
            if self.unit and self.done and elapsed > 0:  # rate and time left
                rate = self.done / elapsed
                left = max(self.total - self.done, 0) / rate
                text += f", {rate:.3g} {self.unit}/s, {left:.0f} s left"
            return text
        spin = self.SPIN[int(elapsed / self.interval) % len(self.SPIN)]
        return f"{self.label} {spin} {elapsed:.0f} s"

    def _run(self) -> None:
        if self._stop.wait(self.delay):
            return
        while True:
            self._draw()
            if self._stop.wait(self.interval):
                return

    def _draw(self) -> None:
        text = self.line()
        if text != self._last_text:
            self.stream.write("\r" + text.ljust(self._drawn))
            self.stream.flush()
            self._drawn = max(self._drawn, len(text))
            self._last_text = text
