"""A one-line progress indicator for long commands, drawn only on a terminal."""

from __future__ import annotations

import sys
import threading
import time
from typing import Any


def is_terminal(stream: Any) -> bool:
    isatty = getattr(stream, "isatty", None)
    try:
        return bool(isatty and isatty())
    except ValueError:  # closed stream
        return False


class Progress:
    """A one-line progress indicator on stderr, drawn only when stderr is a terminal.

    Without ``total`` a spinner with the elapsed time; with ``total`` a bar
    advanced by :meth:`advance`. Nothing is drawn during the first ``delay``
    seconds, so quick work shows nothing; the line is erased at the end.
    """

    WIDTH = 24
    SPIN = "|/-\\"

    def __init__(self, label: str, total: int | None = None, *, stream: Any = None,
                 delay: float = 0.5, interval: float = 0.1) -> None:
        self.label = label
        self.total = total
        self.done = 0
        self.stream = sys.stderr if stream is None else stream
        self.enabled = is_terminal(self.stream)
        self.delay = delay
        self.interval = interval
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._start = 0.0
        self._drawn = 0

    def __enter__(self) -> Progress:
        self._start = time.perf_counter()
        if self.enabled:
            self._thread = threading.Thread(target=self._run, daemon=True)
            self._thread.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._thread is not None:
            self._stop.set()
            self._thread.join()
            if self._drawn:
                self.stream.write("\r" + " " * self._drawn + "\r")
                self.stream.flush()

    def advance(self, step: int = 1) -> None:
        """Count ``step`` more units of work done."""
        self.done += step

    def line(self) -> str:
        """The text of the indicator now."""
        elapsed = time.perf_counter() - self._start
        if self.total:
            filled = int(self.WIDTH * min(self.done, self.total) / self.total)
            bar = "#" * filled + "." * (self.WIDTH - filled)
            return f"{self.label} [{bar}] {self.done}/{self.total} {elapsed:.0f} s"
        spin = self.SPIN[int(elapsed / self.interval) % len(self.SPIN)]
        return f"{self.label} {spin} {elapsed:.0f} s"

    def _run(self) -> None:
        if self._stop.wait(self.delay):
            return
        last = ""
        while True:
            text = self.line()
            if text != last:
                self.stream.write("\r" + text.ljust(self._drawn))
                self.stream.flush()
                self._drawn = max(self._drawn, len(text))
                last = text
            if self._stop.wait(self.interval):
                return
