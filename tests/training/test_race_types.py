"""Training for DeepRacer's race types: the [race] table, boxes and bots in the VecEnv, and
short PPO runs of each race type with the built-in reward and with DeepRacer reward files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from h2h_racing.cli.command import build_parser
from h2h_racing.training.cli import _train_config
from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.race_settings import RaceSettings
from h2h_racing.training.train import train
from h2h_racing.training.vec_env import RacingVecEnv

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "deepracer"
TINY = {"track": "oval", "num_envs": 4, "num_steps_per_env": 8, "hidden_dims": (16, 16),
        "eval_every": 0}


def boxes_env(seed: int = 3, num_envs: int = 8, **fields) -> RacingVecEnv:
    config = EnvConfig(track="oval", num_cars=1, race_type="object_avoidance",
                       rules=RaceRules.preset("object_avoidance", "training"),
                       randomize_obstacles=True, **fields)
    return RacingVecEnv(config, num_envs=num_envs, seed=seed)


def bots_env(seed: int = 3, num_envs: int = 4, **fields) -> RacingVecEnv:
    config = EnvConfig(track="oval", num_cars=1, race_type="head_to_bot",
                       rules=RaceRules.preset("head_to_bot", "training"), **fields)
    return RacingVecEnv(config, num_envs=num_envs, seed=seed)


class TestRaceTable:
    """TrainConfig's [race] table and train's flags."""

    def test_table_sets_race_type_boxes_and_bots(self) -> None:
        config = TrainConfig.from_dict({"race": {"race_type": "object_avoidance", "boxes": 4}})
        env = config.env_config()
        assert (env.race_type, env.obstacle_count, env.randomize_obstacles) == (
            "object_avoidance", 4, True)
        bots = TrainConfig.from_dict({"race": {"race_type": "head_to_bot", "bot_speed": 0.5,
                                               "bot_lane_change": False}}).env_config()
        assert (bots.race_type, bots.bot_count, bots.bot_speed, bots.bot_lane_change) == (
            "head_to_bot", 3, 0.5, False)

    def test_defaults_follow_deepracer(self) -> None:
        assert TrainConfig().env_config().race_type == "time_trial"
        assert TrainConfig(num_cars=2, opponent="racing_line",
                           learners=1).env_config().race_type == "head_to_head"
        oa = TrainConfig(race=RaceSettings(race_type="object_avoidance")).env_config()
        assert (oa.obstacle_count, oa.bot_count) == (6, 0)
        h2b = TrainConfig(race=RaceSettings(race_type="head_to_bot")).env_config()
        assert (h2b.obstacle_count, h2b.bot_count, h2b.bot_speed) == (0, 3, 0.75)
        assert TrainConfig().env_config().obstacle_count == 0

    @pytest.mark.parametrize(("race", "message"), [
        ({"race_type": "drag"}, r"\[race\]\.race_type must be one of .*'head_to_bot'.*got 'drag'"),
        ({"boxes": -1}, r"\[race\]\.boxes must be an int in \[0, 32\].*got -1"),
        ({"boxes": 33}, r"\[race\]\.boxes must be an int in \[0, 32\].*got 33"),
        ({"bots": 13}, r"\[race\]\.bots must be an int in \[0, 12\].*got 13"),
        ({"bot_speed": 0}, r"\[race\]\.bot_speed must be a finite number > 0 \[m/s\].*got 0"),
        ({"bot_speed": "fast"}, r"\[race\] bot_speed must be a number, got 'fast'"),
        ({"boxes": 2.5}, r"\[race\] boxes must be an integer \(or left out\), got 2\.5"),
        ({"box": 3}, r"\[race\] unknown keys \['box'\]; allowed keys are .*'boxes'"),
        ({"race_type": "head_to_head"}, r"head_to_head' needs two cars or more"),
    ])
    def test_bad_values_are_refused_clearly(self, race: dict, message: str) -> None:
        with pytest.raises(ValueError, match=message):
            TrainConfig.from_dict({"race": race}, source="run.toml")

    def test_toml_file(self, tmp_path: Path) -> None:
        path = tmp_path / "oa.toml"
        path.write_text('track = "oval"\n[race]\nrace_type = "object_avoidance"\nboxes = 3\n'
                        "randomize_boxes = false\n")
        config = TrainConfig.from_toml(path)
        assert config.race == RaceSettings(race_type="object_avoidance", boxes=3,
                                           randomize_boxes=False)

    def test_flags_fill_the_table(self) -> None:
        args = build_parser().parse_args(
            ["train", "--out", "x", "--race-type", "head_to_bot", "--bots", "5",
             "--bot-speed", "1.5", "--no-bot-lane-change"])
        race = _train_config(args).race
        assert race == RaceSettings(race_type="head_to_bot", bots=5, bot_speed=1.5,
                                    bot_lane_change=False)
        boxes = _train_config(build_parser().parse_args(
            ["train", "--out", "x", "--race-type", "object_avoidance", "--boxes", "2"])).race
        assert (boxes.race_type, boxes.boxes, boxes.bots) == ("object_avoidance", 2, None)
        assert _train_config(build_parser().parse_args(["train", "--out", "x"])).race == (
            RaceSettings())


class TestBoxes:
    """Boxes are drawn per env copy and per episode from the VecEnv's seed."""

    def test_each_copy_draws_its_own_boxes_reproducibly(self) -> None:
        a, b, other = boxes_env(seed=3), boxes_env(seed=3), boxes_env(seed=4)
        assert a.core.obstacle_s.shape == (8, 6)
        assert len({tuple(row) for row in a.core.obstacle_s.round(6)}) == 8
        assert np.array_equal(a.core.obstacle_s, b.core.obstacle_s)
        assert np.array_equal(a.core.obstacle_d, b.core.obstacle_d)
        assert not np.array_equal(a.core.obstacle_s, other.core.obstacle_s)

    def test_a_new_episode_redraws_the_copy_s_boxes(self) -> None:
        runs = []
        for _ in range(2):
            env = boxes_env(seed=5, num_envs=4)
            before = env.core.obstacle_s.copy()
            ended = np.zeros(4, dtype=bool)
            # Full left lock at full speed leaves the oval within a few seconds.
            for _ in range(200):
                _, _, dones, _ = env.step(torch.tensor([[1.0, 1.0]] * 4))
                ended |= dones.numpy().astype(bool)
                if ended.all():
                    break
            assert ended.all()
            # Episodes ended at different steps: every copy has boxes it did not start with.
            assert (np.abs(env.core.obstacle_s - before).max(axis=1) > 1e-9).all()
            runs.append(env.core.obstacle_s.copy())
        assert np.array_equal(runs[0], runs[1])

    @pytest.mark.parametrize("seed", [0, 1])
    def test_no_copy_starts_on_or_right_behind_a_box(self, seed: int) -> None:
        # Random training starts round the lap: without a check about one copy in six put its
        # car on a box or just behind one (a crash on the first steps).
        env = boxes_env(seed=seed, num_envs=64)
        core = env.core
        for step in range(40):
            # Every copy's start is checked, the first ones and those of reset copies.
            gap = np.mod(core.obstacle_s - core.s[:, :1], env.track.length)
            gap = np.where(gap > env.track.length / 2, gap - env.track.length, gap)
            fresh = core.steps == 0
            near = ((gap > -0.6) & (gap < 1.5)).any(axis=1)
            assert not (near & fresh).any(), f"step {step}"
            env.step(torch.tensor([[1.0, 1.0]] * 64))

    def test_a_new_track_keeps_starts_clear(self) -> None:
        from h2h_racing.track.io import load_track

        env = boxes_env(seed=2, num_envs=64)
        env.set_track(load_track("speedway"))
        core = env.core
        gap = np.mod(core.obstacle_s - core.s[:, :1], env.track.length)
        gap = np.where(gap > env.track.length / 2, gap - env.track.length, gap)
        assert not ((gap > -0.6) & (gap < 1.5)).any()

    def test_first_step_has_no_crash(self) -> None:
        env = boxes_env(seed=1, num_envs=256)
        _, _, dones, _ = env.step(torch.zeros(256, 2))
        assert not dones.any()
        assert env.core.crashes.sum() == 0


