"""DeepRacer's training starts: round-robin start points and alternating driving direction.

The oval's lap is L = 19.999672 m, so a round-robin advance of 0.05 L is 0.9999836 m.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

import h2h_racing
from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.policies import make_driver
from h2h_racing.track.io import load_track

OVAL = load_track("oval")
L = OVAL.length
STEP = 0.05 * L


def recorder() -> tuple[list[dict[str, Any]], Any]:
    """A DeepRacer reward function that keeps every params dict it is given."""
    seen: list[dict[str, Any]] = []

    def reward(params: dict[str, Any]) -> float:
        seen.append(params)
        return 0.0

    return seen, reward


def drive(env: Any, steps: int) -> None:
    drivers = [make_driver("pure_pursuit") for _ in env.possible_agents]
    for d in drivers:
        d.reset(env.core)
    for _ in range(steps):
        if not env.agents:
            break
        env.step({a: drivers[i].act(env.core, i)[0]
                  for i, a in enumerate(env.possible_agents) if a in env.agents})


class TestConfig:
    """The new fields are validated like the others."""

    @pytest.mark.parametrize(("kwargs", "field"), [
        ({"round_robin_advance": 0.0}, "round_robin_advance"),
        ({"round_robin_advance": 1.0}, "round_robin_advance"),
        ({"round_robin_advance": math.nan}, "round_robin_advance"),
        ({"round_robin_starts": 1}, "round_robin_starts"),
        ({"alternate_direction": "yes"}, "alternate_direction"),
    ])
    def test_bad_values_name_the_field(self, kwargs: dict[str, Any], field: str) -> None:
        with pytest.raises(ValueError, match=f"EnvConfig.{field}"):
            EnvConfig(**kwargs)

    def test_defaults_are_off(self) -> None:
        cfg = EnvConfig()
        assert (cfg.round_robin_starts, cfg.round_robin_advance, cfg.alternate_direction) == (
            False, 0.05, False)


class TestRoundRobin:
    """Each reset moves a copy's start 0.05 of a lap further (DeepRacer's start_ndist)."""

    def test_env_advances_five_percent_per_reset(self) -> None:
        env = h2h_racing.parallel_env(track="oval", num_cars=1, round_robin_starts=True)
        starts = []
        for k in range(22):
            env.reset(seed=0 if k == 0 else None)
            starts.append(float(env.core.start_distance[0, 0]))
        # A single car starts on the centre line at the start point: k * 0.05 L, wrapping
        # after 20 episodes (20 * 0.05 = 1.0 -> 0).
        expected = [(k * 0.05 % 1.0) * L for k in range(22)]
        np.testing.assert_allclose(starts, expected, atol=1e-9)
        assert starts[1] == pytest.approx(0.9999836, abs=1e-6)
        np.testing.assert_allclose(env.core.position[0, 0], OVAL.point_at(STEP), atol=1e-12)

    def test_off_by_default(self) -> None:
        env = h2h_racing.parallel_env(track="oval", num_cars=1)
        env.reset(seed=0)
        env.reset()
        assert env.core.start_distance[0, 0] == 0.0

    def test_seeded_reset_restarts_the_rotation(self) -> None:
        env = h2h_racing.parallel_env(track="oval", num_cars=1, round_robin_starts=True)
        env.reset(seed=0)
        env.reset()
        assert env.core.start_distance[0, 0] == pytest.approx(STEP)
        env.reset(seed=0)
        assert env.core.start_distance[0, 0] == 0.0

    def test_core_counts_episodes_per_copy(self) -> None:
        cfg = EnvConfig(track="oval", num_cars=2, grid="fixed", round_robin_starts=True,
                        round_robin_advance=0.1)
        core = RaceCore(cfg, OVAL, num_envs=3)
        core.reset(seed=0)
        # Slot 0 (car 0) at the start point, slot 1 (car 1) 0.75 m behind it.
        np.testing.assert_allclose(core.start_distance[:, 0], [0.0, 0.0, 0.0])
        core.reset_envs(np.array([True, False, True]))
        np.testing.assert_allclose(core.start_distance[:, 0], [0.1 * L, 0.0, 0.1 * L])
        np.testing.assert_allclose(core.start_distance[:, 1], [0.1 * L - 0.75, -0.75,
                                                               0.1 * L - 0.75])
        core.reset_envs(np.array([True, True, False]))
        np.testing.assert_allclose(core.start_distance[:, 0], [0.2 * L, 0.1 * L, 0.1 * L])
        assert core.episodes.tolist() == [3, 2, 2]

    def test_explicit_start_wins_but_the_count_goes_on(self) -> None:
        cfg = EnvConfig(track="oval", num_cars=1, round_robin_starts=True)
        core = RaceCore(cfg, OVAL, num_envs=1)
        core.reset(seed=0)
        core.reset_envs(np.array([True]), start=np.array([3.0]))
        assert core.start_distance[0, 0] == 3.0
        core.reset_envs(np.array([True]))
        assert core.start_distance[0, 0] == pytest.approx(2 * STEP)

    def test_laps_count_from_the_rotated_start(self) -> None:
        training = RaceCore(EnvConfig(track="oval", num_cars=1, round_robin_starts=True,
                                      rules=RaceRules.preset("head_to_head", "training")), OVAL)
        training.reset(seed=0)
        training.reset()
        race = RaceCore(EnvConfig(track="oval", num_cars=1, round_robin_starts=True), OVAL)
        race.reset(seed=0)
        race.reset()
        # Training: from the car's own start; race: from the start point (the same here, one
        # car on the centre line): 0.05 L either way, and no progress yet.
        assert training.lap_origin[0, 0] == pytest.approx(STEP)
        assert race.lap_origin[0, 0] == pytest.approx(STEP)
        assert training.episode_progress[0, 0] == 0.0

    def test_deepracer_progress_is_relative_to_the_rotated_start(self) -> None:
        seen, reward = recorder()
        env = h2h_racing.parallel_env(track="oval", num_cars=1, round_robin_starts=True,
                                      reward_function=reward)
        env.reset(seed=0)
        env.reset()
        env.step({"car_0": np.array([0.0, -1.0])})
        p = seen[-1]
        # The model point is 0.14 m ahead of the car, which moved a few cm: progress is
        # (0.14 + a little) / 20 m = 0.7 % and a little, not the 5 % the start moved.
        assert 0.7 < p["progress"] < 1.5
        assert p["projection_distance"] == pytest.approx(STEP + 0.14, abs=0.1)


class TestAlternateDirection:
    """Every second episode drives the track the other way round; params say is_reversed."""

    def test_is_reversed_flips_every_episode(self) -> None:
        seen, reward = recorder()
        env = h2h_racing.parallel_env(track="oval", num_cars=2, alternate_direction=True,
                                      reward_function=reward)
        flags, core_flags = [], []
        for k in range(4):
            env.reset(seed=0 if k == 0 else None)
            env.step({a: np.array([0.0, -1.0]) for a in env.agents})
            flags.append(seen[-1]["is_reversed"])
            core_flags.append(env.core.is_reversed)
        assert flags == [False, True, False, True] and core_flags == flags

    def test_reversed_episode_starts_facing_the_other_way(self) -> None:
        env = h2h_racing.parallel_env(track="oval", num_cars=1, alternate_direction=True)
        env.reset(seed=0)
        forward_pos, forward_yaw = env.core.position[0, 0].copy(), env.core.yaw[0, 0]
        env.reset()
        # Same start line, heading turned by pi; the driving-direction track is the reverse.
        np.testing.assert_allclose(env.core.position[0, 0], forward_pos, atol=1e-9)
        assert math.cos(env.core.yaw[0, 0] - forward_yaw) == pytest.approx(-1.0, abs=1e-9)
        assert env.track is env.core.track and env.track.is_ccw != OVAL.is_ccw

    def test_progress_counts_in_the_driving_direction(self) -> None:
        env = h2h_racing.parallel_env(track="oval", num_cars=1, alternate_direction=True)
        ends = []
        for k in range(2):
            env.reset(seed=0 if k == 0 else None)
            drive(env, 45)  # 3 s
            assert env.core.distance[0, 0] > 2.0 and env.core.episode_progress[0, 0] > 10.0
            ends.append(env.core.position[0, 0].copy())
        # Forward and reversed runs leave the start line on opposite sides.
        assert np.linalg.norm(ends[0] - ends[1]) > 3.0

    def test_seeded_reset_restarts_forward(self) -> None:
        env = h2h_racing.parallel_env(track="oval", num_cars=1, alternate_direction=True)
        env.reset(seed=0)
        env.reset()
        assert env.core.is_reversed
        env.reset(seed=0)
        assert not env.core.is_reversed

    def test_core_reverse_argument_flips_lanes(self) -> None:
        core = RaceCore(EnvConfig(track="oval", num_cars=1, num_bots=2), OVAL)
        core.reset(seed=0)
        forward_lanes = core.bot_lane[0].tolist()
        core.reset(reverse=True)
        # The oval is counter-clockwise: inner = left (+1) forward, right (-1) reversed; the
        # first bot starts on the inner lane either way.
        assert forward_lanes == [1.0, -1.0] and core.bot_lane[0].tolist() == [-1.0, 1.0]
        assert core.is_reversed and core.forward_track is OVAL

    def test_copies_cannot_flip_one_by_one(self) -> None:
        core = RaceCore(EnvConfig(track="oval", num_cars=1, alternate_direction=True), OVAL,
                        num_envs=2)
        core.reset(seed=0)
        with pytest.raises(ValueError, match="alternate_direction.*every env copy"):
            core.reset_envs(np.array([True, False]))
        core.reset_envs(np.array([True, True]))
        assert core.is_reversed

    def test_parallel_api_with_training_starts_and_bots(self) -> None:
        env = h2h_racing.parallel_env(track="oval", num_cars=2, race_type="head_to_bot",
                                      rules="training", round_robin_starts=True,
                                      alternate_direction=True)
        parallel_api_test(env, num_cycles=200)
