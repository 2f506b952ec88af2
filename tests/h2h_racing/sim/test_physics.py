"""Tests for :mod:`h2h_racing.sim.physics`: contacts never tunnel and leave no deep overlap."""

from __future__ import annotations

import numpy as np
import pytest

from h2h_racing.config.env import CarParams
from h2h_racing.sim.physics import PhysicsWorld

from conftest import box_corners, box_penetration

DT = 1.0 / 15.0
CAR = CarParams()
SLOP = 0.03  # [m] largest acceptable overlap once a contact is resolved ("a few cm")
SUB_DT = DT / 4  # pymunk sub-step with the default 4 sub-steps
SETTLE = 3  # steps after the first contact by which the overlap must be below SLOP
OBSTACLE = (0.5, 0.4)


def hold(world: PhysicsWorld, velocity: np.ndarray, omega: np.ndarray) -> None:
    """Hold the cars' velocities (C, 2) and yaw rates (C,) for one 1/15 s step of 4 sub-steps."""
    world.command[:, :2] = velocity
    world.command[:, 2] = omega
    world.step(DT, 4)


def driven(world: PhysicsWorld, command: np.ndarray) -> np.ndarray:
    """Car velocities for the next step: each car's current velocity along its heading, pushed
    toward ``command`` [m/s] by the speed controller (a = 6 (v_cmd - v) within [-5, 3] m/s^2),
    as the core's dynamics do (a contact that stopped a car must be re-accelerated)."""
    st = world.state[: world.num_cars]
    heading = np.stack([np.cos(st[:, 2]), np.sin(st[:, 2])], axis=1)
    v = np.einsum("ij,ij->i", st[:, 3:5], heading)
    v = v + np.clip(CAR.speed_gain * (command - v), -CAR.max_brake, CAR.max_accel) * DT
    return heading * v[:, None]


def make_world(num_cars: int, num_obstacles: int = 0) -> PhysicsWorld:
    return PhysicsWorld(num_cars=num_cars, num_obstacles=num_obstacles,
                        car_size=(CAR.length, CAR.width), car_mass=CAR.mass,
                        car_inertia=CAR.yaw_inertia, obstacle_size=OBSTACLE,
                        friction=CAR.body_friction, elasticity=CAR.body_elasticity)


