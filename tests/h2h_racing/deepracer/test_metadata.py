"""model_metadata.json -> EnvConfig overrides."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import h2h_racing
from h2h_racing.config.env import EnvConfig
from h2h_racing.deepracer import load_model_metadata

EXAMPLE = Path(__file__).resolve().parents[3] / "examples" / "deepracer" / "model_metadata.json"


def write(tmp_path: Path, data) -> Path:
    path = tmp_path / "model_metadata.json"
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return path


class TestParse:
    """Discrete, continuous and sensors."""

    def test_example_discrete(self) -> None:
        out = load_model_metadata(EXAMPLE)
        assert out["action_type"] == "discrete"
        assert out["discrete_actions"] == ((-30.0, 0.6), (-15.0, 0.6), (0.0, 0.6), (15.0, 0.6),
                                           (30.0, 0.6))
        assert out["sensors"] == ("camera",)
        EnvConfig(**out)

    def test_discrete_ordered_by_index(self, tmp_path: Path) -> None:
        path = write(tmp_path, {"action_space": [{"steering_angle": 10, "speed": 1, "index": 1},
                                                 {"steering_angle": 0, "speed": 2, "index": 0}]})
        assert load_model_metadata(path)["discrete_actions"] == ((0.0, 2.0), (10.0, 1.0))

    def test_continuous_and_lidar(self, tmp_path: Path) -> None:
        path = write(tmp_path, {"action_space": {"speed": {"high": 2, "low": 1},
                                                 "steering_angle": {"high": 20, "low": -10}},
                                "action_space_type": "continuous", "training_algorithm": "sac",
                                "sensor": ["STEREO_CAMERAS", "SECTOR_LIDAR"]})
        out = load_model_metadata(path)
        assert (out["min_speed"], out["max_speed"]) == (1.0, 2.0)
        assert (out["min_steer_deg"], out["max_steer_deg"]) == (-10.0, 20.0)
        assert out["sensors"] == ("camera", "lidar") and out["camera"].stereo
        assert out["lidar"].mode == "sector_lidar"
        # In the env, steer -1 -> -10 deg and +1 -> 20 deg (linear, ScalableBoxActionSpace).
        seen = []
        env = h2h_racing.parallel_env(
            num_cars=2, reward_function=lambda p: seen.append(p["steering_angle"]) or 0.0,
            **{k: v for k, v in out.items() if k not in ("sensors", "camera", "lidar")})
        env.reset(seed=0)
        env.step({"car_0": np.array([-1.0, 0.0]), "car_1": np.array([1.0, 0.0])})
        assert seen == pytest.approx([-10.0, 20.0])
        assert math.degrees(env.core.steer_command[0, 1]) == pytest.approx(20.0)

    def test_clipped_to_actuator_limits(self, tmp_path: Path) -> None:
        path = write(tmp_path, {"action_space": [{"steering_angle": 45, "speed": 5}]})
        with pytest.warns(UserWarning, match="outside DeepRacer's actuator limits"):
            out = load_model_metadata(path)
        assert out["discrete_actions"] == ((30.0, 4.0),)


class TestErrors:
    """Bad files name the file and the key."""

    @pytest.mark.parametrize("data, key", [
        ("{not json", "cannot read"),
        ({"sensor": ["FRONT_FACING_CAMERA"]}, "'action_space'"),
        ({"action_space": []}, "'action_space'"),
        ({"action_space": [{"speed": 1}]}, r"action_space\[0\]"),
        ({"action_space": [{"steering_angle": "left", "speed": 1}]}, "steering_angle"),
        ({"action_space": {"speed": {"low": 1, "high": 2}}, "action_space_type": "continuous"},
         "action_space.steering_angle"),
        ({"action_space": {"speed": {"low": 2, "high": 1},
                           "steering_angle": {"low": -30, "high": 30}},
          "action_space_type": "continuous"}, "low < high"),
        ({"action_space": [{"steering_angle": 0, "speed": 1}], "action_space_type": "box"},
         "'action_space_type'"),
        ({"action_space": [{"steering_angle": 0, "speed": 1}], "sensor": ["RADAR"]},
         "'sensor'"),
        ({"action_space": [{"steering_angle": 0, "speed": 1}],
          "sensor": ["FRONT_FACING_CAMERA", "STEREO_CAMERAS"]}, "exactly one camera"),
        ({"action_space": [{"steering_angle": 0, "speed": 1}], "training_algorithm": "sac"},
         "'action_space_type'"),
    ])
    def test_bad_file(self, tmp_path: Path, data, key: str) -> None:
        path = write(tmp_path, data)
        with pytest.raises(ValueError, match=key) as info:
            load_model_metadata(path)
        assert str(path) in str(info.value)

    def test_config_steer_range_validation(self) -> None:
        with pytest.raises(ValueError, match="min_steer_deg/max_steer_deg"):
            EnvConfig(min_steer_deg=-10.0)
        with pytest.raises(ValueError, match="min_steer_deg/max_steer_deg"):
            EnvConfig(min_steer_deg=-40.0, max_steer_deg=10.0)
