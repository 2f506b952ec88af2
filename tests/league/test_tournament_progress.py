"""The tournament's progress line: the commands' shared display (h2h_racing.common.progress)."""

from __future__ import annotations

import io

from h2h_racing.league.cli import _races_progress
from h2h_racing.common.progress import Progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_log_file_gets_a_line_per_tenth_and_no_carriage_returns() -> None:
    log = io.StringIO()
    progress = Progress("tournament", stream=log)
    callback = _races_progress(progress)
    for done in range(1, 26):
        callback(done, 25)
    progress.close()
    lines = log.getvalue().splitlines()
    assert "\r" not in log.getvalue()
    # 1/25 (0 tenths), each new tenth up to 23/25, and the last state at close (25/25).
    assert len(lines) == 11
    # All races run, not yet rated: 99 %, not 100 % while the ratings are fitted.
    assert lines[-1].startswith("tournament  99% |") and "| 25/25 races, rating" in lines[-1]


def test_the_eta_leaves_out_the_first_races_start_up() -> None:
    """Before: the ETA extrapolated from the first races, which carry the workers' start and
    the kernels' compilation: several times the real time."""
    import time

    log = io.StringIO()
    progress = Progress("tournament", stream=log)
    callback = _races_progress(progress)
    callback(0, 40)
    callback(4, 40)  # the first job: start-up, no ETA to show
    time.sleep(0.05)
    callback(8, 40)
    lines = log.getvalue().splitlines()
    assert lines[0].endswith("0/40 races, starting  0:00") and "ETA" not in lines[0]
    assert "4/40 races, starting" in lines[1] and "ETA" not in lines[1]
    # 4 races in the time since the first job: 32 more take 8 times that (a second or so).
    assert "8/40 races  0:00 ETA 0:0" in lines[2]


def test_a_terminal_gets_one_redrawn_line() -> None:
    terminal = _Terminal()
    progress = Progress("tournament", stream=terminal, interval=0.0)
    callback = _races_progress(progress)
    for done in range(1, 4):
        callback(done, 3)
    progress.close()
    text = terminal.getvalue()
    assert text.count("\r") == 3 and text.endswith("\n") and text.count("\n") == 1
    assert "| 3/3 races" in text.split("\r")[-1]
