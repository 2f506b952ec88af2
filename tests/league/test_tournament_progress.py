"""The tournament's progress line: redrawn on a terminal, plain lines in a log file."""

from __future__ import annotations

import io

from h2h_racing.league.cli import _Progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_log_file_gets_a_line_per_tenth_and_no_carriage_returns() -> None:
    log = io.StringIO()
    progress = _Progress(log)
    for done in range(1, 26):
        progress(done, 25)
    progress.close()
    lines = log.getvalue().splitlines()
    assert "\r" not in log.getvalue()
    # 1/25 (0 tenths) and then each new tenth: 3, 5, 8, 10, 13, 15, 18, 20, 23, 25.
    assert [line.split()[0] for line in lines] == [
        "1/25", "3/25", "5/25", "8/25", "10/25", "13/25", "15/25", "18/25", "20/25", "23/25",
        "25/25"]


def test_a_terminal_gets_one_redrawn_line() -> None:
    terminal = _Terminal()
    progress = _Progress(terminal)
    for done in range(1, 4):
        progress(done, 3)
    progress.close()
    text = terminal.getvalue()
    assert text.count("\r") == 3 and text.endswith("\n") and text.count("\n") == 1
    assert text.split("\r")[-1].startswith("3/3 races")
