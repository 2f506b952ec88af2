"""train's console output: one compact progress line by default with the run's totals (also in
--minutes mode, where learn() runs in chunks of 10), rsl-rl's block with verbose; and the
head-to-head defaults of `h2h-racing train`."""

from __future__ import annotations

import io
import re
from pathlib import Path

import pytest

from h2h_racing.cli.command import build_parser
from h2h_racing.training.cli_train import _train_config
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.train import train

SMALL = TrainConfig(track="oval", num_envs=4, num_steps_per_env=4, hidden_dims=(8, 8),
                    eval_every=0)


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def counts(text: str) -> list[tuple[int, str]]:
    """(iterations done, total shown) of each progress line."""
    return [(int(done), total) for done, total in re.findall(r"it (\d+)/(~?\d+)", text)]


def test_default_output_is_a_few_lines_with_the_runs_totals_in_minutes_mode(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # rsl-rl counts each learn() call as a run of its own (0/10, 10/20, ...): the line shows the
    # run's iterations and total instead.
    train(SMALL, iterations=25, out=tmp_path, minutes=60.0, progress="auto")
    out, err = capsys.readouterr()
    assert "Learning iteration" not in out and "Storing git diff" not in out
    assert "\r" not in err  # captured stderr is not a terminal
    lines = err.splitlines()
    assert 8 <= len(lines) <= 15, err  # setup, a line per tenth of 25 iterations, saving, end
    # Before the first iteration: what the wait is, and no ETA (compiling would inflate it).
    assert "building 4 env copies" in lines[0] and "compiling" in lines[1]
    assert all("% |" in line and "ETA" not in line for line in lines[:2])
    shown = counts(err)
    assert len(shown) == len(lines) - 4
    assert {total for _, total in shown} == {"~25"}  # the run's total, not a chunk's
    assert [d for d, _ in shown] == sorted(d for d, _ in shown)
    assert "samples/s" in lines[-3] and "reward" in lines[-3] and "(60 min)" in lines[-3]
    # Saving policy.pt and the curves is a phase of its own, below 100 %.
    assert "saving" in lines[-2] and "policy.pt and the curves" in lines[-2]
    assert "ETA" not in lines[-2]  # the iterations' rate says nothing of the saving's time
    # Only the end of training reads 100 %; the iterations' lines stay below it.
    assert lines[-1].startswith("train 100% |") and "it 25: done" in lines[-1]
    assert not any(line.startswith("train 100%") for line in lines[:-1])


def test_on_a_terminal_the_line_is_redrawn(tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    stream = Terminal()
    monkeypatch.setattr("sys.stderr", stream)
    train(SMALL, iterations=4, out=tmp_path, progress="auto")
    text = stream.getvalue()
    assert text.count("\n") == 1 and text.count("\r") >= 1
    assert text.rstrip("\n").split("\r")[-1].startswith("train 100% |")
    assert "it 4: done" in text.rstrip("\n").split("\r")[-1]


def test_verbose_prints_rsl_rls_block_with_the_runs_totals(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    train(SMALL, iterations=12, out=tmp_path, minutes=60.0, progress="auto", verbose=True)
    out, err = capsys.readouterr()
    shown = re.findall(r"Learning iteration (\d+)/(\d+)", out)
    assert [int(it) for it, _ in shown] == list(range(12))
    assert {total for _, total in shown} == {"12"}  # not 10, then 20
    assert "train " not in err  # no progress line besides the block


def test_train_races_racing_line_by_default() -> None:
    parser = build_parser()
    config = _train_config(parser.parse_args(["train", "--out", "runs/x"]))
    assert (config.num_cars, config.learners, config.opponent) == (2, 1, "racing_line")
    assert config.reward.contact == -5.0
    alone = _train_config(parser.parse_args(["train", "--out", "runs/x", "--opponents", "none"]))
    assert (alone.num_cars, alone.opponent) == (1, None)
    # A config file is taken as written.
    shipped = _train_config(parser.parse_args(["train", "--out", "runs/x", "--config",
                                               "ppo_generalist/imitate"]))
    assert shipped.num_cars == 1 and shipped.reward.contact == 0.0


def test_opponents_take_driver_settings(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    parser = build_parser()
    config = _train_config(parser.parse_args(
        ["train", "--out", "runs/x", "--opponents", "racing_line:grip_factor=0.7,pure_pursuit"]))
    assert config.opponents() == ["racing_line:grip_factor=0.7", "pure_pursuit"]
    for opponents, message in [
            ("racing_line:grip_factor=1.5",
             "TrainConfig.opponent: racing_line: grip_factor must be a number in (0, 1], got "
             "'1.5'"),
            ("pure_pursuit,racing_line:grp=1", "racing_line: unknown setting 'grp'"),
            ("league_racer:grip_factor=0.7", "league_racer: a trained policy takes no settings")]:
        with pytest.raises(ValueError, match=re.escape(message)):
            _train_config(parser.parse_args(["train", "--out", "runs/x", "--opponents",
                                             opponents]))
    # On the command line: one line, and nothing trained or written.
    from h2h_racing.cli.command import main

    out = tmp_path / "run"
    assert main(["train", "--out", str(out), "--opponents", "racing_line:grip_factor=2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "grip_factor must be a number in (0, 1], got '2'" in err
    assert not out.exists()
