"""How much lateral acceleration the simulated car reaches at full lock, against mu g.

The car model (h2h_racing.sim.dynamics) saturates each axle's lateral force at mu times its
load, so a car with friction 1.0 should corner at up to 1 g. Two measurements:

* ``core``: a car in a RaceCore (the env's own step: dynamics, then pymunk) rolling at a
  speed, given that speed and a constant steering angle as commands on ``grand_loop``; the
  lateral acceleration is speed times yaw rate at its last step on the track (within 0.6 s;
  the yaw rate settles in 3-4 steps).
* ``model``: the single-track step alone in a loop that does what the core does between two
  steps (the velocity held during a step is rotated to the mid-step heading; the heading read
  back at the next step is the end-of-step one), with ``--held-heading`` reading the velocity
  back at the heading it was held at (yaw - dt r / 2) instead.

    python experiments/physics/lateral_grip.py
"""

from __future__ import annotations

import argparse
import inspect
import math
import re
import textwrap

import numpy as np
from numba import njit

from h2h_racing.config.car import CarParams
from h2h_racing.config.env import EnvConfig
from h2h_racing.config.rules import RaceRules
from h2h_racing.sim import dynamics
from h2h_racing.sim.core import RaceCore
from h2h_racing.track.io import load_track

SPEEDS = (1.5, 2.5, 3.5)
STEERS = (10.0, 15.0, 20.0, 30.0)


def held_heading_step():
    """The dynamics kernel with the body-frame velocity read at the heading it was held at."""
    src = textwrap.dedent(inspect.getsource(dynamics._single_track_step.py_func))
    src = re.sub(r"@njit\([^)]*\)\n", "", src)
    old = "        c = math.cos(yaw[i])\n        s = math.sin(yaw[i])\n"
    new = ("        held = yaw[i] - 0.5 * dt * yaw_rate[i]\n        c = math.cos(held)\n"
           "        s = math.sin(held)\n")
    if old not in src:
        raise RuntimeError("the dynamics kernel changed: update this experiment")
    namespace = dict(dynamics.__dict__)
    exec(src.replace(old, new), namespace)  # our own source, patched: nothing read from input
    return njit(namespace["_single_track_step"])


def model_g(speed: float, steer_deg: float) -> float:
    """Lateral acceleration [g] after 3 s of the model loop (the core's bookkeeping)."""
    model = dynamics.SingleTrackModel(CarParams())
    dt = 1.0 / 15.0
    yaw, vel, rate, steer = np.zeros(1), np.array([[speed, 0.0]]), np.zeros(1), np.zeros(1)
    for _ in range(45):
        vel, rate, steer = model.step(yaw, vel, rate, steer, np.array([math.radians(steer_deg)]),
                                      np.array([speed]), np.ones(1, dtype=bool), dt)
        yaw = yaw + rate * dt  # pymunk advances the angle by the held yaw rate
    return float(rate[0] * speed / dynamics.GRAVITY)


def core_g(speed: float, steer_deg: float) -> float:
    """Lateral acceleration [g] of a car in the RaceCore after 0.6 s at constant commands."""
    cfg = EnvConfig(track="grand_loop", num_cars=1, race_type="time_trial",
                    rules=RaceRules(laps=1, time_limit=30.0))
    core = RaceCore(cfg, load_track("grand_loop"), num_envs=1)
    core.reset(seed=0, start=np.array([0.0]), rolling=speed)
    steer = np.full((1, 1), math.radians(steer_deg))
    g = 0.0
    for _ in range(9):
        core.step(steer, np.full((1, 1), speed))
        if not core.racing[0, 0]:  # off the track: frozen for its penalty
            break
        g = float(core.speed[0, 0] * abs(core.yaw_rate[0, 0]) / dynamics.GRAVITY)
    return g


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--held-heading", action="store_true",
                        help="read the velocity back at the heading it was held at")
    args = parser.parse_args()
    if args.held_heading:
        dynamics._single_track_step = held_heading_step()
    print("friction 1.0: lateral acceleration [g] at each steering angle [deg]")
    for speed in SPEEDS:
        model = "  ".join(f"{s:.0f}: {model_g(speed, s):.2f}" for s in STEERS)
        core = "  ".join(f"{s:.0f}: {core_g(speed, s):.2f}" for s in STEERS)
        print(f"{speed:.1f} m/s  model loop  {model}   |  core  {core}")


if __name__ == "__main__":
    main()
