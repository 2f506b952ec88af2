"""DeepRacer's evaluation episodes between ``train --simtrace`` iterations: the rows in the
training metrics, and deepracer-utils' training-progress plot drawn with its defaults."""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from h2h_racing.deepracer.logs import STATUS_LABELS
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.simtrace_eval import MIN_EVAL_TRIALS, SimtraceEvaluations
from h2h_racing.training.train import train
from h2h_racing.training.vec_env import RacingVecEnv

TRAINING_KEYS = {"reward_score", "metric_time", "start_time", "elapsed_time_in_milliseconds",
                 "episode", "trial", "phase", "completion_percentage", "episode_status"}
EPISODES = 2  # training episodes per simtrace iteration: small, so a short run has several
QUICK = TrainConfig(track="oval", num_envs=2, num_steps_per_env=64, hidden_dims=(16, 16),
                    simtrace_envs=2, simtrace_episodes=EPISODES, eval_every=0)


def metrics(folder: Path, name: str = "TrainingMetrics.json") -> list[dict[str, Any]]:
    return json.loads((folder / "metrics" / name).read_text())["metrics"]


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short training run (8 iterations of 2 x 64 steps, ~3 s) with 2 logged copies."""
    out = tmp_path_factory.mktemp("run")
    train(QUICK, iterations=8, out=out)
    return out / "simtrace" / "car_0"


def blocks(rows: list[dict[str, Any]]) -> list[tuple[int, list[dict[str, Any]]]]:
    """Each run of evaluation rows, with the index of the training row before it."""
    found: list[tuple[int, list[dict[str, Any]]]] = []
    for i, row in enumerate(rows):
        if row["phase"] != "evaluation":
            continue
        if i and rows[i - 1]["phase"] == "evaluation":
            found[-1][1].append(row)
        else:
            found.append((i - 1, [row]))
    return found


class TestEvaluationRows:
    """Worker 0's metrics hold one block of 5 evaluation episodes after each iteration."""

    def test_one_block_of_five_after_every_iteration(self, run: Path) -> None:
        rows = metrics(run)
        training = [r for r in rows if r["phase"] == "training"]
        found = blocks(rows)
        # Every finished iteration of worker 0 (EPISODES training episodes) is followed by
        # one block, and only those: the last, unfinished iteration has none.
        assert len(found) == len(training) // EPISODES >= 3
        for before, block in found:
            last = rows[before]
            assert last["phase"] == "training" and last["trial"] == EPISODES
            assert len(block) == MIN_EVAL_TRIALS
            for row in block:
                assert set(row) == TRAINING_KEYS
                assert row["phase"] == "evaluation"
                # simapp counts neither: the iteration's last training episode and trial.
                assert (row["episode"], row["trial"]) == (last["episode"], last["trial"])

    def test_fields_and_simulated_times(self, run: Path) -> None:
        rows = metrics(run)
        labels = set(STATUS_LABELS.values())
        for before, block in blocks(rows):
            # The trials run one after another on the worker's clock from the end of the
            # iteration, and the next training episode starts after them.
            clock = rows[before]["metric_time"]
            for row in block:
                assert isinstance(row["completion_percentage"], int)
                assert 0 <= row["completion_percentage"] <= 100
                assert row["episode_status"] in labels
                # One lap attempt under training rules ends at the lap or an infraction.
                assert row["episode_status"] in ("Lap complete", "Off track", "Reversed",
                                                 "Immobilized", "Crashed", "Time Up")
                assert (row["episode_status"] == "Lap complete") == (
                    row["completion_percentage"] == 100)
                assert row["elapsed_time_in_milliseconds"] > 0
                assert abs(row["start_time"] - clock) <= 1
                assert row["metric_time"] - row["start_time"] == \
                    row["elapsed_time_in_milliseconds"]
                clock = row["metric_time"]
            after = rows[before + len(block) + 1] if before + len(block) + 1 < len(rows) else None
            if after is not None:
                assert after["phase"] == "training"
                assert abs(after["start_time"] - clock) <= 1

    def test_simtrace_clock_runs_on_through_the_evaluations(self, run: Path) -> None:
        """The prepare row of the training episode after a block is stamped at its end."""
        rows = metrics(run)
        found = blocks(rows)
        with (run / "0" / "training-simtrace" / "1-iteration.csv").open() as f:
            first = next(csv.DictReader(f))
        assert first["episode_status"] == "prepare"
        block_end = found[0][1][-1]["metric_time"] / 1000.0
        assert float(first["tstamp"]) == pytest.approx(block_end, abs=1e-3)

    def test_only_worker_0_evaluates(self, run: Path) -> None:
        rows = metrics(run, "TrainingMetrics_1.json")
        assert rows and all(r["phase"] == "training" for r in rows)

    def test_off_runs_none(self, tmp_path: Path) -> None:
        config = dataclasses.replace(QUICK, simtrace_eval_trials=0)
        train(config, iterations=3, out=tmp_path)
        rows = metrics(tmp_path / "simtrace" / "car_0")
        assert rows and all(r["phase"] == "training" for r in rows)


