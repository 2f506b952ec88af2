"""Camera and lidar observations through the PettingZoo env."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from pettingzoo.test import api_test, parallel_api_test
from pettingzoo.utils.conversions import parallel_to_aec

import h2h_racing
from h2h_racing.config.env import CameraConfig, EnvConfig, LidarConfig

COMBINATIONS = [("camera",), ("lidar",), ("state", "lidar"), ("camera", "lidar", "state"),
                ("state",)]


def _drive(env: h2h_racing.RacingEnv, steps: int, seed: int) -> list:
    rng = np.random.default_rng(seed)
    observations = []
    obs, _ = env.reset(seed=seed)
    observations.append(obs)
    for _ in range(steps):
        if not env.agents:
            break
        actions = {a: rng.uniform(-0.3, 1.0, 2).astype(np.float32) for a in env.agents}
        obs, *_ = env.step(actions)
        observations.append(obs)
    return observations


class TestSpaces:
    """Every sensor combination passes PettingZoo's API tests with exact dtypes and bounds."""

    @pytest.mark.parametrize("sensors", COMBINATIONS)
    def test_api_tests_pass(self, sensors: tuple[str, ...]) -> None:
        with warnings.catch_warnings():
            # PettingZoo warns that Dict observations are "not a NumPy array": expected here.
            warnings.simplefilter("ignore", UserWarning)
            api_test(parallel_to_aec(h2h_racing.parallel_env(track="oval", sensors=sensors)),
                     num_cycles=40)
            parallel_api_test(h2h_racing.parallel_env(track="oval", sensors=sensors),
                              num_cycles=40)

    @pytest.mark.parametrize("sensors", COMBINATIONS)
    def test_observations_lie_in_their_space(self, sensors: tuple[str, ...]) -> None:
        env = h2h_racing.parallel_env(track="kidney", num_cars=3, sensors=sensors,
                                      race_type="object_avoidance")
        for step, obs in enumerate(_drive(env, 30, seed=1)):
            for agent, o in obs.items():
                assert env.observation_space(agent).contains(o), f"[{step}] {agent}"

    def test_dict_keys_follow_the_sensors_order(self) -> None:
        env = h2h_racing.parallel_env(track="oval", sensors=("lidar", "camera"))
        obs, _ = env.reset(seed=0)
        assert list(obs["car_0"]) == ["lidar", "camera"]
        assert obs["car_0"]["camera"].shape == (120, 160, 1)
        assert obs["car_0"]["lidar"].shape == (64,)

    def test_stereo_stacked_camera_and_sector_lidar_shapes(self) -> None:
        env = h2h_racing.parallel_env(
            track="oval", sensors=("camera", "lidar"),
            camera=CameraConfig(width=80, height=60, stereo=True, frame_stack=3),
            lidar=LidarConfig(mode="sector_lidar"))
        obs, _ = env.reset(seed=0)
        # 2 cameras x 3 stacked frames = 6 channels; 8 binary sectors.
        assert obs["car_1"]["camera"].shape == (60, 80, 6)
        assert obs["car_1"]["lidar"].shape == (8,)

    def test_bad_sensor_name_is_rejected(self) -> None:
        with pytest.raises(ValueError, match="sensors"):
            h2h_racing.parallel_env(track="oval", sensors=("radar",))
        with pytest.raises(ValueError, match="sensors"):
            h2h_racing.parallel_env(track="oval", sensors=())


class TestDeterminism:
    """Sensor observations depend on the state and the seed only."""

    def test_same_seed_same_noisy_observations(self) -> None:
        kwargs = dict(track="oval", sensors=("camera", "lidar"),
                      lidar=LidarConfig(noise_std=0.01, max_range=4.0))
        a = _drive(h2h_racing.parallel_env(**kwargs), 40, seed=5)
        b = _drive(h2h_racing.parallel_env(**kwargs), 40, seed=5)
        for step, (oa, ob) in enumerate(zip(a, b)):
            for agent in oa:
                for key in oa[agent]:
                    assert np.array_equal(oa[agent][key], ob[agent][key]), f"[{step}] {key}"

    def test_lidar_noise_changes_with_the_seed(self) -> None:
        kwargs = dict(track="oval", sensors=("lidar",), grid="fixed",
                      lidar=LidarConfig(noise_std=0.01, max_range=4.0))
        # With a fixed grid the start poses agree; car_1 sees car_0 0.75 m ahead, so its scan
        # has hits, and the noise on them differs between seeds.
        a, _ = h2h_racing.parallel_env(**kwargs).reset(seed=1)
        b, _ = h2h_racing.parallel_env(**kwargs).reset(seed=2)
        assert (a["car_1"]["lidar"] < 4.0).any()
        assert not np.array_equal(a["car_1"]["lidar"], b["car_1"]["lidar"])

    def test_camera_does_not_read_the_renderer(self) -> None:
        plain = _drive(h2h_racing.parallel_env(track="oval", sensors=("camera",)), 20, seed=3)
        rendered_env = h2h_racing.parallel_env(track="oval", sensors=("camera",),
                                               render_mode="rgb_array")
        rendered_env.reset(seed=3)
        rendered_env.render()
        rendered = _drive(rendered_env, 20, seed=3)
        for oa, ob in zip(plain, rendered):
            assert np.array_equal(oa["car_0"]["camera"], ob["car_0"]["camera"])

    def test_camera_changes_when_the_car_drives(self) -> None:
        frames = _drive(h2h_racing.parallel_env(track="oval", sensors=("camera",)), 15, seed=0)
        assert not np.array_equal(frames[0]["car_0"]["camera"], frames[-1]["car_0"]["camera"])


class TestConfig:
    """Sensor settings come through EnvConfig.from_dict (e.g. from a TOML file)."""

    def test_from_dict_builds_nested_sensor_configs(self) -> None:
        cfg = EnvConfig.from_dict({"sensors": ["camera", "state"],
                                   "camera": {"width": 64, "height": 48},
                                   "lidar": {"beams": 32, "sectors": 8}})
        assert cfg.sensors == ("camera", "state")
        assert cfg.camera.width == 64 and cfg.lidar.beams == 32

    def test_from_dict_rejects_unknown_camera_keys(self) -> None:
        with pytest.raises(ValueError, match="unknown keys"):
            EnvConfig.from_dict({"camera": {"resolution": 3}})
