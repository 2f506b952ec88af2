"""The commands' one progress display (``race``, ``evaluate``, ``tournament``, ``train``,
``league train``).

A line on stderr in one style: ``label  42% |############......| what  0:12 ETA 0:17``. On a
terminal it is redrawn in place (carriage returns, at most ten times a second); anywhere else
(a log file, a pipe) it is a plain line per tenth of the job and never a carriage return, so
logs stay readable. ``mode="off"`` shows nothing.

The commands are quiet when piped: without ``--progress``/``--no-progress`` they show the
line only when stderr is a terminal (``progress_mode``); ``--progress`` asks for the plain
lines in a log or a pipe too, ``--no-progress`` for none.
"""

from __future__ import annotations

import math
import sys
import time
from typing import Any, Literal, TextIO

Mode = Literal["auto", "off"]
MODES: tuple[Mode, ...] = ("auto", "off")
WIDTH = 30
"""Characters of the bar itself."""
NO_ETA = -1.0
"""An ``eta`` that shows none: the time left is not known yet (workers starting, kernels
compiling), and extrapolating from it would mislead."""


def clock(seconds: float) -> str:
    """``75.4`` -> ``"1:15"``, ``3725`` -> ``"1:02:05"`` (whole seconds)."""
    seconds = int(max(seconds, 0.0))
    hours, rest = divmod(seconds, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"


class Progress:
    """One job's progress line on ``stream`` (stderr by default).

    Args:
        label: What runs (the line's first word: ``race``, ``train``, ...).
        mode: ``"auto"``: redrawn on a terminal, a plain line per tenth elsewhere; ``"off"``:
            nothing.
        stream: Where to write (stderr by default); a terminal is a stream whose ``isatty()``
            is true.
        delay: Wall seconds before the line first appears (short jobs show none).
        interval: Shortest time between two redraws on a terminal [s].
        elapsed_before: Time the job ran before this display started [s] (a resumed league
            counts its earlier runs): shown in the elapsed time.
    """

    def __init__(self, label: str, mode: Mode = "auto", stream: TextIO | None = None,
                 delay: float = 0.0, interval: float = 0.1, elapsed_before: float = 0.0) -> None:
        if mode not in MODES:
            raise ValueError(f"progress mode must be one of {MODES}, got {mode!r}")
        self.label = label
        self.mode = mode
        self.stream = sys.stderr if stream is None else stream
        self.terminal = bool(getattr(self.stream, "isatty", lambda: False)())
        self.delay = delay
        self.interval = interval
        self.elapsed_before = float(elapsed_before)
        self.start = time.monotonic()
        self._last_draw = -math.inf
        self._tenths = -1
        self._pending: tuple[float, str, float | None] | None = None
        self._printed: tuple[float, str] | None = None
        self._open = False

    def line(self, fraction: float, info: str = "", eta: float | None = None) -> str:
        """The line for ``fraction`` (in [0, 1]) done: ``eta`` [s] left if given (none for
        ``NO_ETA``), else extrapolated from the time so far."""
        fraction = min(max(float(fraction), 0.0), 1.0)
        elapsed = time.monotonic() - self.start + self.elapsed_before
        filled = round(fraction * WIDTH)
        text = f"{self.label} {100 * fraction:3.0f}% |{'#' * filled}{'.' * (WIDTH - filled)}|"
        if info:
            text += f" {info}"
        text += f"  {clock(elapsed)}"
        if eta is None and 0.02 <= fraction < 1.0:  # before that it says little
            eta = elapsed / fraction * (1.0 - fraction)
        if eta is not None and eta >= 0.0 and fraction < 1.0:
            text += f" ETA {clock(eta)}"
        return text

    def update(self, fraction: float, info: str = "", eta: float | None = None,
               force: bool = False) -> None:
        """Show ``fraction`` done (see ``line``): redrawn on a terminal (throttled unless
        ``force``), a plain line when a new tenth is reached elsewhere."""
        if self.mode == "off":
            return
        self._pending = (fraction, info, eta)
        now = time.monotonic()
        if now - self.start < self.delay and not force:
            return
        if self.terminal:
            if force or now - self._last_draw >= self.interval:
                self._last_draw = now
                self._pending = None
                self.stream.write(f"\r{self.line(fraction, info, eta)}\x1b[K")
                self.stream.flush()
                self._open = True
            return
        tenths = math.floor(10 * min(max(fraction, 0.0), 1.0))
        if tenths > self._tenths or (force and (fraction, info) != self._printed):
            self._tenths = tenths
            self._printed = (fraction, info)
            self._pending = None
            self.stream.write(self.line(fraction, info, eta) + "\n")
            self.stream.flush()

    def clear(self) -> None:
        """Take the redrawn line off the terminal (before printing something else there); it
        comes back on the next update (``close`` does not draw it again)."""
        self._pending = None
        if self._open:
            self.stream.write("\r\x1b[K")
            self.stream.flush()
            self._open = False
            self._last_draw = -math.inf

    def message(self, text: str) -> None:
        """Print ``text`` as its own line on the progress stream, also with ``mode="off"``
        (in place of the redrawn line on a terminal, which comes back on the next update)."""
        self.clear()
        self.stream.write(text + "\n")
        self.stream.flush()

    def close(self) -> None:
        """Show the last state given (a throttled redraw may have skipped it) and end the
        line. A job that ended within ``delay`` shows nothing."""
        if self.mode == "off":
            return
        shown = self._open or self._tenths >= 0
        if self._pending is not None and (shown or time.monotonic() - self.start >= self.delay):
            self.update(*self._pending, force=True)
        if self._open:
            self.stream.write("\n")
            self.stream.flush()
            self._open = False


PROGRESS_HELP = ("show progress on stderr: auto: a line redrawn when stderr is a terminal, "
                 "nothing when it is a pipe or a file (quiet when piped); --progress: also a "
                 "plain line per tenth of the job in a log or a pipe; --no-progress: none")


def add_progress_flag(parser: Any) -> None:
    """Add ``--progress/--no-progress`` (``PROGRESS_HELP``; default ``"auto"``, see
    ``progress_mode``) to an argparse parser."""
    import argparse

    parser.add_argument("--progress", action=argparse.BooleanOptionalAction, default="auto",
                        help=PROGRESS_HELP)


def progress_mode(args: Any, stream: TextIO | None = None) -> Mode:
    """The ``Progress`` mode of a command's ``--progress/--no-progress``: ``"off"`` for
    ``--no-progress``, ``"auto"`` for ``--progress``, and without either ``"auto"`` only when
    ``stream`` (stderr by default, where the line goes) is a terminal: a command whose output
    is piped or sent to a file prints no progress lines there unless asked."""
    flag = getattr(args, "progress", "auto")
    if flag is False:
        return "off"
    if flag is True:
        return "auto"
    stream = sys.stderr if stream is None else stream
    return "auto" if bool(getattr(stream, "isatty", lambda: False)()) else "off"
