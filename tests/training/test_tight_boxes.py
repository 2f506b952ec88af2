"""Tight boxes for object-avoidance training ([race] tight_box_share,
h2h_racing.training.tight_boxes): the room beside a box worked by hand, the move of a box,
the VecEnv's layouts with the option on and off, and bad settings refused."""

from __future__ import annotations

import numpy as np
import pytest

from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim import layouts
from h2h_racing.track.shape import Track
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.race_settings import RaceSettings
from h2h_racing.training.tight_boxes import TightBoxes, box_room, tight_places, tighten
from h2h_racing.training.vec_env import RacingVecEnv

BOX = (0.5, 0.4)  # DeepRacer's crash rectangle: length, width [m]


def circle(radius: float, width: float | np.ndarray, count: int = 400) -> Track:
    """An anticlockwise circle (its inside on the left), ``width`` [m] wide."""
    a = np.linspace(0.0, 2 * np.pi, count, endpoint=False)
    half = 0.5 * np.broadcast_to(width, a.shape)
    return Track(np.c_[radius * np.cos(a), radius * np.sin(a)], half, half, name="circle")


def test_room_beside_a_box_by_hand() -> None:
    track = circle(2.0, 0.6)
    s = np.array([1.0, 5.0])
    # Outside lane (right, d = -0.15): the left half-width 0.3 + 0.15 - 0.2 = 0.25 m.
    assert box_room(track, s, np.array([-1.0, -1.0]), *BOX) == pytest.approx(0.25, abs=1e-3)
    # Inside lane (left): 0.25 less the bulge of a straight box's ends, its outer side on a
    # 2 - 0.15 + 0.2 = 2.05 m radius: sqrt(2.05^2 + 0.25^2) - 2.05 = 0.01519 m.
    bulge = np.sqrt(2.05 ** 2 + 0.25 ** 2) - 2.05
    assert box_room(track, s, np.array([1.0, 1.0]), *BOX) == pytest.approx(0.25 - bulge,
                                                                           abs=1e-3)


def test_tight_places_are_the_inside_lane_within_the_boxes_part_of_the_lap() -> None:
    track = circle(2.0, 0.6)
    s, lane = tight_places(track, (0.21, 0.24), *BOX, grid_length=0.33)
    assert len(s) and np.all(lane == 1.0)
    assert s.min() >= layouts.OBSTACLE_CLEAR_START
    assert s.max() <= track.length - layouts.OBSTACLE_CLEAR_END - 0.33
    assert len(tight_places(track, (0.3, 0.5), *BOX, grid_length=0.33)[0]) == 0


def test_the_nearest_box_moves_and_the_gaps_are_kept() -> None:
    s = np.array([[4.0, 8.0, 12.0]])
    lane = np.array([[1.0, -1.0, 1.0]])
    rng = np.random.default_rng(0)
    # A place at 9.0: the box at 8.0 is nearest, the others 5 and 3 m away: moved there.
    new_s, new_lane, moved = tighten(s, lane, (np.array([9.0]), np.array([1.0])), rng, 1.0, 2.0)
    assert moved == 1 and new_s.tolist() == [[4.0, 9.0, 12.0]]
    assert new_lane.tolist() == [[1.0, 1.0, 1.0]] and s[0, 1] == 8.0  # the input untouched
    # A place at 10.0 between boxes 8 and 12: either move leaves a box 2 m away; at 10.5 the
    # box at 12 moves and 8 stays 2.5 m away; at 9.9 with min_gap 2.5 neither move is clear.
    assert tighten(s, lane, (np.array([10.5]), np.array([-1.0])), rng, 1.0, 2.0)[0].tolist() \
        == [[4.0, 8.0, 10.5]]
    assert tighten(s, lane, (np.array([9.9]), np.array([1.0])), rng, 1.0, 2.5)[2] == 0
    # Share 0: never moved.
    assert tighten(s, lane, (np.array([9.0]), np.array([1.0])), rng, 0.0, 2.0)[2] == 0


