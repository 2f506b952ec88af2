"""``policies.trained_numpy``: a plain MLP actor in numpy acts as torch's within a few float32
ulps, gives a row the same bits whatever else is in its batch, and a command driving a
state-observation policy never imports torch."""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from h2h_racing.config.env import EnvConfig
from h2h_racing.policies.trained import TrainedPolicy, load_policy_payload, shipped_policies
from h2h_racing.policies.trained_numpy import (ACTIVATIONS, MAX_TILE_ROWS, NumpyActor,
                                               numpy_actor, tiling)
from h2h_racing.sim.core import RaceCore
from h2h_racing.track.io import load_track

torch = pytest.importorskip("torch")

from h2h_racing.policies.trained_plain import plain_actor  # noqa: E402

MLP_POLICIES = [name for name, path in shipped_policies().items()
                if load_policy_payload(path)["actor_cfg"]["class_name"] == "MLPModel"]
EPS = float(np.finfo(np.float32).eps)
TOLERANCE = 16
"""Largest difference from torch's action allowed, in ``EPS * sum |terms|`` of the last
layer's dot product (its bias and each weight times hidden unit, in float64): what float32
rounding can move a sum of those terms by. Two float32 sums of the same K terms in other
orders differ by up to about ``K * EPS * sum |terms|`` at worst and ``sqrt(K)`` times that
typically; the measured largest is 4.5 (every shipped MLP, real and random inputs), with the
hidden layers' own differences and the ELU's ``exp(x) - 1`` in it."""
REAL_ULPS = 8
"""On observations of real driving the actions are within 1.7 of 0; the largest difference
measured is 4.5 ulps of 1 (5.4e-7, obstacle_generalist); allowed: 8."""


def _real_observations(name: str, copies: int = 16, steps: int = 150) -> np.ndarray:
    """The ``policy`` group of the driver's own laps of kidney, every 10th step."""
    driver = TrainedPolicy(shipped_policies()[name])
    config = EnvConfig(num_cars=1)
    core = RaceCore(config, load_track("kidney"), num_envs=copies)
    core.reset(seed=3)
    driver.reset(core)
    seen = []
    for step in range(steps):
        core.step(*config.commands(driver.act(core, 0)[:, None, :]))
        if step % 10 == 0:
            seen.append(driver._observe(core, 0)["policy"])
    return np.concatenate(seen)


def _term_sizes(payload: dict[str, Any], x: np.ndarray) -> np.ndarray:
    """``sum |terms|`` of each row's last dot products (float64, the network's own ELU)."""
    state = {k: np.asarray(v, dtype=np.float64) for k, v in payload["actor_state_dict"].items()}
    h = (x - state["obs_normalizer._mean"]) / (state["obs_normalizer._std"] + 0.01)
    layers = len([k for k in state if k.startswith("mlp.") and k.endswith(".weight")])
    for i in range(layers - 1):
        h = h @ state[f"mlp.{2 * i}.weight"].T + state[f"mlp.{2 * i}.bias"]
        h = np.where(h > 0, h, np.expm1(np.minimum(h, 0)))
    last = f"mlp.{2 * (layers - 1)}"
    return np.abs(h) @ np.abs(state[f"{last}.weight"].T) + np.abs(state[f"{last}.bias"])


@pytest.mark.parametrize("name", MLP_POLICIES)
def test_actions_are_torchs_within_a_few_ulps(name: str) -> None:
    payload = load_policy_payload(name)
    state = payload["actor_state_dict"]
    mean = state["obs_normalizer._mean"].numpy()
    std = state["obs_normalizer._std"].numpy()
    rng = np.random.default_rng(0)
    real = _real_observations(name)
    spread = [(mean + std * rng.normal(0.0, scale, (2000, mean.shape[1]))).astype(np.float32)
              for scale in (1.0, 3.0, 10.0)]
    for x in [real, *spread]:
        obs = {"policy": x}
        ours = numpy_actor(payload, obs)
        theirs = plain_actor(payload, obs)
        assert isinstance(ours, NumpyActor) and theirs is not None
        with torch.inference_mode():
            want = theirs(obs).numpy()
        got = ours(obs)
        assert got.dtype == np.float32 and got.shape == want.shape
        assert np.all(np.abs(got - want) <= TOLERANCE * EPS * _term_sizes(payload, x))
    with torch.inference_mode():
        want = plain_actor(payload, {"policy": real})({"policy": real}).numpy()  # type: ignore
    assert np.abs(numpy_actor(payload, {"policy": real})({"policy": real})  # type: ignore
                  - want).max() <= REAL_ULPS * EPS


