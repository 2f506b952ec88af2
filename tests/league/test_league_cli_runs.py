"""`league train` and `tournament` as a user runs them (issue 37): a command in a fresh process,
on a terminal (a pseudo-terminal) or writing to files, stopped with a Ctrl-C sent to its
whole process group as a terminal sends it (the command and its worker processes).

The smallest leagues: one learner on `oval`, 2 env copies of 4 steps, one anchor, one-lap
races. Subprocess timeouts only catch a hang; no test asserts a duration. Each runs for 10 to
40 s on two busy cores, so all are marked slow (`python -m pytest tests/league -m slow`); the
mechanisms behind them are tested in process, in the default run, by ``test_league_stop.py``
and ``test_backends.py``.
"""

from __future__ import annotations

import os
import re
import select
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("torch")

REPO = Path(__file__).resolve().parents[2]
CLI = [sys.executable, "-c",
       "import sys; from h2h_racing.cli.command import main; sys.exit(main(sys.argv[1:]))"]
ENV = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
           GIT_PYTHON_REFRESH="quiet")


def _config(tmp_path: Path, iterations: int = 1, rounds: int | None = 1) -> Path:
    path = tmp_path / "tiny.toml"
    cap = f"max_rounds = {rounds}\n" if rounds is not None else ""
    path.write_text(f"""\
name = "tiny"
tracks = ["oval"]
init = "racing_line_student"
anchors = ["racing_line"]
{cap}seed = 0

[training]
iterations_per_round = {iterations}
num_envs = 2
num_steps_per_env = 4

[snapshots]
min_rounds = 1
max_rounds = 1

[races]
eval_races = 1
placement_races = 1
laps = 1

[[learners]]
name = "main"
role = "main"
""")
    return path


def _run(argv: list[str], cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run(CLI + argv, capture_output=True, text=True, timeout=timeout, env=ENV,
                          cwd=cwd, check=False)


def _on_a_terminal(argv: list[str], cwd: Path, timeout: float = 300) -> tuple[int, str]:
    """Run the command with a pseudo-terminal as stdin, stdout and stderr; its exit status
    and everything it wrote (terminal line ends as "\\n")."""
    import pty

    master, slave = pty.openpty()
    process = subprocess.Popen(CLI + argv, stdin=slave, stdout=slave, stderr=slave, env=ENV,
                               cwd=cwd, start_new_session=True)
    os.close(slave)
    chunks = []
    end = time.monotonic() + timeout
    try:
        while time.monotonic() < end:
            ready, _, _ = select.select([master], [], [], 1.0)
            if not ready:
                continue
            try:
                data = os.read(master, 65536)
            except OSError:  # EIO: the command and every process on the terminal ended
                break
            if not data:
                break
            chunks.append(data)
        status = process.wait(timeout=max(end - time.monotonic(), 1.0))
    finally:
        if process.poll() is None:
            process.kill()
        os.close(master)
    return status, b"".join(chunks).decode().replace("\r\n", "\n")


def _wait_for(check, what: str, timeout: float = 180.0) -> None:
    end = time.monotonic() + timeout
    while not check():
        if time.monotonic() > end:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.2)


def _ctrl_c(process: subprocess.Popen) -> None:
    """What a terminal's Ctrl-C does: SIGINT to the foreground process group."""
    os.killpg(process.pid, signal.SIGINT)


