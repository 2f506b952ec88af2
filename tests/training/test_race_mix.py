"""Distilling a scripted driver for object avoidance and head-to-bot (issue 22's
obstacle_generalist recipe): race types taking turns per procedural track ([race]
race_types), the expert's labels round boxes and bots, the student's obstacle and opponent
slots, and distillation with a DeepRacer reward file."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch

from h2h_racing.sensors.state import BASE_FEATURES, OPPONENT_FEATURES
from h2h_racing.track.io import load_track
from h2h_racing.training.config import DistillConfig, TrainConfig
from h2h_racing.training.imitation import ImitationConfig
from h2h_racing.training.race_settings import RaceSettings
from h2h_racing.training.train import train

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "deepracer"
MIX = RaceSettings(race_types=("object_avoidance", "head_to_bot"))
DISTIL = TrainConfig(track="procedural", num_envs=8, num_steps_per_env=8, hidden_dims=(16, 16),
                     eval_every=0, race=MIX, imitation=ImitationConfig(teacher="racing_line"),
                     distill=DistillConfig(learning_rate=3e-3))
OBSTACLE_SLOT = BASE_FEATURES + 2 * OPPONENT_FEATURES
"""Index of the first obstacle slot's 'present' feature (default 2 opponent slots)."""


class TestRaceTypesTable:
    """[race] race_types: checked, and only for procedural runs."""

    def test_first_race_type_is_in_force_at_the_start(self) -> None:
        env = DISTIL.env_config()
        assert (env.race_type, env.obstacle_count, env.bot_count) == ("object_avoidance", 6, 0)

    @pytest.mark.parametrize(("race", "message"), [
        ({"race_types": ["time_trial"]},
         r"\[race\]\.race_types must be a list of race types from .* at least one of them "
         r"other than 'time_trial' \(for one race type, give race_type instead\)"),
        ({"race_types": ["drag"]}, r"\[race\]\.race_types must be a list of race types"),
        ({"race_types": ["head_to_bot"], "race_type": "object_avoidance"},
         r"\[race\]\.race_types must be left out when race_type is given"),
    ])
    def test_bad_lists_are_refused(self, race: dict, message: str) -> None:
        with pytest.raises(ValueError, match=message):
            TrainConfig.from_dict({"track": "procedural", "race": race}, source="run.toml")

    @pytest.mark.parametrize("rules", ["training", "race"])
    def test_a_time_trial_turn_keeps_the_racing_rules(self, rules: str) -> None:
        # Listed first, time_trial sets the first track's (empty) boxes and bots, while the
        # rules stay head_to_bot's: by hand from RaceRules.preset, 1-lap episodes of 120 s
        # ranked on total time, with 5 s penalties in race mode and no void laps.
        mixed = TrainConfig(track="procedural", rules=rules, race=RaceSettings(
            race_types=("time_trial", "head_to_bot"))).env_config()
        alone = TrainConfig(track="procedural", rules=rules, race=RaceSettings(
            race_type="head_to_bot")).env_config()
        assert (mixed.race_type, mixed.obstacle_count, mixed.bot_count) == ("time_trial", 0, 0)
        assert mixed.rules == alone.rules
        assert (mixed.rules.laps, mixed.rules.time_limit, mixed.rules.ranking,
                mixed.rules.max_resets_per_lap) == (1, 120.0, "total_time", None)

    def test_a_fixed_track_is_refused(self) -> None:
        with pytest.raises(ValueError, match=r"race_types \['object_avoidance', "
                                             r"'head_to_bot'\] take turns, one per random "
                                             r"track: set track = 'procedural' \(got 'oval'\)"):
            dataclasses.replace(DISTIL, track="oval")

    def test_head_to_head_in_turn_needs_an_opponent(self) -> None:
        with pytest.raises(ValueError, match="head_to_head' needs two cars or more"):
            TrainConfig(track="procedural",
                        race=RaceSettings(race_types=("object_avoidance", "head_to_head")))