class TestNoTunnelling:
    """Full-speed impacts stop at the other body."""

    def test_head_on_at_full_speed(self) -> None:
        world = make_world(2)
        # Car 0 at x = -4 heading +x, car 1 at x = +4 heading -x, both flat out: each reaches
        # 4 m/s after ~1.5 s and ~3.5 m (8 m/s closing, 0.13 m per 1/60 s sub-step).
        world.set_state(np.array([[-4.0, 0.0], [4.0, 0.0]]), np.array([0.0, np.pi]),
                        np.zeros((2, 2)), np.zeros(2))
        contacts = 0
        first = None
        top = 0.0
        for step in range(60):
            vel = driven(world, np.array([4.0, 4.0]))
            top = max(top, float(np.abs(vel[:, 0]).min()))
            hold(world, vel, np.zeros(2))
            a, _ = world.pop_contacts()
            contacts += a.size
            if a.size and first is None:
                first = step
            st = world.state
            assert st[0, 0] < st[1, 0], f"[{step}] passed through"
            corners = box_corners(st[:2, :2], st[:2, 2], CAR.length, CAR.width)
            depth = box_penetration(corners[0], corners[1])
            # Discrete detection: at impact the overlap is at most one sub-step of closing
            # travel, 8 m/s * 1/60 s = 0.133 m; a few steps later it is resolved.
            assert depth <= 8.0 * SUB_DT, f"[{step}] overlap {depth:.3f} m"
            if first is not None and step >= first + SETTLE:
                assert depth <= SLOP, f"[{step}] overlap {depth:.3f} m not resolved"
        assert contacts >= 1 and top >= 3.9  # they met at (nearly) full speed
        # Released (no more driving), the cars end separated.
        for _ in range(10):
            hold(world, np.zeros((2, 2)), np.zeros(2))
        st = world.state
        corners = box_corners(st[:2, :2], st[:2, 2], CAR.length, CAR.width)
        assert box_penetration(corners[0], corners[1]) <= 0.005
        assert st[1, 0] - st[0, 0] >= CAR.length - 0.005

    def test_full_speed_into_obstacle(self) -> None:
        world = make_world(1, 1)
        # Obstacle (kinematic, 0.5 x 0.4 m) centred at x = 2: its near face is at x = 1.75;
        # the car's nose is at x + 0.162, so the car centre must stay below 1.75 - 0.162 = 1.588.
        # The car starts 5 m back, so it arrives at its 4 m/s top speed.
        world.set_state(np.array([[-3.0, 0.0], [2.0, 0.0]]), np.zeros(2), np.zeros((2, 2)),
                        np.zeros(2))
        first = None
        for step in range(60):
            hold(world, driven(world, np.array([4.0])), np.zeros(1))
            if world.pop_contacts()[0].size and first is None:
                first = step
            st = world.state
            # At most one sub-step of travel (4 m/s * 1/60 s = 0.067 m) into it at impact,
            # resolved to a few mm within SETTLE steps.
            limit = SLOP if first is not None and step >= first + SETTLE else 4.0 * SUB_DT
            assert st[0, 0] <= 1.75 - 0.5 * CAR.length + limit, f"[{step}] x = {st[0, 0]:.3f}"
            # The obstacle cannot be pushed.
            assert st[1, :3].tolist() == [2.0, 0.0, 0.0]
        # The car reached the obstacle (it stops *at* it, not before).
        assert st[0, 0] == pytest.approx(1.75 - 0.5 * CAR.length, abs=SLOP)


class TestContactsReported:
    """New contacts are reported once, with body indices cars-then-obstacles."""

    def test_pairs_and_indices(self) -> None:
        world = make_world(2, 1)
        world.set_state(np.array([[0.0, 0.0], [0.0, 3.0], [0.6, 0.0]]), np.zeros(3),
                        np.zeros((3, 2)), np.zeros(3))
        seen = []
        for _ in range(20):
            hold(world, driven(world, np.array([2.0, 0.0])), np.zeros(2))
            a, b = world.pop_contacts()
            seen += [tuple(sorted(p)) for p in zip(a.tolist(), b.tolist())]
        # Car 0 (index 0) hits the obstacle (index 2) once; car 1 is far away.
        assert seen == [(0, 2)]
        assert world.pop_contacts()[0].size == 0


class TestStackedCars:
    """A pile-up of several cars resolves without deep overlap."""

    def test_four_car_pileup(self) -> None:
        world = make_world(4, 1)
        xs = np.array([0.0, -0.5, -1.0, -1.5])
        pos = np.concatenate([np.stack([xs, np.zeros(4)], 1), [[1.0, 0.0]]])
        world.set_state(pos, np.zeros(5), np.zeros((5, 2)), np.zeros(5))
        for step in range(45):
            # Everyone floors it into the obstacle; cars behind faster, with some yaw.
            hold(world, driven(world, np.array([2.0, 3.0, 4.0, 4.0])),
                 np.array([0.0, 0.3, -0.3, 0.0]))
            st = world.state
            corners = box_corners(st[:4, :2], st[:4, 2], CAR.length, CAR.width)
            i, j = np.triu_indices(4, 1)
            depth = box_penetration(corners[i], corners[j])
            assert depth.max() <= SLOP, f"[{step}] car overlap {depth.max():.3f} m"
            obstacle = box_corners(st[4, :2], st[4, 2], *OBSTACLE)
            odepth = box_penetration(corners, np.broadcast_to(obstacle, corners.shape))
            assert odepth.max() <= SLOP, f"[{step}] obstacle overlap {odepth.max():.3f} m"
