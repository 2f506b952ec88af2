"""The commands' one progress display: redrawn on a terminal, plain lines elsewhere, nothing
when switched off."""

from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
from pathlib import Path

import pytest

from h2h_racing.cli.command import main
from h2h_racing.common.progress import Progress, add_progress_flag, clock, progress_mode


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
    # Off a terminal the lines are asked for (--progress); without it the command is quiet.
    assert main(["evaluate", "--policy", "racing_line", "--against", "pure_pursuit",
                 "--track", "oval", "--races", "2", "--laps", "1",
                 *([] if terminal else ["--progress"])]) == 0
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


# ------------------------------------------------------------------ quiet when piped

REPO = Path(__file__).resolve().parents[3]
CLI = [sys.executable, "-c",
       "import sys; from h2h_racing.cli.command import main; sys.exit(main(sys.argv[1:]))"]
ENV = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
           GIT_PYTHON_REFRESH="quiet")
BAR = "% |"
"""What every progress line has (``label  42% |###...``) and no table row does."""


def _piped(argv: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    """The command with stdout and stderr both pipes (``h2h-racing ... 2>&1 | cat``)."""
    return subprocess.run(CLI + argv, capture_output=True, text=True, timeout=120, env=ENV,
                          cwd=cwd)


def test_the_mode_follows_the_flag_and_else_whether_stderr_is_a_terminal() -> None:
    parser = argparse.ArgumentParser()
    add_progress_flag(parser)
    default, on, off = (parser.parse_args(a) for a in ([], ["--progress"], ["--no-progress"]))
    assert default.progress == "auto"
    assert progress_mode(default, stream=Terminal()) == "auto"
    assert progress_mode(default, stream=io.StringIO()) == "off"  # a pipe or a file: quiet
    assert progress_mode(on, stream=io.StringIO()) == "auto"  # asked: lines in the log
    assert progress_mode(off, stream=Terminal()) == "off"


def test_evaluate_over_two_tracks_prints_no_progress_lines_when_piped(tmp_path: Path) -> None:
    # It printed "evaluate  50% |###...| 1/2 routes" and "evaluate 100% |...| 2/2 routes" on
    # stderr (a plain line per tenth off a terminal), where a single track printed none.
    run = _piped(["evaluate", "--policy", "racing_line", "--track", "oval,kidney",
                  "--episodes", "1", "--jobs", "1"], tmp_path)
    assert run.returncode == 0, run.stderr
    assert "oval " in run.stdout and "kidney " in run.stdout  # the table is there
    assert BAR not in run.stdout and BAR not in run.stderr, run.stderr


def test_a_tournament_prints_no_progress_lines_when_piped(tmp_path: Path) -> None:
    # It printed "tournament   0% |...| 0/2 races, starting" and two more lines on stderr.
    run = _piped(["tournament", "--players", "racing_line,pure_pursuit", "--tracks", "oval",
                  "--races", "1", "--laps", "1", "--league", "t.sqlite"], tmp_path)
    assert run.returncode == 0, run.stderr
    assert "racing_line" in run.stdout
    assert BAR not in run.stdout and BAR not in run.stderr, run.stderr