def test_deepracer_utils_draws_plot_progress_with_its_defaults(run: Path, tmp_path: Path) -> None:
    """The log-analysis notebook's cells: load, summarise, plot with the defaults."""
    logs = pytest.importorskip("deepracer.logs")
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tm = logs.TrainingMetrics(None, fname=str(run / "metrics" / "TrainingMetrics.json"))
    tm.addRound("car_0", fname=str(run / "metrics" / "TrainingMetrics_1.json"),
                training_round=1, worker=1)
    rows = metrics(run)
    iterations = len(blocks(rows))
    assert len(tm.getEvaluation()) == MIN_EVAL_TRIALS * iterations
    summary = tm.getSummary()
    # deepracer-utils puts each block in the iteration whose training episodes it follows.
    evaluated = summary.dropna(subset=["eval_completion"])
    assert len(evaluated) == iterations
    assert (evaluated["eval_episodes"] == MIN_EVAL_TRIALS).all()
    assert list(evaluated.index.get_level_values("iteration")) == list(range(iterations))
    fig = tm.plotProgress()
    path = tmp_path / "progress.png"
    fig.savefig(path)
    assert path.stat().st_size > 0
    lines = {line.get_label(): line for line in fig.axes[0].get_lines()}
    assert set(lines) == {"Evaluation", "Training"}
    drawn = np.asarray(lines["Evaluation"].get_ydata(), dtype=float)
    assert np.isfinite(drawn[:iterations]).all()
    plt.close(fig)


def test_grid_and_restart_put_every_copy_on_copy_0s_grid() -> None:
    """``grid`` reads a copy's start line and slots back; ``restart`` starts copies there."""
    config = TrainConfig(track="oval", num_cars=2, learners=1, opponent="pure_pursuit",
                         num_envs=3).env_config()
    env = RacingVecEnv(config, num_envs=3, learners=1, opponent="pure_pursuit", seed=2)
    start, slots = env.grid(1)
    assert sorted(slots.tolist()) == [0, 1]
    other = RacingVecEnv(config, num_envs=4, learners=1, opponent="pure_pursuit", seed=5)
    other.restart(start, slots)
    assert np.allclose(other.core.start_distance, env.core.start_distance[1])
    assert (other.core.steps == 0).all()


def test_evaluations_of_a_fixed_actor_are_deterministic() -> None:
    """Five trials of the mean action from one grid, measured as the training's episodes."""
    import torch

    env = RacingVecEnv(QUICK.env_config(), num_envs=2, seed=0)

    def actor(obs: Any) -> torch.Tensor:  # full speed ahead, a little left
        return torch.tensor([[0.05, 1.0]]).expand(obs.batch_size[0], 2)

    evaluations = SimtraceEvaluations(env, lambda: actor)
    trials = evaluations.run(*env.grid(0))
    assert len(trials) == MIN_EVAL_TRIALS and all(len(t) == 1 for t in trials)
    assert all(t == trials[0] for t in trials)
    assert set(trials[0][0]) >= {"reward_score", "completion_percentage", "episode_status",
                                 "elapsed_time_in_milliseconds"}
    assert evaluations.run(*env.grid(0)) == trials
    with pytest.raises(ValueError, match="trials"):
        SimtraceEvaluations(env, lambda: actor, trials=0)


