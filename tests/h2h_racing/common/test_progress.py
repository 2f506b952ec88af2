"""The commands' one progress display: redrawn on a terminal, plain lines elsewhere, nothing
when switched off."""

from __future__ import annotations

import io

import pytest

from h2h_racing.cli.command import main
from h2h_racing.common.progress import Progress, clock


class Terminal(io.StringIO):
    """A stream that says it is a terminal."""

    def isatty(self) -> bool:
        return True


def test_a_terminal_gets_one_redrawn_line() -> None:
    stream = Terminal()
    progress = Progress("job", stream=stream, interval=0.0)
    for done in range(1, 5):
        progress.update(done / 4, f"{done}/4 things")
    progress.close()
    text = stream.getvalue()
    assert text.count("\r") == 4 and text.count("\n") == 1 and text.endswith("\n")
    last = text.rstrip("\n").split("\r")[-1]
    assert last.startswith("job 100% |" + "#" * 30 + "| 4/4 things"), last
    assert "ETA" not in last  # nothing left


def test_a_log_file_gets_a_line_per_tenth_and_no_carriage_returns() -> None:
    stream = io.StringIO()
    progress = Progress("job", stream=stream)
    for done in range(1, 26):
        progress.update(done / 25, f"{done}/25")
    progress.close()
    assert "\r" not in stream.getvalue() and "\x1b" not in stream.getvalue()
    # 1/25 (0 tenths) and then each new tenth: 3, 5, 8, 10, 13, 15, 18, 20, 23, 25.
    assert [line.split("| ")[1].split()[0] for line in stream.getvalue().splitlines()] == [
        "1/25", "3/25", "5/25", "8/25", "10/25", "13/25", "15/25", "18/25", "20/25", "23/25",
        "25/25"]


def test_off_shows_no_progress_but_messages() -> None:
    stream = Terminal()
    progress = Progress("job", mode="off", stream=stream)
    progress.update(0.5, "half")
    progress.message("a result")
    progress.close()
    assert stream.getvalue() == "a result\n"


def test_a_message_takes_the_redrawn_lines_place() -> None:
    stream = Terminal()
    progress = Progress("job", stream=stream, interval=0.0)
    progress.update(0.5)
    progress.message("a result")
    progress.update(0.75)
    progress.close()
    # the line is erased before the message, and drawn again after it
    assert stream.getvalue().split("\r")[2] == "\x1b[Ka result\n"
    assert stream.getvalue().split("\r")[-1].startswith("job  75%")


def test_given_eta_and_clock() -> None:
    progress = Progress("job", stream=io.StringIO())
    assert progress.line(0.5, "x", eta=3725).endswith("ETA 1:02:05")
    assert clock(75.4) == "1:15"
    with pytest.raises(ValueError, match="progress mode must be one of"):
        Progress("job", mode="loud")


@pytest.mark.parametrize("terminal", [True, False])
def test_evaluate_against_shows_races_done(terminal: bool, monkeypatch: pytest.MonkeyPatch,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    # It used to be silent for more than a minute.
    stream = Terminal() if terminal else io.StringIO()
    monkeypatch.setattr("sys.stderr", stream)
    assert main(["evaluate", "--policy", "racing_line", "--against", "pure_pursuit",
                 "--track", "oval", "--races", "2", "--laps", "1"]) == 0
    text = stream.getvalue()
    assert ("\r" in text) == terminal
    assert "races vs pure_pursuit on oval (1/1)" in text
    if not terminal:  # on a terminal the line is cleared for the table's row
        assert text.splitlines()[-1].startswith("evaluate 100% |"), text
        assert "2/2 races vs pure_pursuit on oval (1/1)" in text
    assert "pure_pursuit" in capsys.readouterr().out  # the table stays on stdout


def test_no_progress_writes_nothing_to_stderr(monkeypatch: pytest.MonkeyPatch) -> None:
    stream = Terminal()
    monkeypatch.setattr("sys.stderr", stream)
    assert main(["evaluate", "--policy", "racing_line", "--against", "pure_pursuit",
                 "--track", "oval", "--races", "2", "--laps", "1", "--no-progress"]) == 0
    assert stream.getvalue() == ""


def test_a_log_file_gets_the_last_state_once() -> None:
    stream = io.StringIO()
    progress = Progress("job", stream=stream)
    progress.update(0.55, "a")
    progress.update(0.58, "b")  # same tenth: not printed yet
    progress.close()  # prints it
    progress = Progress("job", stream=stream)
    progress.update(1.0, "c")
    progress.update(1.0, "c")
    progress.close()
    assert [line.split("| ")[1].split()[0] for line in stream.getvalue().splitlines()] == [
        "a", "b", "c"]
