"""A training run a user can watch, stop and resume (issue 37): the output folder is refused,
overwritten or resumed as asked, curves.csv and curves.png show the reward in use, --minutes
stops within one iteration of its budget, and Ctrl-C stops at a safe point with one line."""

from __future__ import annotations

import csv
import dataclasses
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch

from h2h_racing.training import train_progress
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.curves import plot_curves, read_curves
from h2h_racing.training.run_folder import RunFolderError
from h2h_racing.training.train import make_runner, train

SMALL = TrainConfig(track="oval", num_envs=4, num_steps_per_env=4, hidden_dims=(8, 8),
                    eval_every=0)
SAMPLES = 4 * 4  # per iteration: env copies x steps (one learner car)
EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "deepracer"
TINY_FLAGS = ["--track", "oval", "--envs", "4", "--eval-every", "0", "--no-onnx"]


def rows(out: Path) -> list[dict[str, str]]:
    return read_curves(out / "curves.csv")[1]


def twenty_seconds_an_update(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """Count PPO updates (``["count"]``) on a clock on which each takes 20 s and the run's
    setup none."""
    from rsl_rl.algorithms import PPO

    updates = {"count": 0}
    update = PPO.update

    def counted(self: PPO) -> dict[str, float]:
        updates["count"] += 1
        return update(self)

    monkeypatch.setattr(PPO, "update", counted)
    monkeypatch.setattr(train_progress, "_now", lambda: 20.0 * updates["count"])
    return updates


def tags(out: Path) -> set[str]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    log = EventAccumulator(str(out))
    log.Reload()
    return set(log.Tags()["scalars"])


class TestOutputFolder:
    """An existing --out is refused unless --resume or --overwrite."""

    def test_an_existing_out_is_refused_in_one_line_and_left_as_it_was(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        from h2h_racing.cli.command import main

        out = tmp_path / "run"
        out.mkdir()
        (out / "model_4.pt").write_bytes(b"old checkpoint")
        (out / "notes.txt").write_text("mine")
        assert main(["train", *TINY_FLAGS, "--iterations", "1", "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1, err
        assert f"--out {out} already exists" in err
        assert "--resume to continue it from model_4.pt" in err and "--overwrite" in err
        assert sorted(p.name for p in out.iterdir()) == ["model_4.pt", "notes.txt"]
        assert (out / "model_4.pt").read_bytes() == b"old checkpoint"

    def test_an_empty_or_missing_out_starts_a_run(self, tmp_path: Path) -> None:
        train(SMALL, iterations=1, out=tmp_path)  # tmp_path exists, empty
        assert (tmp_path / "policy.pt").is_file()

    def test_overwrite_deletes_the_old_runs_files_only(self, tmp_path: Path) -> None:
        train(SMALL, iterations=3, out=tmp_path)
        (tmp_path / "notes.txt").write_text("mine")
        train(SMALL, iterations=2, out=tmp_path, overwrite=True)
        names = sorted(p.name for p in tmp_path.iterdir())
        # rsl-rl's model_0 (its save interval) and the latest, model_1: not the old model_2.
        assert [n for n in names if n.startswith("model_")] == ["model_0.pt", "model_1.pt"]
        assert len([n for n in names if n.startswith("events.out.tfevents")]) == 1
        assert [r["iteration"] for r in rows(tmp_path)] == ["1", "2"]
        assert (tmp_path / "notes.txt").read_text() == "mine"

    def test_bad_combinations_are_refused_before_any_work(self, tmp_path: Path) -> None:
        with pytest.raises(RunFolderError, match="not both"):
            train(SMALL, iterations=1, out=tmp_path, resume=True, overwrite=True)
        with pytest.raises(RunFolderError, match="holds no checkpoint"):
            train(SMALL, iterations=1, out=tmp_path / "none", resume=True)
        (tmp_path / "file").write_text("x")
        with pytest.raises(RunFolderError, match="is a file, not a folder"):
            train(SMALL, iterations=1, out=tmp_path / "file")


class TestResume:
    """--resume continues from the latest checkpoint, its curves and its iteration count."""

    def test_resume_goes_on_from_the_latest_checkpoint(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        train(SMALL, iterations=3, out=tmp_path)
        first = rows(tmp_path)
        capsys.readouterr()
        train(SMALL, iterations=5, out=tmp_path, resume=True)
        assert "resuming at iteration 3 of 5 from " in capsys.readouterr().out
        curves = rows(tmp_path)
        assert [r["iteration"] for r in curves] == ["1", "2", "3", "4", "5"]
        assert curves[:3] == first  # the first run's rows are kept as they were
        assert [int(r["steps"]) for r in curves] == [SAMPLES * k for k in range(1, 6)]
        # The run's clock goes on: the resumed rows come after the first run's time.
        assert float(curves[3]["seconds"]) > float(curves[2]["seconds"])
        assert torch.load(tmp_path / "policy.pt", weights_only=True)["training"][
            "iterations"] == 5
        # The resumed run's checkpoint replaced the one it started from (off the interval).
        assert sorted(p.name for p in tmp_path.glob("model_*.pt")) == ["model_0.pt",
                                                                       "model_4.pt"]

    def test_the_checkpoint_loads_weights_only_into_a_runner(self, tmp_path: Path) -> None:
        from h2h_racing.training.policy_file import load_checkpoint

        train(SMALL, iterations=2, out=tmp_path)
        runner = make_runner(SMALL, SMALL.make_env())
        load_checkpoint(runner, tmp_path / "model_1.pt")
        saved = torch.load(tmp_path / "model_1.pt", weights_only=True)
        actor = runner.alg.get_policy().state_dict()
        assert all(torch.equal(saved["actor_state_dict"][k], actor[k]) for k in actor)
        assert runner.current_learning_iteration == 1
        (tmp_path / "model_7.pt").write_bytes(b"not a checkpoint")
        with pytest.raises(ValueError, match="model_7.pt"):
            load_checkpoint(runner, tmp_path / "model_7.pt")

    def test_a_finished_run_says_so(self, tmp_path: Path) -> None:
        train(SMALL, iterations=2, out=tmp_path)
        with pytest.raises(RunFolderError, match="already trained 2 of --iterations 2"):
            train(SMALL, iterations=2, out=tmp_path, resume=True)

    def test_a_run_that_fails_part_way_resumes_with_continuous_curves(
            self, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
            capsys: pytest.CaptureFixture[str]) -> None:
        # As ppo_generalist/routes seed 2 (issue 36, step 5): learn() ended on iteration
        # index 1 (its checkpoint model_1.pt), then drawing the next random track raised. The
        # row of that iteration (curves' 2) waited in memory for the next one and was lost:
        # the resumed run had no row 2 and its clock restarted from 0 (seconds_at found none).
        from h2h_racing.training import train as train_module
        from h2h_racing.training.tracks import ProceduralTracks

        updates = twenty_seconds_an_update(monkeypatch)
        set_tracks = train_module._set_tracks
        calls = {"count": 0}

        def failing_second_draw(*args: object) -> None:
            calls["count"] += 1
            if calls["count"] == 2:
                raise RuntimeError("random_track found no valid track in 100 tries")
            set_tracks(*args)

        monkeypatch.setattr(train_module, "_set_tracks", failing_second_draw)
        config = dataclasses.replace(SMALL, track="procedural",
                                     procedural=ProceduralTracks(every=2))
        with pytest.raises(RuntimeError, match="no valid track"):
            train(config, iterations=5, out=tmp_path)
        assert sorted(p.name for p in tmp_path.glob("model_*.pt")) == ["model_0.pt",
                                                                       "model_1.pt"]
        # The checkpoint's iteration has its row on disk.
        assert [r["iteration"] for r in rows(tmp_path)] == ["1", "2"]
        capsys.readouterr()
        train(config, iterations=5, out=tmp_path, resume=True)
        assert "resuming at iteration 2 of 5 from " in capsys.readouterr().out
        curves = rows(tmp_path)
        assert [r["iteration"] for r in curves] == ["1", "2", "3", "4", "5"]
        assert [int(r["steps"]) for r in curves] == [SAMPLES * k for k in range(1, 6)]
        # The clock goes on from the checkpoint's row: 20 s an iteration, both runs.
        assert [r["seconds"] for r in curves] == ["20", "40", "60", "80", "100"]
        assert updates["count"] == 5  # exactly the iterations asked, none twice or left out
        assert torch.load(tmp_path / "policy.pt", weights_only=True)["training"][
            "iterations"] == 5
        assert (tmp_path / "model_4.pt").is_file()

    def test_simtrace_logs_are_not_resumed(self, tmp_path: Path) -> None:
        # Their iteration files would restart at 0 over the first run's.
        config = dataclasses.replace(SMALL, simtrace_envs=1, simtrace_eval_trials=0)
        train(config, iterations=1, out=tmp_path)
        with pytest.raises(RunFolderError, match="cannot go on with DeepRacer simtrace logs"):
            train(config, iterations=2, out=tmp_path, resume=True)


class TestCurves:
    """curves.csv and curves.png beside the tensorboard log, with the reward in use."""

    def test_built_in_reward_columns_match_the_tensorboard_log(self, tmp_path: Path) -> None:
        pytest.importorskip("tensorboard")
        from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

        # Rollouts of 16 steps: episodes (about 20 steps) end, so returns are logged.
        train(dataclasses.replace(SMALL, num_steps_per_env=16), iterations=3, out=tmp_path)
        header, curves = read_curves(tmp_path / "curves.csv")
        # RewardConfig's non-zero weights: progress, off_track, crash, overtake.
        assert header[:5] == ["iteration", "steps", "seconds", "return", "episode_length"]
        assert [c for c in header if c.startswith("reward/")] == [
            "reward/progress", "reward/off_track", "reward/crash", "reward/overtake"]
        assert "lap_completion" in header and "eval_lap_completion" in header
        log = EventAccumulator(str(tmp_path))
        log.Reload()
        returns = {e.step: e.value for e in log.Scalars("Train/mean_reward")}
        progress = {e.step: e.value for e in log.Scalars("reward/progress")}
        assert sorted(returns) == [int(r["iteration"]) - 1 for r in curves if r["return"]]
        # The terms only where episodes ended that iteration (the return: the last 100).
        assert sorted(progress) == [int(r["iteration"]) - 1 for r in curves
                                    if r["reward/progress"]]
        assert progress
        for row in curves:  # tensorboard's step: the iteration's index, from 0
            step = int(row["iteration"]) - 1
            if row["return"]:
                assert float(row["return"]) == pytest.approx(returns[step], rel=1e-5)
            if row["reward/progress"]:
                assert float(row["reward/progress"]) == pytest.approx(progress[step], rel=1e-5)
        png = (tmp_path / "curves.png").read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n"

    def test_a_deepracer_reward_file_is_the_curves_reward(self, tmp_path: Path) -> None:
        pytest.importorskip("tensorboard")
        config = dataclasses.replace(
            SMALL, reward_function=str(EXAMPLES / "follow_centre_line.py"))
        train(config, iterations=2, out=tmp_path)
        header, curves = read_curves(tmp_path / "curves.csv")
        assert [c for c in header if c.startswith("reward/")] == ["reward/reward_function"]
        # follow_centre_line pays 1, 0.5, 0.1 or 1e-3 a step: its mean lies between.
        for row in curves:
            assert 1e-3 <= float(row["reward/reward_function"]) <= 1.0
        logged = tags(tmp_path)
        assert "reward/reward_function" in logged
        assert not {"reward/progress", "reward/crash", "reward/off_track"} & logged

    def test_an_evaluation_joins_its_iterations_row(self, tmp_path: Path) -> None:
        # Rows go to disk as their iteration ends, except one an evaluation is due after.
        config = dataclasses.replace(SMALL, eval_every=2, eval_episodes=1,
                                     eval_race_seconds=1.0)
        train(config, iterations=3, out=tmp_path)
        curves = rows(tmp_path)
        assert [r["iteration"] for r in curves] == ["1", "2", "3"]
        assert [bool(r["eval_lap_completion"]) for r in curves] == [False, True, False]
        assert all(r["steps"] for r in curves)

    def test_a_resumed_clock_goes_on_from_the_latest_row_at_or_before_the_checkpoint(
            self, tmp_path: Path) -> None:
        from h2h_racing.training.curves import seconds_at

        # A folder written before every row went to disk at once: the checkpoint's row (3) is
        # missing. It used to give 0 (the resumed clock restarted); row 2's time is the best
        # known, one iteration short.
        path = tmp_path / "curves.csv"
        path.write_text("iteration,steps,seconds\n1,16,10.5\n2,32,21\n4,64,40\n5,80,\n")
        assert seconds_at(path, 2) == 21.0
        assert seconds_at(path, 3) == 21.0
        assert seconds_at(path, 4) == 40.0
        assert seconds_at(path, 5) == 40.0  # a row cut short (no seconds) is passed over
        assert seconds_at(path, 0) == 0.0
        assert seconds_at(tmp_path / "none.csv", 3) == 0.0

    def test_without_matplotlib_the_plot_is_skipped_in_one_line(
            self, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
        path = tmp_path / "curves.csv"
        with path.open("w", newline="") as file:
            writer = csv.writer(file)
            writer.writerow(["iteration", "steps", "return"])
            writer.writerow([1, 16, -3.5])
        monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib fails
        line = plot_curves(path, tmp_path / "curves.png")
        assert line.startswith("curves plot skipped: matplotlib is not installed")
        assert "\n" not in line and not (tmp_path / "curves.png").exists()


class TestBudget:
    """--minutes stops within one iteration of its budget, and not after it."""

    def test_stops_before_the_iteration_that_would_end_past_the_budget(
            self, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
        # A clock on which every iteration takes 20 s: the 60 s budget holds 3 iterations.
        # Before, train checked the time every 10 iterations, so a budget ran over by up to 9.
        twenty_seconds_an_update(monkeypatch)
        runner = train(SMALL, iterations=12, out=tmp_path, minutes=1.0)
        assert runner.current_learning_iteration == 3
        assert [r["seconds"] for r in rows(tmp_path)] == ["20", "40", "60"]

    def test_budget_rules(self, monkeypatch: pytest.MonkeyPatch) -> None:
        now = {"t": 100.0}
        monkeypatch.setattr(train_progress, "_now", lambda: now["t"])
        budget = train_progress.Budget(minutes=1.0, spent=30.0)  # a resumed run's 30 s
        now["t"] = 110.0
        assert budget.tick() == (40.0, False)  # 40 + 10 <= 60
        now["t"] = 120.0
        assert budget.tick() == (50.0, False)  # 50 + 10 = 60: the next ends on the budget
        now["t"] = 125.0  # an evaluation of 5 s leaves 5 s: no room for a 10 s iteration
        assert budget.after_pause()
        assert train_progress.Budget(minutes=0.5, spent=30.0).spent_all()
        assert not train_progress.Budget(minutes=None, spent=1e9).spent_all()


def _start(command: list[str], cwd: Path) -> subprocess.Popen[str]:
    # Python's own SIGINT handling in the child, whatever this process has installed.
    return subprocess.Popen([sys.executable, "-m", "h2h_racing.cli.command", *command], cwd=cwd,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


@pytest.mark.slow
def test_ctrl_c_stops_at_an_iteration_with_one_line_and_resumes(tmp_path: Path) -> None:
    """The CLI in a subprocess: SIGINT once training runs; exit 130, one line naming the kept
    checkpoint and the command that resumes, no traceback; that command resumes."""
    out = tmp_path / "run"
    child = _start(["train", *TINY_FLAGS, "--iterations", "100000", "--out", str(out)],
                   tmp_path)
    try:
        deadline = time.monotonic() + 240
        while not (out / "model_0.pt").is_file():  # the first iteration's checkpoint
            assert child.poll() is None, child.communicate()
            assert time.monotonic() < deadline, "no iteration in 240 s"
            time.sleep(0.2)
        child.send_signal(signal.SIGINT)
        stdout, stderr = child.communicate(timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
    assert child.returncode == 130, stderr
    assert "Traceback" not in stderr and "Exception ignored" not in stderr
    lines = [line for line in stderr.splitlines() if line.startswith("interrupted")]
    assert len(lines) == 1, stderr
    match = re.fullmatch(r"interrupted after iteration (\d+): kept (\S+model_(\d+)\.pt) and "
                         r"(\S+policy\.pt) .*; resume with: (.+)", lines[0])
    assert match, lines[0]
    done, checkpoint, index = int(match.group(1)), Path(match.group(2)), int(match.group(3))
    assert index == done - 1 and checkpoint.is_file()
    assert [int(r["iteration"]) for r in rows(out)] == list(range(1, done + 1))
    command = match.group(5)
    assert command.startswith("h2h-racing train ") and command.endswith(" --resume")
    # The command it gives resumes (with a cap just above, so that it ends).
    words = command.split()[1:]
    words[words.index("--iterations") + 1] = str(done + 1)
    resumed = subprocess.run([sys.executable, "-m", "h2h_racing.cli.command", *words,
                              "--no-progress"],
                             cwd=tmp_path, capture_output=True, text=True, timeout=240,
                             env={**os.environ})
    assert resumed.returncode == 0, resumed.stderr
    assert f"resuming at iteration {done} of {done + 1} from {checkpoint}" in resumed.stdout
    assert [int(r["iteration"]) for r in rows(out)] == list(range(1, done + 2))


class TestTrainedAlone:
    """A policy file says whether it was trained alone; race and evaluate warn once when such a
    policy races another car (issue 37: a time-trial model left the track 28 times in a race,
    and nothing said why)."""

    def test_the_policy_file_records_how_it_was_trained(self, tmp_path: Path) -> None:
        from h2h_racing.training.policy_file import trained_alone

        train(SMALL, iterations=1, out=tmp_path / "alone")
        versus = dataclasses.replace(SMALL, num_cars=2, learners=1,
                                     opponent="pure_pursuit,blocker")
        train(versus, iterations=1, out=tmp_path / "versus")
        alone = torch.load(tmp_path / "alone" / "policy.pt", weights_only=True)
        raced = torch.load(tmp_path / "versus" / "policy.pt", weights_only=True)
        assert alone["racing"] == {"alone": True, "cars": 1, "learners": 1, "opponents": []}
        assert raced["racing"] == {"alone": False, "cars": 2, "learners": 1,
                                   "opponents": ["pure_pursuit", "blocker"]}
        assert trained_alone(alone) is True and trained_alone(raced) is False
        # Files written before the record: the env config's car count says it.
        del alone["racing"]
        assert trained_alone(alone) is True
        assert trained_alone({"env_config": {}}) is None

    def test_shipped_time_trial_policies_count_as_trained_alone(self) -> None:
        from h2h_racing.policies.trained import load_policy_payload
        from h2h_racing.training.policy_file import trained_alone

        assert trained_alone(load_policy_payload("ppo_generalist")) is True
        assert trained_alone(load_policy_payload("league_racer")) is False

    def test_race_warns_once_per_policy_trained_alone(
            self, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
        from h2h_racing.training import cli_train
        from h2h_racing.cli.command import main

        monkeypatch.setattr(cli_train, "_WARNED_ALONE", set())
        assert main(["race", "--track", "oval", "--laps", "1", "--no-progress", "--drivers",
                     "ppo_generalist,league_racer,ppo_generalist"]) == 0
        err = capsys.readouterr().err
        warnings = [line for line in err.splitlines() if line.startswith("warning:")]
        assert warnings == [
            "warning: ppo_generalist was trained alone (no other car on its track), and races "
            "2 other cars here: it has never seen one and is likely to crash; for races, "
            "train it against a car (h2h-racing train's default: --opponents racing_line)"]
        # Once per command: a second call in the same process says nothing more.
        cli_train.warn_trained_alone(["ppo_generalist", "pure_pursuit"], others=1)
        assert capsys.readouterr().err == ""

    def test_no_warning_alone_or_for_racers(self, capsys: pytest.CaptureFixture[str],
                                            monkeypatch: pytest.MonkeyPatch) -> None:
        from h2h_racing.training import cli_train

        monkeypatch.setattr(cli_train, "_WARNED_ALONE", set())
        cli_train.warn_trained_alone(["ppo_generalist"], others=0)  # a time trial
        cli_train.warn_trained_alone(["league_racer", "racing_line", "no_such.pt"],
                                        others=2)
        assert capsys.readouterr().err == ""

    def test_evaluate_against_warns_once_over_opponents_and_tracks(
            self, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
        from h2h_racing.training import cli_train
        from h2h_racing.cli.command import main

        monkeypatch.setattr(cli_train, "_WARNED_ALONE", set())
        assert main(["evaluate", "--policy", "ppo_generalist", "--against",
                     "pure_pursuit,blocker", "--track", "oval", "--races", "2", "--laps", "1",
                     "--no-progress"]) == 0
        err = capsys.readouterr().err
        assert err.count("warning: ppo_generalist was trained alone") == 1, err