def _group_gone(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return True
    return False


def _resume_argv(line: str, marker: str) -> list[str]:
    command = shlex.split(line.split(marker, 1)[1])
    assert command[0] == "h2h-racing"
    return command[1:]


# ------------------------------------------------------------------------- point 1 and 2


@pytest.mark.slow
def test_league_train_shows_its_phases_logs_them_and_ends_with_the_league_table(tmp_path):
    """Before: nothing on the terminal until the first round had ended, no log file, and a
    final table of the frozen players only (no learners), rated by another fit than
    `league table`'s."""
    config = _config(tmp_path)
    status, shown = _on_a_terminal(["league", "train", "--config", str(config), "--out",
                                    "league", "--backend", "inprocess"], tmp_path)
    assert status == 0, shown
    # Life first: the start line, then the line redrawn with the round's phase and count,
    # all before the round's own line.
    assert shown.startswith("[league tiny] starting in league: 0.0 of 30 min used"), shown
    round_line = shown.index("[league tiny] round 1 ")
    assert re.search(r"\rleague +\d+% \|[#.]+\| round 1 of 1, train \d/1 iterations",
                     shown[:round_line]), shown
    assert "round 1 of 1, evaluate 0/2 races" in shown[:round_line]
    # The log beside league.sqlite holds the lines said, each after its time.
    log = (tmp_path / "league" / "league.log").read_text()
    assert re.search(r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d  \[league tiny\] starting in league",
                     log, re.M)
    assert "[league tiny] round 1 " in log and "ended at its round cap, 1 rounds" in log
    # One table: exactly what `league table` prints for the file, every player in it.
    table = _run(["league", "table", "--league", "league/league.sqlite"], tmp_path)
    assert table.returncode == 0, table.stderr
    assert ("ratings of every player in league/league.sqlite (the table `h2h-racing league "
            "table --league league/league.sqlite` prints):\n" + table.stdout) in shown
    players = {line.split()[1] for line in table.stdout.splitlines()[3:]
               if line[:3].strip().isdigit()}
    assert players == {"main", "main_v1", "racing_line"}


# ------------------------------------------------------------------------------- point 3


@pytest.mark.slow
def test_ctrl_c_stops_league_train_at_a_safe_point_and_its_command_resumes(tmp_path):
    """Before: a KeyboardInterrupt traceback from concurrent.futures and the workers ("Exception
    ignored from cffi callback"), about 20 s to stop, exit status -2, no word on resuming; the
    rerun lost the interrupted round's training."""
    config = _config(tmp_path, iterations=100_000, rounds=None)  # a round longer than the test
    out, err = tmp_path / "out.txt", tmp_path / "err.txt"
    argv = ["league", "train", "--config", str(config), "--out", "league", "--rounds", "1",
            "--backend", "local", "--workers", "1"]
    with open(out, "w") as stdout, open(err, "w") as stderr:
        process = subprocess.Popen(CLI + argv, stdout=stdout, stderr=stderr, env=ENV,
                                   cwd=tmp_path, start_new_session=True)
    progress = tmp_path / "league" / "learners" / "main" / "progress"
    try:
        # In the middle of round 1's PPO iterations (the worker counts them in this file).
        _wait_for(lambda: progress.is_file() and int(progress.read_text().split()[1]) >= 2,
                  "the learner's second iteration")
        _ctrl_c(process)
        status = process.wait(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    text = err.read_text()
    assert status == 130, text
    for noise in ("Traceback", "KeyboardInterrupt", "Exception ignored"):
        assert noise not in text, text
    _wait_for(lambda: _group_gone(process.pid), "the worker processes to end", timeout=30)
    last = text.rstrip().splitlines()[-1]
    kept = re.search(r"kept its training \(main (\d+)/100000 iterations\)", last)
    assert last.startswith("[league tiny] stopped (Ctrl-C) after ") and kept, text
    assert last in (tmp_path / "league" / "league.log").read_text()
    resume = _resume_argv(last, "; to resume: ")
    assert resume == ["league", "train", "--config", str(config), "--out", "league",
                      "--rounds", "1", "--workers", "1"]
    from h2h_racing.league.store import LeagueStore

    with LeagueStore(tmp_path / "league" / "league.sqlite") as store:
        meta = store.meta()
    # The iterations it stopped after are the round's training, recorded: 2 copies x 4 steps.
    assert meta["main.trained_round"] == "0" and meta.get("round", "0") == "0"
    assert int(meta["main.steps"]) == int(kept.group(1)) * 2 * 4
    assert float(meta["elapsed_seconds"]) > 0

    # The command it printed resumes the round where it stopped: its races, not its training.
    again = _run(resume, tmp_path)
    assert again.returncode == 0, again.stderr
    assert "[league tiny] resuming at round 1 in league" in again.stderr
    assert "ended at its round cap, 1 rounds" in again.stdout
    with LeagueStore(tmp_path / "league" / "league.sqlite") as store:
        assert store.meta()["main.steps"] == meta["main.steps"]
        assert store.count_matches(context="league:tiny:eval") == 2


@pytest.mark.slow
def test_ctrl_c_stops_a_tournament_with_one_line_and_its_command_plays_the_rest(tmp_path):
    """Before: a KeyboardInterrupt traceback (and the workers' own), waiting for the running
    races, no word on resuming."""
    tracks = "oval,speedway,kidney,grand_loop,hairpin_valley,varying,technical"
    argv = ["tournament", "--players", "racing_line,pure_pursuit,blocker", "--tracks", tracks,
            "--laps", "3", "--league", "t.sqlite", "--workers", "1"]  # 2 races by default
    err = tmp_path / "err.txt"
    with open(err, "w") as stderr:
        # --progress: the progress lines in the file (quiet without it off a terminal) tell
        # when the first races are stored; the resume command leaves the flag out.
        process = subprocess.Popen(CLI + argv + ["--progress"], stdout=subprocess.DEVNULL,
                                   stderr=stderr, env=ENV, cwd=tmp_path, start_new_session=True)
    try:
        # 3 pairs x 7 tracks = 21 jobs of 4 races: stop after the first few.
        _wait_for(lambda: re.search(r"\b[1-9]\d*/84 races", err.read_text()),
                  "the first races stored")
        _ctrl_c(process)
        status = process.wait(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    text = err.read_text()
    assert status == 130, text
    for noise in ("Traceback", "KeyboardInterrupt", "Exception ignored"):
        assert noise not in text, text
    _wait_for(lambda: _group_gone(process.pid), "the worker processes to end", timeout=30)
    last = text.rstrip().splitlines()[-1]
    stored = re.match(r"tournament 'default' stopped \(Ctrl-C\): (\d+) of 84 races stored in "
                      r"t\.sqlite", last)
    assert stored and 0 < int(stored.group(1)) < 84, text
    resume = _resume_argv(last, "; to play the rest: ")
    assert resume == argv
    rest = _run(resume, tmp_path)
    assert rest.returncode == 0, rest.stderr
    done = int(stored.group(1))
    assert f"tournament 'default': {84 - done} races run, {done} already in t.sqlite" in \
        rest.stdout


# ------------------------------------------------------------------------------- point 4


@pytest.mark.slow
def test_minutes_end_a_league_within_an_iteration_and_count_all_its_runs(tmp_path):
    """Before: the round that crossed the budget ran to its end (here a million PPO
    iterations), and a rerun of the command trained for the whole budget again."""
    config = _config(tmp_path, iterations=1_000_000, rounds=None)
    argv = ["league", "train", "--config", str(config), "--out", "league", "--backend",
            "inprocess", "--minutes", "0.25"]
    from h2h_racing.league.store import LeagueStore

    def meta() -> dict[str, str]:
        with LeagueStore(tmp_path / "league" / "league.sqlite") as store:
            return store.meta()

    first = _run(argv, tmp_path)
    assert first.returncode == 0, first.stderr
    assert ("ended at its time budget (a larger --minutes, the league's total, or --this-run "
            "trains on), 0 rounds") in first.stdout
    assert "round 1 stopped in its train phase: kept its training (main " in first.stdout
    steps = int(meta()["main.steps"])
    assert 0 < steps < 1_000_000 * 2 * 4
    assert float(meta()["elapsed_seconds"]) >= 15.0
    # The same command again: the league's 0.25 minutes are spent.
    again = _run(argv, tmp_path)
    assert again.returncode == 0, again.stderr
    assert "its 0.25-minute budget is spent" in again.stderr
    assert int(meta()["main.steps"]) == steps
    # --this-run: 0.25 minutes more, from where it stopped (round 1's races, then round 2).
    more = _run(argv + ["--this-run"], tmp_path)
    assert more.returncode == 0, more.stderr
    assert "[league tiny] resuming at round 1 in league" in more.stderr
    assert meta()["round"] == "1" and int(meta()["main.steps"]) > steps