def test_tiles() -> None:
    assert [tiling(b) for b in (1, 10, 16, 17, 20, 32, 33, 40, 800)] == [
        (1, 1), (1, 10), (1, 16), (2, 9), (2, 10), (2, 16), (3, 11), (3, 14), (50, 16)]
    for block in range(1, 200):
        tiles, rows = tiling(block)
        assert rows <= MAX_TILE_ROWS and tiles * rows >= block > (tiles - 1) * rows


@pytest.mark.parametrize("name", MLP_POLICIES)
def test_a_row_keeps_its_bits_whatever_else_is_in_the_batch(name: str) -> None:
    """Blocks of 1 to 800 rows: a forward pass of many blocks gives each row the bits of its
    block alone; OpenBLAS's thread count does not change them (without tiles, OpenBLAS gives
    a row other bits by where it sits in the batch: ``test_what_the_tiles_are_for``)."""
    payload = load_policy_payload(name)
    rng = np.random.default_rng(1)
    x = rng.normal(0.0, 3.0, (4000, 33)).astype(np.float32)
    actor = numpy_actor(payload, {"policy": x[:1]})
    assert actor is not None
    limits = pytest.importorskip("threadpoolctl").threadpool_limits
    for block in (1, 2, 3, 4, 5, 10, 12, 13, 16, 17, 20, 33, 40, 100, 800):
        blocks = min(len(x) // block, 40)
        rows = x[:blocks * block]
        whole = actor({"policy": rows}, block)
        with limits(1, user_api="blas"):
            assert np.array_equal(actor({"policy": rows}, block), whole)
        for b in range(blocks):
            alone = actor({"policy": np.ascontiguousarray(rows[b * block:(b + 1) * block])})
            assert np.array_equal(alone, whole[b * block:(b + 1) * block]), (block, b)


def _blas() -> str:
    try:
        return str(np.show_config(mode="dicts")["Build Dependencies"]["blas"]["name"])
    except (TypeError, KeyError):  # numpy before 1.26: no mode
        return "unknown"


def test_what_the_tiles_are_for() -> None:
    """On OpenBLAS (numpy's wheels), a plain 2-D matmul of the first layer gives some row
    other bits in a batch of 40 than in a batch of 10 (its sgemm handles rows in groups of
    12 on x86-64, a partial group with another kernel): why the actor multiplies tiles."""
    if "openblas" not in _blas():
        pytest.skip(f"numpy's BLAS is {_blas()}, not OpenBLAS")
    actor = numpy_actor(load_policy_payload("ppo_generalist"),
                        {"policy": np.zeros((1, 33), dtype=np.float32)})
    assert actor is not None
    x = np.random.default_rng(1).normal(0.0, 3.0, (40, 33)).astype(np.float32)
    weight = actor.layers[0][0]
    assert not np.array_equal((x @ weight)[:10], x[:10] @ weight)


def _payload(activation: str, seed: int = 0) -> dict[str, Any]:
    """ppo_generalist's file with random weights and another activation."""
    payload = copy.deepcopy(load_policy_payload("ppo_generalist"))
    payload["actor_cfg"]["activation"] = activation
    generator = torch.Generator().manual_seed(seed)
    for key, value in payload["actor_state_dict"].items():
        if key.startswith("mlp."):
            payload["actor_state_dict"][key] = torch.randn(value.shape, generator=generator) * 0.3
    return payload


@pytest.mark.parametrize("activation", sorted(ACTIVATIONS))
def test_every_activation_is_torchs(activation: str) -> None:
    payload = _payload(activation)
    x = np.random.default_rng(2).normal(0.0, 3.0, (500, 33)).astype(np.float32)
    obs = {"policy": x}
    with torch.inference_mode():
        want = plain_actor(payload, obs)(obs).numpy()  # type: ignore[misc]
    got = numpy_actor(payload, obs)(obs)  # type: ignore[misc]
    scale = np.abs(want).max()
    assert np.abs(got - want).max() <= 64 * EPS * max(scale, 1.0), activation


def test_gelu_acts_with_torch() -> None:
    payload = _payload("gelu")
    obs = {"policy": np.zeros((2, 33), dtype=np.float32)}
    assert numpy_actor(payload, obs) is None and plain_actor(payload, obs) is not None
    driver = TrainedPolicy.from_payload(payload, "gelu")
    core = RaceCore(EnvConfig(num_cars=1), load_track("oval"), num_envs=3)
    core.reset(seed=0)
    driver.reset(core)
    assert driver._forward is not None and not isinstance(driver._forward, NumpyActor)
    assert driver.act(core, 0).shape == (3, 2)


@pytest.mark.parametrize("name", MLP_POLICIES)
def test_a_file_and_its_payload_in_memory_act_alike(name: str) -> None:
    """A driver from the file (numpy arrays) and one from torch's payload in memory (as
    training evaluates its iterations) act in numpy, to the same bits."""
    from_file = TrainedPolicy(shipped_policies()[name])
    in_memory = TrainedPolicy.from_payload(load_policy_payload(name), name)
    config = EnvConfig(num_cars=1)
    core = RaceCore(config, load_track("oval"), num_envs=5)
    core.reset(seed=1)
    for driver in (from_file, in_memory):
        driver.reset(core)
        assert isinstance(driver._forward, NumpyActor)
    for _ in range(20):
        action = from_file.act(core, 0)
        assert action.dtype == np.float32 and np.array_equal(action, in_memory.act(core, 0))
        assert np.all(np.abs(action) <= 1.0)
        core.step(*config.commands(action[:, None, :]))


HEAVY = ("torch", "rsl_rl", "tensordict", "rerun", "matplotlib", "ray")


def test_commands_driving_a_state_policy_never_import_torch(tmp_path: Path) -> None:
    """``evaluate`` over a folder of routes and on one track with ``ppo_generalist``, a
    ``race`` of ``league_racer`` against a car (its file read for the trained-alone warning
    too) and a ``tournament``: none of ``HEAVY`` is imported (torch alone was 2-3 s of a
    command)."""
    routes = tmp_path / "routes"
    routes.mkdir()
    catalogue = Path(load_track.__code__.co_filename).resolve().parents[2] / "tracks"
    for name in ("oval", "kidney"):
        (routes / f"{name}.json").write_text((catalogue / f"{name}.json").read_text())
    commands = [
        ["evaluate", "--policy", "ppo_generalist", "--track", str(routes), "--episodes", "2",
         "--jobs", "1", "--json", str(tmp_path / "routes.json"), "--no-progress"],
        ["evaluate", "--policy", "ppo_generalist", "--track", "oval", "--episodes", "2"],
        ["race", "--track", "oval", "--laps", "1", "--drivers", "league_racer,racing_line",
         "--no-progress"],
        ["tournament", "--players", "league_racer,racing_line", "--tracks", "oval", "--races",
         "1", "--laps", "1", "--league", str(tmp_path / "league.sqlite"), "--backend",
         "inprocess"],
    ]
    code = ("import sys; from h2h_racing.cli.command import main\n"
            f"for argv in {commands!r}:\n"
            "    assert main(argv) in (0, 1), argv\n"
            f"print('HEAVY', sorted(m for m in {HEAVY!r} if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=tmp_path, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "HEAVY []", done.stdout
    assert json.loads((tmp_path / "routes.json").read_text())["summary"]["routes"] == 2
    # Without torch installed (None in sys.modules fails its import), the race still runs.
    code = ("import sys; sys.modules['torch'] = None; from h2h_racing.cli.command import main; "
            f"sys.exit(main({commands[2]!r}))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=tmp_path, timeout=300)
    assert done.returncode == 0 and "league_racer" in done.stdout, done.stderr
