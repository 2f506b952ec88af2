"""The state observation's obstacle slots (:mod:`h2h_racing.sensors.state`), worked by hand.

One car on a 3 m radius circle (L = 18.8494 m), on the centre line at s = 4 m; two boxes whose
arc positions and offsets are set directly. Slot features: present, arc gap / 5 m, offset
minus the car's / 1 m; nearest first from 0.5 m behind the car's centre to 5 m ahead.
"""

from __future__ import annotations

import numpy as np
import pytest

from h2h_racing.config.env import EnvConfig
from h2h_racing.sim.core import RaceCore
from h2h_racing.sensors.state import BASE_FEATURES, OPPONENT_FEATURES, state_observation

from conftest import circle_track

TRACK = circle_track(3.0)
CAR_S = 4.0


def obstacle_slots(boxes: list[tuple[float, float]], car_s: float = CAR_S) -> np.ndarray:
    """The two obstacle slots (2, 3) of a car at s = car_s, d = 0 with boxes at (s, d)."""
    cfg = EnvConfig(track=TRACK.name, num_cars=1, grid="fixed", num_obstacles=len(boxes),
                    opponent_slots=2, obstacle_slots=2)
    core = RaceCore(cfg, TRACK, num_envs=1)
    core.reset(seed=0)
    core.s[0, 0], core.d[0, 0] = car_s, 0.0
    core.obstacle_s[0] = [s for s, _ in boxes]
    core.obstacle_d[0] = [d for _, d in boxes]
    first = BASE_FEATURES + 2 * OPPONENT_FEATURES
    return state_observation(core)[0, 0, first:].reshape(2, 3)


def test_a_box_beside_the_car_comes_first_with_a_negative_gap() -> None:
    # Box B 0.3 m behind the car's centre (its body still beside the car), box A 0.7 m ahead.
    slots = obstacle_slots([(CAR_S + 0.7, 0.25), (CAR_S - 0.3, -0.25)])
    np.testing.assert_allclose(slots, [[1.0, -0.3 / 5.0, -0.25], [1.0, 0.7 / 5.0, 0.25]],
                               atol=1e-6)


def test_a_box_more_than_half_a_metre_behind_is_gone() -> None:
    slots = obstacle_slots([(CAR_S + 0.7, 0.25), (CAR_S - 0.6, -0.25)])
    np.testing.assert_allclose(slots, [[1.0, 0.7 / 5.0, 0.25], [0.0, 0.0, 0.0]], atol=1e-6)


@pytest.mark.parametrize(("ahead", "seen"), [(4.9, True), (5.1, False)])
def test_boxes_are_seen_up_to_five_metres_ahead(ahead: float, seen: bool) -> None:
    slots = obstacle_slots([(CAR_S + ahead, 0.0)])
    expected = [1.0, ahead / 5.0, 0.0] if seen else [0.0, 0.0, 0.0]
    np.testing.assert_allclose(slots[0], expected, atol=1e-6)


def test_the_window_wraps_round_the_start_line() -> None:
    # Car 0.2 m past the line: a box 0.2 m before the line is 0.4 m behind it, one at 1 m is
    # 0.8 m ahead.
    slots = obstacle_slots([(1.0, 0.0), (TRACK.length - 0.2, 0.1)], car_s=0.2)
    np.testing.assert_allclose(slots, [[1.0, -0.4 / 5.0, 0.1], [1.0, 0.8 / 5.0, 0.0]],
                               atol=1e-6)
