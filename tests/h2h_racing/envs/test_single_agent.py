"""The single-agent Gymnasium view (h2h_racing.envs.single_agent, "h2h_racing/Race-v0")."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import h2h_racing
from h2h_racing.policies import make_driver
from h2h_racing.envs.single_agent import SingleAgentRaceEnv

ROOT = Path(__file__).resolve().parents[3]


def _make(**kwargs):
    return gymnasium.make("h2h_racing/Race-v0", track=kwargs.pop("track", "oval"), **kwargs)


@pytest.mark.parametrize("kwargs", [
    {},
    {"opponents": ["racing_line", "random"]},
    {"opponents": ["pure_pursuit"], "sensors": ["camera", "lidar", "state"]},
    {"opponents": ["blocker"], "action_type": "discrete", "race_type": "object_avoidance"},
], ids=["alone", "scripted", "dict", "discrete"])
def test_passes_gymnasium_and_sb3_env_checkers(kwargs):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = _make(**kwargs)
    with warnings.catch_warnings():
        # Any checker warning (spaces, seeding, dtypes, determinism) fails the test.
        warnings.simplefilter("error")
        check_env(env.unwrapped)
        sb3_check_env(env.unwrapped)
    expected = gymnasium.spaces.Dict if "sensors" in kwargs else gymnasium.spaces.Box
    if kwargs.get("action_type") == "discrete":
        assert isinstance(env.action_space, gymnasium.spaces.Discrete)
    assert isinstance(env.observation_space, expected)


def test_make_passes_keyword_arguments_to_the_race():
    env = _make(track="speedway", opponents=["racing_line", "pure_pursuit"],
                sensors=["lidar", "state"], race_type="head_to_bot", rules="training")
    race = env.unwrapped.race
    assert race.track.name == "speedway"
    assert race.config.num_cars == 3
    assert race.config.sensors == ("lidar", "state")
    assert race.config.race_type == "head_to_bot"
    assert race.config.rules.mode == "training"
    assert race.core.num_bots == 3
    assert set(env.observation_space.spaces) == {"lidar", "state"}


def test_race_type_defaults_to_time_trial_alone_and_head_to_head_with_opponents():
    assert _make().unwrapped.race.config.race_type == "time_trial"
    assert _make(opponents=["racing_line"]).unwrapped.race.config.race_type == "head_to_head"


def test_same_seed_gives_the_same_episode_and_another_seed_another():
    def rollout(seed):
        env = _make(opponents=["random", "pure_pursuit"], randomize_obstacles=True,
                    num_obstacles=2)
        obs, _ = env.reset(seed=seed)
        observations = [obs]
        rewards = []
        for _ in range(30):
            obs, reward, terminated, truncated, _ = env.step(np.array([0.05, 0.3], np.float32))
            observations.append(obs)
            rewards.append(reward)
            if terminated or truncated:
                break
        positions = env.unwrapped.core.position[0].copy()
        return np.array(observations), np.array(rewards), positions

    first, second, other = rollout(7), rollout(7), rollout(8)
    for a, b in zip(first, second):
        np.testing.assert_array_equal(a, b)
    # The random opponent's actions come from the seed too: its car ends elsewhere.
    assert not np.array_equal(first[2], other[2])


def test_matches_the_parallel_env_driven_by_the_same_drivers():
    """The view is the PettingZoo race with car_0 driven from outside: driving the same race
    by hand gives the same observations, rewards and infos."""
    learner = make_driver("racing_line")
    env = _make(opponents=["pure_pursuit"])
    obs, info = env.reset(seed=3)
    learner.reset(env.unwrapped.core)

    race = h2h_racing.parallel_env(track="oval", num_cars=2, race_type="head_to_head")
    drivers = [make_driver("racing_line"), make_driver("pure_pursuit")]
    ref_obs, ref_infos = race.reset(seed=3)
    for driver in drivers:
        driver.reset(race.core)
    np.testing.assert_array_equal(obs, ref_obs["car_0"])
    assert info == ref_infos["car_0"]
    for _ in range(60):
        obs, reward, terminated, truncated, info = env.step(
            learner.act(env.unwrapped.core, 0)[0])
        ref = race.step({a: drivers[i].act(race.core, i)[0]
                         for i, a in enumerate(race.possible_agents) if a in race.agents})
        np.testing.assert_array_equal(obs, ref[0]["car_0"])
        assert reward == ref[1]["car_0"]
        assert (terminated, truncated) == (ref[2]["car_0"], ref[3]["car_0"])
        assert info == ref[4]["car_0"]


def test_learner_finishing_the_lap_terminates_the_episode():
    env = _make(rules="training")
    driver = make_driver("racing_line")
    env.reset(seed=0)
    driver.reset(env.unwrapped.core)
    terminated = truncated = False
    while not (terminated or truncated):
        _, _, terminated, truncated, info = env.step(driver.act(env.unwrapped.core, 0)[0])
    assert terminated and not truncated
    assert info["finished"] and info["lap"] == 1
    with pytest.raises(RuntimeError, match="call reset"):
        env.step(np.zeros(2, np.float32))


def test_learner_ends_even_while_opponents_still_race():
    # The learner drives off the track at once under training rules: its episode ends, the
    # opponent's race goes on.
    env = _make(opponents=["pure_pursuit"], rules="training")
    env.reset(seed=0)
    terminated = truncated = False
    while not (terminated or truncated):
        _, _, terminated, truncated, info = env.step(np.array([1.0, 1.0], np.float32))
    assert terminated and not truncated and not info["finished"]
    assert env.unwrapped.race.agents == ["car_1"]
    obs, _ = env.reset()
    assert obs in env.observation_space


def test_time_limit_truncates():
    env = _make(opponents=["pure_pursuit"], max_cycles=5)
    env.reset(seed=0)
    ends = [env.step(np.array([0.0, 0.0], np.float32))[2:4] for _ in range(5)]
    assert ends == [(False, False)] * 4 + [(False, True)]


def test_render_gives_the_spectator_frame():
    env = _make(render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3


@pytest.mark.parametrize("opponents, error, match", [
    ("racing_line", TypeError, "list of driver names"),
    (["no_such_driver"], ValueError, "no_such_driver"),
    ([42], TypeError, "opponent 0 must be a driver name"),
])
def test_bad_opponents_are_refused_with_a_clear_error(opponents, error, match):
    with pytest.raises(error, match=match):
        SingleAgentRaceEnv(track="oval", opponents=opponents)


def test_bad_render_mode_is_refused():
    with pytest.raises(ValueError, match="render_mode"):
        SingleAgentRaceEnv(track="oval", render_mode="human")


def test_import_registers_without_importing_the_view():
    code = ("import sys, gymnasium, h2h_racing; "
            "print('h2h_racing/Race-v0' in gymnasium.registry, "
            "'h2h_racing.envs.single_agent' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["True", "False"]


def test_sb3_example_trains_and_predicts(tmp_path):
    spec = importlib.util.spec_from_file_location("sb3_single_agent",
                                                  ROOT / "examples" / "sb3_single_agent.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    out = tmp_path / "model"
    result = example.train("oval", ["pure_pursuit"], timesteps=256, out=str(out))
    assert result["model"].num_timesteps == 256
    assert result["steps"] >= 1 and (result["terminated"] or result["truncated"])
    assert (tmp_path / "model.zip").is_file()


def test_a_trained_policy_drives_an_opponent():
    from h2h_racing.policies.trained import TrainedPolicy, shipped_policies

    if not shipped_policies():
        pytest.skip("no shipped policy")
    name = next(iter(shipped_policies()))
    env = _make(opponents=[name])
    assert isinstance(env.unwrapped.opponents[0], TrainedPolicy)
    env.reset(seed=0)
    start = env.unwrapped.core.distance[0, 1]
    for _ in range(30):
        env.step(np.array([0.0, -1.0], np.float32))
    # The trained car drove off the grid under its own policy.
    assert env.unwrapped.core.distance[0, 1] > start + 0.3
