"""Fuzzing the batched core: random and extreme actions over several tracks and race types.

>= 100,000 car-steps in total; after every step: no NaN/inf in the state, observations finite,
float32 and within [-5, 5], and no car (or obstacle) inside another beyond a sub-step of travel.
"""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.sensors.state import OBS_BOUND, state_observation
from h2h_racing.track.io import load_track

from conftest import box_corners, box_penetration

# At impact two cars can overlap by one sub-step of closing travel (8 m/s * 1/60 s = 0.133 m,
# see test_physics); anything deeper means one body went (partly) through another.
MAX_OVERLAP = 0.14
STATE_FIELDS = ("position", "yaw", "velocity", "yaw_rate", "steer", "speed", "s", "d", "distance",
                "time")
CASES = [
    # (track, race_type, num_cars, num_envs, steps, rules): 4*32*200 + 5*24*200 + 6*16*200
    # + 2*32*200 = 25600 + 24000 + 19200 + 12800 = 81,600 car-steps, plus 3*24*300 = 21,600.
    ("speedway", "head_to_head", 4, 32, 200, "race"),
    ("grand_loop", "object_avoidance", 5, 24, 200, "race"),
    ("technical", "head_to_head", 6, 16, 200, "training"),
    ("hairpin_valley", "time_trial", 2, 32, 200, "race"),
    ("kidney", "object_avoidance", 3, 24, 300, "training"),
]


def actions(rng: np.random.Generator, step: int, e: int, n: int) -> np.ndarray:
    """(E, N, 2) actions in [-1, 1]; env copy k uses mode k % 4: uniform random, extreme
    (+-1 corners), alternating full lock each step, or random held for 10 steps."""
    out = rng.uniform(-1.0, 1.0, (e, n, 2))
    mode = np.arange(e) % 4
    extreme = np.sign(rng.uniform(-1.0, 1.0, (e, n, 2)))
    out[mode == 1] = extreme[mode == 1]
    alt = np.empty((e, n, 2))
    alt[..., 0] = 1.0 if step % 2 else -1.0
    alt[..., 1] = 1.0
    out[mode == 2] = alt[mode == 2]
    held = np.random.default_rng(step // 10).uniform(-1.0, 1.0, (e, n, 2))
    out[mode == 3] = held[mode == 3]
    return out


@pytest.mark.parametrize(("track", "race_type", "num_cars", "num_envs", "steps", "mode"), CASES)
def test_fuzz_core(track: str, race_type: str, num_cars: int, num_envs: int, steps: int,
                   mode: str) -> None:
    rng = np.random.default_rng(zlib.crc32(f"{track}/{num_cars}".encode()))
    cfg = EnvConfig(track=track, race_type=race_type, num_cars=num_cars,
                    rules=RaceRules.preset(race_type, mode), randomize_obstacles=True)
    core = RaceCore(cfg, load_track(track), num_envs=num_envs)
    core.reset(seed=int(rng.integers(1000)))
    car = cfg.car
    mid, half = 0.5 * (cfg.max_speed + cfg.min_speed), 0.5 * (cfg.max_speed - cfg.min_speed)
    i, j = np.triu_indices(num_cars, 1)
    car_steps = 0
    for step in range(steps):
        act = actions(rng, step, num_envs, num_cars)
        core.step(act[..., 0] * car.max_steer, mid + half * act[..., 1])
        car_steps += num_envs * num_cars
        for name in STATE_FIELDS:
            value = getattr(core, name)
            assert np.isfinite(value).all(), f"[{step}] non-finite {name}"
        obs = state_observation(core)
        assert obs.dtype == np.float32 and np.isfinite(obs).all(), f"[{step}] obs"
        assert np.abs(obs).max() <= OBS_BOUND, f"[{step}] obs out of bounds"
        # Geometric overlap between cars that are on the track (parked cars are off it).
        corners = box_corners(core.position, core.yaw, car.length, car.width)
        live = ~core.done
        if len(i):
            depth = box_penetration(corners[:, i], corners[:, j]) * (live[:, i] & live[:, j])
            assert depth.max() <= MAX_OVERLAP, (
                f"[{step}] cars overlap {depth.max():.3f} m at env/pair "
                f"{np.unravel_index(depth.argmax(), depth.shape)}")
        if core.num_obstacles:
            ob = box_corners(core.obstacle_position, core.obstacle_yaw, cfg.obstacle_length,
                             cfg.obstacle_width)
            depth = box_penetration(corners[:, :, None], ob[:, None, :]) * live[:, :, None]
            assert depth.max() <= MAX_OVERLAP, f"[{step}] car in obstacle {depth.max():.3f} m"
        # Finished or retired copies start again, so every step fuzzes live cars.
        over = core.done.all(axis=1)
        if over.any():
            core.reset_envs(over)
    assert car_steps >= steps * num_envs * num_cars


def test_no_car_spawns_inside_an_obstacle() -> None:
    import h2h_racing

    # oval (L = 20 m), 5 cars: grid slots at s = 0, 19.25, 18.5, 17.75, 17.0 m; seed 2 puts
    # obstacle 5 at s = 18.03 m on the inner lane, on top of car_3 (slot 3, inner lane).
    for seed in range(8):
        env = h2h_racing.parallel_env(track="oval", num_cars=5, race_type="object_avoidance",
                                      randomize_obstacles=True, grid="fixed")
        env.reset(seed=seed)
        core, cfg = env.core, env.config
        cars = box_corners(core.position, core.yaw, cfg.car.length, cfg.car.width)
        obstacles = box_corners(core.obstacle_position, core.obstacle_yaw, cfg.obstacle_length,
                                cfg.obstacle_width)
        depth = box_penetration(cars[:, :, None], obstacles[:, None, :])
        assert depth.max() == 0.0, f"seed {seed}: overlap {depth.max():.3f} m"