class TestBots:
    """Bots drive their lanes in every copy."""

    def test_bots_move_at_their_speed(self) -> None:
        env = bots_env(bot_lane_change=False)
        core = env.core
        start = core.bot_distance.copy()
        steps = 15
        for _ in range(steps):
            env.step(torch.tensor([[0.0, -1.0]] * 4))
        assert core.bot_distance.shape == (4, 3)
        # No contact with the slow learner behind them: every bot drove bot_speed * time.
        assert np.allclose(core.bot_distance - start, 0.75 * steps * core.config.step_dt,
                           atol=1e-6)

    def test_bots_are_drawn_per_copy_and_change_lanes(self) -> None:
        env = bots_env(seed=2, num_envs=4, randomize_bots=True)
        core = env.core
        assert len({tuple(row) for row in core.bot_s.round(6)}) == 4
        lanes = core.bot_lane.copy()
        for _ in range(100):  # 6.7 s: the first lane change comes 3-5 s after the start
            env.step(torch.tensor([[0.0, -1.0]] * 4))
        assert (core.bot_lane != lanes).any()


class TestDeepRacerParams:
    """A DeepRacer reward file sees the boxes and bots of its own copy."""

    def test_objects_are_the_copy_s_boxes(self, tmp_path: Path) -> None:
        reward = tmp_path / "objects.py"
        reward.write_text("def reward_function(params):\n"
                          "    xs = [p[0] for p in params['objects_location']]\n"
                          "    return 1000.0 * len(xs) + sum(xs)\n")
        config = EnvConfig(track="oval", num_cars=1, race_type="object_avoidance",
                           rules=RaceRules.preset("object_avoidance", "training"),
                           randomize_obstacles=True)
        env = RacingVecEnv(config, num_envs=3, seed=1, reward_function=str(reward))
        _, rewards, dones, _ = env.step(torch.zeros(3, 2))
        assert not dones.any()
        expected = 6000.0 + env.core.obstacle_position[:, :, 0].sum(axis=1)
        assert np.allclose(rewards.numpy(), expected, atol=1e-2)

    def test_objects_are_the_copy_s_bots(self, tmp_path: Path) -> None:
        reward = tmp_path / "bots.py"
        reward.write_text("def reward_function(params):\n"
                          "    return 1000.0 * len(params['objects_location'])"
                          " + sum(params['objects_speed'])\n")
        config = EnvConfig(track="oval", num_cars=1, race_type="head_to_bot",
                           rules=RaceRules.preset("head_to_bot", "training"), bot_speed=0.5)
        env = RacingVecEnv(config, num_envs=2, seed=1, reward_function=str(reward))
        _, rewards, _, _ = env.step(torch.zeros(2, 2))
        assert np.allclose(rewards.numpy(), 3000.0 + 3 * 0.5)


