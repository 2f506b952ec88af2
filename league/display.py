"""What a league run shows while it runs: one progress line (``h2h_racing.common.progress``)
over its time budget with the round's phase and that phase's own count, the round lines, and
the same lines in ``league.log`` beside ``league.sqlite``.

The line reads, for example::

    league  41% |############..................| round 7, train 52/90 iterations  12:17 ETA 17:43

The share is of the budget (``minutes``: the league's time in all runs, or this run's), or of
the round cap when that is nearer; it stays below 100 % until the run has ended. The ETA is the
budget left, which is exact whatever compiles: the run stops within one training iteration of
it. The round cap is shown (``round 7 of 10``) only when a config sets one. A thread redraws
the line twice a second on a terminal, so the clock moves and the count follows the workers;
elsewhere (a pipe, a log) the line is printed once per tenth of the budget, as the other
commands' lines are, however long a phase runs. Round lines and notes are printed in both
cases and appended to the log with the time.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import TextIO

from h2h_racing.common.progress import Mode, Progress

LOG_FILE = "league.log"
"""The run's log, beside ``league.sqlite``."""
REDRAW = 0.5
"""Seconds between two redraws by the display's thread."""
BELOW_DONE = 0.99
"""Highest share shown while the run has work left."""


def minutes_text(value: float) -> str:
    """``30.0`` -> ``30``, ``0.25`` -> ``0.25``, ``0.1527`` -> ``0.15``."""
    return f"{value:.2f}".rstrip("0").rstrip(".")


class LeagueDisplay:
    """The display of one ``League.run``.

    Args:
        name: The league's name (the round lines' prefix).
        folder: The league folder (``LOG_FILE`` is appended to there).
        budget: The time budget [s] on the league's clock.
        used: League time already spent when this run started [s].
        max_rounds: The round cap; shown only when ``show_cap``.
        show_cap: Whether the config set a round cap to show.
        mode: ``"auto"`` or ``"off"`` (round lines only), as ``Progress``.
        stream: Where to write (stderr when None).
    """

    def __init__(self, name: str, folder: Path, budget: float, used: float, max_rounds: int,
                 show_cap: bool, mode: Mode = "auto", stream: TextIO | None = None) -> None:
        self.name = name
        self.log_path = Path(folder) / LOG_FILE
        self.budget = float(budget)
        self.used = float(used)
        self.max_rounds = max_rounds
        self.show_cap = show_cap
        self.progress = Progress("league", mode=mode, stream=stream, elapsed_before=used)
        self.started = time.monotonic()
        self._lock = threading.RLock()
        self._round = 0
        self._rounds_done = 0
        self._phase = "starting"
        self._count: Callable[[], tuple[int, int]] | None = None
        self._unit = ""
        self._closed = threading.Event()
        self._thread: threading.Thread | None = None

    # ---- clock

    def elapsed(self) -> float:
        """League time [s]: earlier runs' and this run's."""
        return self.used + time.monotonic() - self.started

    def left(self) -> float:
        """Budget left [s] (0 when spent)."""
        return max(self.budget - self.elapsed(), 0.0)

    # ---- what is shown

    def start(self) -> None:
        """Draw the line now and keep it moving: redrawn on a terminal, a line on each new
        tenth elsewhere (also while one phase runs long)."""
        self.draw(force=self.progress.terminal)
        if self.progress.mode != "off":
            self._thread = threading.Thread(target=self._tick, name="league-display",
                                            daemon=True)
            self._thread.start()

    def phase(self, round_index: int, phase: str, count: Callable[[], tuple[int, int]] | None,
              unit: str = "", rounds_done: int | None = None) -> None:
        """Show round ``round_index`` (0-based) in ``phase`` (``train``, ``evaluate``,
        ``place``), with ``count()`` giving (done, total) in ``unit``."""
        with self._lock:
            self._round = round_index
            self._phase = phase
            self._count = count
            self._unit = unit
            if rounds_done is not None:
                self._rounds_done = rounds_done
        # Redrawn at once on a terminal; elsewhere a line only on a new tenth (quiet in logs).
        self.draw(force=self.progress.terminal)

    def info(self) -> str:
        """The line's text after the bar."""
        with self._lock:
            text = f"round {self._round + 1}"
            if self.show_cap:
                text += f" of {self.max_rounds}"
            text += f", {self._phase}"
            if self._count is not None:
                done, total = self._count()
                text += f" {done}/{total}"
                if self._unit:
                    text += f" {self._unit}"
                if not done and self._phase == "train":
                    text += ", starting"  # workers building the learners, kernels compiling
        return text

    def fraction(self) -> float:
        """Share of the run done: of the budget, or of the round cap when that is nearer;
        below 100 % while the run goes on."""
        by_time = self.elapsed() / self.budget if self.budget > 0 else 0.0
        by_rounds = self._rounds_done / self.max_rounds
        return min(max(by_time, by_rounds), BELOW_DONE)

    def draw(self, force: bool = False) -> None:
        """Redraw the line (a terminal) or print it on a new tenth (elsewhere)."""
        if self._closed.is_set():
            return
        with self._lock:
            self.progress.update(self.fraction(), self.info(), eta=self.left(), force=force)

    def say(self, text: str) -> None:
        """Print ``text`` as its own line (also with ``--no-progress``) and log it."""
        with self._lock:
            self.progress.message(text)
        self.log(text)

    def log(self, text: str) -> None:
        """Append ``text`` to the log, each line after the local time."""
        stamp = time.strftime("%Y-%m-%d %H:%M:%S")
        try:
            with open(self.log_path, "a", encoding="utf-8") as log:
                for line in text.splitlines() or [""]:
                    log.write(f"{stamp}  {line}\n")
        except OSError:
            pass  # a log that cannot be written must not stop the league

    def close(self, finished: bool, rounds_done: int, why: str = "done") -> None:
        """End the line after ``rounds_done`` rounds: at 100 % when the run ``finished`` (saying
        ``why``: ``done``, ``budget spent``), else where it stood (``stopped``)."""
        self._closed.set()
        if self._thread is not None:
            self._thread.join()
        with self._lock:
            self._rounds_done = rounds_done
            self._count = None
            if finished:
                self._phase = why
                if why == "done":
                    self._round = max(rounds_done - 1, 0)
                self.progress.update(1.0, self.info(), eta=0.0, force=True)
            else:
                self._phase = "stopped"
                self.progress.update(self.fraction(), self.info(), eta=self.left(),
                                     force=self.progress.terminal)
            self.progress.close()

    def _tick(self) -> None:
        while not self._closed.wait(REDRAW):
            self.draw()