def test_config_checks_the_counts() -> None:
    with pytest.raises(ValueError, match="simtrace_eval_trials must be an int in"):
        TrainConfig(simtrace_eval_trials=-1)
    with pytest.raises(ValueError, match="simtrace_episodes must be an int >= 1"):
        TrainConfig(simtrace_episodes=0)


def test_writer_without_root_writes_nothing(tmp_path: Path,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    """``root=None`` measures episodes in memory; ``log_evaluation`` is for training logs."""
    from h2h_racing.deepracer.logs import SimtraceWriter

    monkeypatch.chdir(tmp_path)
    env = RacingVecEnv(QUICK.env_config(), num_envs=1, seed=0)
    env.simtrace = SimtraceWriter(None, env.config, env.track)
    env.simtrace.start(env.core)
    import torch

    while env.simtrace.first_episodes() is None:
        env.step(torch.tensor([[0.3, 1.0]]))
    (entry,), = env.simtrace.first_episodes()
    assert entry["phase"] == "training" and entry["episode"] == 1
    env.close()
    assert env.simtrace.paths == [] and not any(tmp_path.iterdir())
    env.simtrace.clear()
    assert env.simtrace.first_episodes() is None
    with pytest.raises(ValueError, match="one entry per logged car"):
        env.simtrace.log_evaluation([[]])
    evaluation = SimtraceWriter(tmp_path / "logs", env.config, env.track, phase="evaluation")
    with pytest.raises(ValueError, match="go into training metrics"):
        evaluation.log_evaluation([])


@pytest.mark.slow
def test_train_cli_with_deepracer_defaults(tmp_path: Path) -> None:
    """``train --reward-function F --simtrace 2`` as the guide runs it (20 episodes per
    iteration, 5 evaluations each; ~40 s): the notebook's progress plot draws with its
    defaults, each evaluated iteration with DeepRacer's 5 evaluation episodes."""
    logs = pytest.importorskip("deepracer.logs")
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from h2h_racing.cli.command import main

    examples = Path(__file__).resolve().parents[2] / "examples" / "deepracer"
    out = tmp_path / "run"
    assert main(["train", "--track", "oval", "--iterations", "130", "--envs", "2",
                 "--reward-function", str(examples / "follow_centre_line.py"),
                 "--opponents", "none", "--simtrace", "2", "--eval-every", "0", "--no-onnx",
                 "--out", str(out)]) == 0
    folder = out / "simtrace" / "car_0"
    rows = metrics(folder)
    training = [r for r in rows if r["phase"] == "training"]
    found = blocks(rows)
    assert len(found) == len(training) // 20 >= 1
    assert all(len(block) == MIN_EVAL_TRIALS and rows[before]["trial"] == 20
               for before, block in found)
    tm = logs.TrainingMetrics(None, fname=str(folder / "metrics" / "TrainingMetrics.json"))
    summary = tm.getSummary()
    evaluated = summary.dropna(subset=["eval_completion"])
    assert len(evaluated) == len(found)
    assert (summary["train_episodes"].iloc[:len(found)] == 20).all()
    fig = tm.plotProgress()
    fig.savefig(tmp_path / "progress.png")
    plt.close(fig)


def test_self_play_every_car_evaluates_after_its_own_last_episode(tmp_path: Path) -> None:
    """Two learners per copy: the reset that ends car 0's episode cuts car 1's short; both
    cars' iterations end there, and both folders get the block after that episode."""
    config = dataclasses.replace(QUICK, num_cars=2, simtrace_envs=1, simtrace_episodes=1)
    train(config, iterations=3, out=tmp_path)
    starts = []
    for car in ("car_0", "car_1"):
        rows = metrics(tmp_path / "simtrace" / car)
        found = blocks(rows)
        training = [r for r in rows if r["phase"] == "training"]
        assert len(found) == len(training) >= 2
        for before, block in found:
            assert rows[before]["phase"] == "training" and len(block) == MIN_EVAL_TRIALS
            assert all(r["episode"] == rows[before]["episode"] for r in block)
        starts.append([block[0]["start_time"] for _, block in found])
    # The same evaluation episodes, at the same moments, in both cars' files.
    assert starts[0] == starts[1]