RUNS = {
    "time_trial": {},
    "head_to_head": {"num_cars": 2, "learners": 1, "opponent": "pure_pursuit"},
    "object_avoidance": {},
    "head_to_bot": {},
}


@pytest.mark.parametrize("race_type", list(RUNS))
def test_ppo_runs_each_race_type_with_the_built_in_reward(race_type: str) -> None:
    config = TrainConfig(**TINY, **RUNS[race_type], race=RaceSettings(race_type=race_type))
    runner = train(config, iterations=2)
    assert runner.current_learning_iteration == 2
    assert all(torch.isfinite(p).all() for p in runner.alg.actor.parameters())


@pytest.mark.parametrize(("race_type", "reward"), [
    ("object_avoidance", "object_avoidance.py"), ("head_to_bot", "head_to_bot.py"),
    ("head_to_bot", "object_avoidance.py")])
def test_ppo_runs_with_deepracer_reward_files(race_type: str, reward: str) -> None:
    config = TrainConfig(**TINY, race=RaceSettings(race_type=race_type),
                         reward_function=str(EXAMPLES / reward))
    env = config.make_env()
    env.step(torch.zeros(4, 2))
    assert len(env._builders) == 4
    runner = train(config, iterations=1)
    assert runner.current_learning_iteration == 1
    assert all(torch.isfinite(p).all() for p in runner.alg.actor.parameters())


def test_head_to_bot_example_rewards_passing_and_punishes_closing_in() -> None:
    import importlib.util

    spec = importlib.util.spec_from_file_location("head_to_bot", EXAMPLES / "head_to_bot.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    base = {"is_offtrack": False, "is_crashed": False, "track_width": 1.0,
            "all_wheels_on_track": True, "distance_from_center": 0.2, "speed": 2.0,
            "x": 0.0, "y": 0.0, "is_left_of_center": True, "closest_objects": [0, 1],
            "objects_location": [[-3.0, 0.0], [0.5, 0.0]],
            "objects_left_of_center": [True, True]}
    clear = module.reward_function({**base, "objects_location": []})
    assert clear == pytest.approx(1.0 + 0.5 * 2.0)
    # 0.5 m behind a bot in our lane: 1 - 0.8 * 0.5 of it.
    assert module.reward_function(base) == pytest.approx(2.0 * 0.6)
    # The same bot in the other lane, beside us: a passing bonus.
    passing = {**base, "objects_left_of_center": [True, False]}
    assert module.reward_function(passing) == pytest.approx(2.0 + 0.5)
    assert module.reward_function({**base, "is_crashed": True}) == pytest.approx(1e-3)
