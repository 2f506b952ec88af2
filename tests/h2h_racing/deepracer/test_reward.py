"""DeepRacer reward functions in the env: loading, per-car state, checks, examples."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import h2h_racing
from h2h_racing.deepracer import DeepRacerReward, RewardFunctionError
from h2h_racing.deepracer.params import PARAM_KEYS

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "deepracer"
COUNTER = """
count = 0


def reward_function(params):
    global count
    count += 1
    return count
"""


def make_env(reward_function, **kw):
    kw.setdefault("track", "speedway")
    kw.setdefault("num_cars", 2)
    return h2h_racing.parallel_env(reward_function=reward_function, grid="fixed", **kw)


def drive(env, steps: int, seed: int = 0):
    env.reset(seed=seed)
    out = []
    for _ in range(steps):
        if not env.agents:
            break
        out.append(env.step({a: np.array([0.0, 0.2], np.float32) for a in env.agents}))
    return out


class TestEnvIntegration:
    """The reward is the function's, from step 1, with params in infos."""

    def test_first_call_sees_step_1_and_all_keys(self) -> None:
        seen = []

        def reward(params):
            seen.append(params)
            return params["steps"] * 2

        steps = drive(make_env(reward, info_level="full"), 3)
        assert [p["steps"] for p in seen[::2]] == [1.0, 2.0, 3.0]
        assert all(set(p) == set(PARAM_KEYS) for p in seen)
        _, rewards, _, _, infos = steps[-1]
        assert rewards == {"car_0": 6.0, "car_1": 6.0}
        params = infos["car_0"]["deepracer_params"]
        assert params["steps"] == 3.0 and "reward_progress" in infos["car_0"]
        # Each car sees the other car as an object.
        assert len(params["objects_location"]) == 1

    def test_function_gets_a_copy(self) -> None:
        def vandal(params):
            params["waypoints"].clear()
            params["objects_location"].append([0, 0])
            return 1

        _, _, _, _, infos = drive(make_env(vandal, info_level="full"), 2)[-1]
        params = infos["car_0"]["deepracer_params"]
        assert len(params["waypoints"]) > 0 and len(params["objects_location"]) == 1

    def test_without_reward_function_no_params(self) -> None:
        infos = drive(h2h_racing.parallel_env(track="speedway", info_level="full"), 1)[-1][4]
        assert "deepracer_params" not in infos["car_0"]

    def test_params_only_at_full_info_level(self) -> None:
        # Default infos are flat and fixed (the same keys at reset and step).
        _, infos = make_env(lambda p: 1.0).reset(seed=0)
        steps = drive(make_env(lambda p: 1.0), 1)
        assert "deepracer_params" not in steps[-1][4]["car_0"]
        assert set(steps[-1][4]["car_0"]) == set(infos["car_0"])

    def test_discrete_steering_is_the_action_lists_value(self) -> None:
        seen = []
        env = make_env(lambda p: seen.append(p) or 1.0, action_type="discrete",
                       discrete_actions=((30.0, 1.0), (-15.0, 0.6)))
        env.reset(seed=0)
        env.step({"car_0": 0, "car_1": 1})
        assert [(p["steering_angle"], p["speed"]) for p in seen] == [(30.0, 1.0), (-15.0, 0.6)]

    def test_stateful_file_has_state_per_car(self, tmp_path: Path) -> None:
        path = tmp_path / "counter.py"
        path.write_text(COUNTER)
        steps = drive(make_env(str(path)), 3)
        # One module per car: each counts its own calls 1, 2, 3 (shared state would give 6).
        assert [s[1] for s in steps] == [{"car_0": float(k), "car_1": float(k)}
                                         for k in (1, 2, 3)]

    @pytest.mark.parametrize("name", ["follow_centre_line", "stay_inside_borders",
                                      "prevent_zig_zag", "object_avoidance",
                                      "progress_per_step"])
    def test_examples_run(self, name: str) -> None:
        env = make_env(str(EXAMPLES / f"{name}.py"), race_type="object_avoidance",
                       rules="training")
        steps = drive(env, 40)
        rewards = [r for s in steps for r in s[1].values()]
        assert rewards and all(math.isfinite(r) for r in rewards)
        assert max(rewards) > 1e-3


class TestBadReturns:
    """Exceptions, non-numbers, NaN and inf stop the run; huge values warn once."""

    @pytest.mark.parametrize("body, match", [
        ("raise KeyError('speedd')", "raised KeyError"),
        ("return 'fast'", "returned 'fast'"),
        ("return None", "returned None"),
        ("return float('nan')", "returned nan"),
        ("return float('inf')", "returned inf"),
    ])
    def test_error_names_file_car_step_params(self, tmp_path: Path, body: str,
                                              match: str) -> None:
        path = tmp_path / "bad.py"
        path.write_text(f"def reward_function(params):\n    {body}\n")
        env = make_env(str(path))
        env.reset(seed=0)
        with pytest.raises(RewardFunctionError, match=match) as info:
            env.step({a: np.zeros(2, np.float32) for a in env.agents})
        text = str(info.value)
        assert str(path) in text and "car_0" in text and "at step 1.0" in text
        assert "'progress':" in text and "<" in text  # params summarised (waypoints counted)

    def test_int_and_numpy_returns_are_cast(self) -> None:
        reward = DeepRacerReward(lambda p: np.float32(2.5), 1)
        assert reward(0, {"steps": 1.0}) == 2.5
        assert type(DeepRacerReward(lambda p: 3, 1)(0, {"steps": 1.0})) is float

    def test_huge_reward_warns_once_per_car(self) -> None:
        reward = DeepRacerReward(lambda p: 1e6, 2)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for _ in range(3):
                assert reward(0, {"steps": 1.0}) == 1e6
                reward(1, {"steps": 1.0})
        assert len(caught) == 2 and "car_0" in str(caught[0].message)

    def test_missing_file_and_function(self, tmp_path: Path) -> None:
        with pytest.raises(FileNotFoundError, match="does not exist"):
            DeepRacerReward(tmp_path / "nope.py", 1)
        path = tmp_path / "empty.py"
        path.write_text("x = 1\n")
        with pytest.raises(TypeError, match="must define a function reward_function"):
            DeepRacerReward(path, 1)
        path.write_text("import nonexistent_module_xyz\n")
        with pytest.raises(RewardFunctionError, match="importing"):
            DeepRacerReward(path, 1)
        with pytest.raises(TypeError, match="path to a .py file or a callable"):
            DeepRacerReward(42, 1)