def narrow_bend_track() -> Track:
    """A 3 m radius circle, 1.2 m wide but for 0.6 m over 2 m of its lap (at 9-11 m)."""
    count = 600
    arc = np.arange(count) * (2 * np.pi * 3.0 / count)
    width = np.where((arc > 9.0) & (arc < 11.0), 0.6, 1.2)
    return circle(3.0, width, count)


def boxes_env(tight: TightBoxes | None, seed: int = 3, num_envs: int = 16) -> RacingVecEnv:
    config = EnvConfig(track="oval", num_cars=1, race_type="object_avoidance",
                       rules=RaceRules.preset("object_avoidance", "training"),
                       randomize_obstacles=True)
    return RacingVecEnv(config, num_envs=num_envs, seed=seed, track=narrow_bend_track(),
                        tight_boxes=tight)


def tight_layouts(env: RacingVecEnv, room: tuple[float, float]) -> np.ndarray:
    core = env.core
    free = box_room(core.tracks[0], core.obstacle_s, core.obstacle_lane, *BOX)
    return ((free >= room[0] - 1e-6) & (free <= room[1] + 1e-6)).any(axis=1)


def test_the_vec_env_moves_a_box_into_the_narrow_bend() -> None:
    room = (0.21, 0.24)  # the inside lane of the 0.6 m part: 0.25 less a 2.2 cm bulge
    off, on = boxes_env(None), boxes_env(TightBoxes(1.0, room))
    core = on.core
    # Off: as the env places them; the option's share 0 the same (no draw).
    same = boxes_env(TightBoxes(0.0, room))
    assert np.array_equal(off.core.obstacle_s, same.core.obstacle_s)
    # On: every copy has a box beside which the room is tight, in the narrow part, on the
    # inside lane; the boxes stay min_gap apart, and pymunk has them where the core has them.
    assert tight_layouts(on, room).all()
    assert tight_layouts(off, room).mean() < 0.5
    inside = (core.obstacle_s > 9.0) & (core.obstacle_s < 11.0) & (core.obstacle_lane == 1.0)
    assert inside.any(axis=1).all()
    gaps = np.diff(np.sort(core.obstacle_s, axis=1), axis=1)
    assert gaps.min() >= core.config.obstacle_min_gap - 1e-9
    k, e = core.num_obstacles, core.num_envs
    bodies = core.world.state[e * core.num_cars:e * core.num_cars + e * k, 0:2]
    expected = (core.obstacle_position + core.env_offset[:, None, :]).reshape(-1, 2)
    assert np.allclose(bodies, expected)
    # After episodes end the reset copies get tight boxes again.
    on.core.reset_envs(np.ones(e, bool))
    on._clear_starts(np.ones(e, bool))
    assert tight_layouts(on, room).all()


def test_race_table_settings() -> None:
    assert RaceSettings().tight_boxes() is None
    settings = RaceSettings(race_type="object_avoidance", tight_box_share=0.5,
                            tight_box_room=(0.21, 0.25))
    assert settings.tight_boxes() == TightBoxes(0.5, (0.21, 0.25))
    config = TrainConfig.from_dict({"track": "oval", "num_envs": 4,
                                    "race": {"race_type": "object_avoidance",
                                             "tight_box_share": 0.5}})
    assert config.make_env().tight_boxes == TightBoxes(0.5, (0.21, 0.24))
    with pytest.raises(ValueError, match=r"\[race\].tight_box_share must be a number in"):
        RaceSettings(tight_box_share=1.5)
    with pytest.raises(ValueError, match=r"tight_box_room must be \(low, high\).*0.196"):
        RaceSettings(tight_box_room=(0.1, 0.25))
    with pytest.raises(ValueError, match="tight_box_room"):
        RaceSettings(tight_box_room=(0.25, 0.21))
    with pytest.raises(ValueError, match="tight_boxes_share"):
        TrainConfig.from_dict({"race": {"tight_boxes_share": 0.5}})
