"""RLlib's multi-agent PPO trains the race through its PettingZoo wrapper
(examples/rllib_multi_agent.py). Slow: starting Ray and building PPO take tens of seconds."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def example():
    # Imported here, not at collection: ray.rllib takes seconds to import.
    pytest.importorskip("ray.rllib", reason="needs ray[rllib] (the dev extra)")
    spec = importlib.util.spec_from_file_location("rllib_multi_agent",
                                                  ROOT / "examples" / "rllib_multi_agent.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def local_ray():
    import ray

    from h2h_racing.league.backends import local_ray_options

    ray.init(log_to_driver=False, **local_ray_options(num_cpus=2))
    yield ray
    ray.shutdown()


def _weights(algo, module_id):
    state = algo.get_module(module_id).get_state()
    return {k: np.array(v, copy=True) for k, v in state.items() if hasattr(v, "shape")}


def test_each_car_trains_its_own_policy(example, local_ray):
    config = example.build_config(track="oval", cars=2, max_cycles=100, batch=200)
    algo = config.build_algo()
    try:
        assert set(algo.config.policies) == {"car_0", "car_1"}
        before = {m: _weights(algo, m) for m in ("car_0", "car_1")}
        steps = []
        for _ in range(2):
            result = algo.train()
            steps.append(result["env_runners"]["num_env_steps_sampled_lifetime"])
        after = {m: _weights(algo, m) for m in ("car_0", "car_1")}
    finally:
        algo.stop()
    assert steps[0] >= 200 and steps[1] >= steps[0] + 200
    for module in ("car_0", "car_1"):
        assert before[module].keys() == after[module].keys() and before[module]
        # PPO updated every car's own network.
        assert any(not np.array_equal(before[module][k], after[module][k])
                   for k in before[module]), module


def test_example_runs_with_parameter_sharing(example, local_ray, capsys):
    assert example.main(["--cars", "3", "--iterations", "1", "--shared", "--batch", "200"]) == 0
    out = capsys.readouterr().out
    assert "iteration 1:" in out
    # Returns are reported per module: only the shared one exists, never one per car.
    assert "car_" not in out
    config = example.build_config(cars=3, shared=True)
    assert set(config.policies) == {"shared"}
    assert {config.policy_mapping_fn(f"car_{i}", None) for i in range(3)} == {"shared"}
