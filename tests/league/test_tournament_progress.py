"""The tournament's progress line: the commands' shared display (h2h_racing.progress)."""

from __future__ import annotations

import io

from h2h_racing.league.cli import _races_progress
from h2h_racing.progress import Progress


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
    assert len(lines) == 11  # 1/25 (0 tenths) and each new tenth
    assert lines[-1].startswith("tournament 100% |") and "| 25/25 races" in lines[-1]


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