class TestTurns:
    """Each new procedural track moves on to the next race type, with its boxes and bots."""

    def test_set_track_alternates_boxes_and_bots(self) -> None:
        env = DISTIL.make_env()
        track = load_track("oval")
        seen = []
        for _ in range(4):
            env.set_track(track)
            seen.append((env.config.race_type, env.core.num_obstacles, env.core.num_bots))
        assert seen == [("object_avoidance", 6, 0), ("head_to_bot", 0, 3)] * 2

    def test_a_time_trial_turn_has_no_boxes_or_bots_and_the_same_rules(self) -> None:
        config = dataclasses.replace(DISTIL, rules="race", race=RaceSettings(
            race_types=("object_avoidance", "head_to_bot", "time_trial")))
        env = config.make_env()
        rules = env.config.rules
        track = load_track("oval")
        seen = []
        for _ in range(4):
            env.set_track(track)
            seen.append((env.config.race_type, env.core.num_obstacles, env.core.num_bots))
            assert env.core.rules == rules
        assert seen == [("object_avoidance", 6, 0), ("head_to_bot", 0, 3),
                        ("time_trial", 0, 0), ("object_avoidance", 6, 0)]

    def test_training_switches_race_type_with_the_track(self) -> None:
        # Tracks change every 2 iterations: after 3 iterations the run is on its second track,
        # a head-to-bot one, and the student has learnt from both.
        config = dataclasses.replace(DISTIL, procedural=dataclasses.replace(
            DISTIL.procedural, every=2))
        runner = train(config, iterations=3)
        env = runner.env
        assert runner.current_learning_iteration == 3
        assert (env.config.race_type, env.core.num_obstacles, env.core.num_bots) == (
            "head_to_bot", 0, 3)
        assert all(torch.isfinite(p).all() for p in runner.alg.get_policy().parameters())


class TestWhatTheStudentSees:
    """The student's state holds the boxes and bots; the expert's labels steer round them."""

    def test_obstacle_and_opponent_slots_are_filled(self) -> None:
        env = DISTIL.make_env()
        env.set_track(load_track("speedway"))
        # 6 boxes on a 20 m lap (speedway): some copy has a box within 5 m ahead.
        boxes = env.get_observations()["policy"][:, OBSTACLE_SLOT]
        assert boxes.max() == 1.0
        env.set_track(load_track("speedway"))
        obs = env.get_observations()["policy"]
        assert obs[:, BASE_FEATURES].max() == 1.0 and obs[:, OBSTACLE_SLOT].max() == 0.0

    def test_expert_labels_steer_round_the_boxes(self) -> None:
        env = DISTIL.make_env()
        env.set_track(load_track("speedway"))
        core = env.core
        for _ in range(10):
            obs, *_ = env.step(env.get_observations()["expert"])
        labels = obs["expert"].numpy()
        length = core.track.length

        def far() -> np.ndarray:
            """Copies with no box within 5 m of the car, ahead or behind."""
            gap = core.obstacle_s - core.s[:, :1]
            return (np.abs(gap - length * np.floor(gap / length + 0.5)) > 5.0).all(axis=1)

        far_before = far()
        # The same states with every box moved a quarter lap on (5 m): other labels where a box
        # was near, the same labels where none was within 5 m, before or after.
        core.obstacle_s[...] = np.mod(core.obstacle_s + length / 4, length)
        moved = env._observe()["expert"].numpy()
        changed = np.abs(moved - labels).max(axis=1) > 1e-3
        assert changed.any()
        assert not (changed & far_before & far()).any()


@pytest.mark.parametrize(("race_type", "reward"), [
    ("object_avoidance", "object_avoidance.py"), ("head_to_bot", "head_to_bot.py")])
def test_distillation_runs_with_deepracer_reward_files(race_type: str, reward: str) -> None:
    # The reward plays no part in distillation's loss, but a run with a reward file (its
    # DeepRacer params built every step from the boxes and bots) must train as PPO does.
    config = dataclasses.replace(DISTIL, track="oval", race=RaceSettings(race_type=race_type),
                                 reward_function=str(EXAMPLES / reward))
    runner = train(config, iterations=2)
    assert runner.current_learning_iteration == 2
    assert len(runner.env._builders) == 8
    assert all(torch.isfinite(p).all() for p in runner.alg.get_policy().parameters())


def test_distilled_recipe_is_a_valid_config() -> None:
    # experiments/obstacles/distilled.toml, the obstacle_generalist recipe the 3-seed series
    # runs: a state student of the box- and bot-aware racing line on procedural tracks only.
    path = Path(__file__).resolve().parents[2] / "experiments" / "obstacles" / "distilled.toml"
    config = TrainConfig.from_toml(path)
    assert (config.track, config.observations) == ("procedural", "state")
    assert config.race.race_types == ("object_avoidance", "head_to_bot")
    assert config.scripted_teacher and config.imitation.teacher == "racing_line"
    expert = config.imitation.expert()
    assert (expert.follow_gap, expert.closing_speed) == (2.0, 0.3)
    env = config.env_config()
    assert (env.opponent_slots, env.obstacle_slots) == (2, 2)
