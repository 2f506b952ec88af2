"""DeepRacer params contract: hand-computed values on a square track, real route files."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest

from h2h_racing.config.env import CarParams
from h2h_racing.deepracer.params import PARAM_KEYS, ParamsBuilder, copy_params
from h2h_racing.track.shape import Track
from h2h_racing.track.io import load_track

ROUTES = Path(__file__).resolve().parents[3] / ".." / "shared" / "data" / "deepracer_tracks"
CAR = CarParams()


def square_track() -> Track:
    """10 x 10 m square centre line, CCW, 1 m each side, with a duplicated row at (5, 0).

    Waypoints (K = 7): (0,0) (5,0) (5,0) (10,0) (10,10) (0,10) (0,0); L = 40 m; their
    normalised arc positions are [0, .125, .125, .25, .5, .75, 1.0].
    """
    centre = [(0, 0), (5, 0), (5, 0), (10, 0), (10, 10), (0, 10)]
    left = [(1, 1), (5, 1), (5, 1), (9, 1), (9, 9), (1, 9)]  # inner (left of CCW travel)
    right = [(-1, -1), (5, -1), (5, -1), (11, -1), (11, 11), (-1, 11)]
    return Track(np.array(centre, float), 1.0, 1.0, name="square",
                 left_border=np.array(left, float), right_border=np.array(right, float))


def build(builder: ParamsBuilder, position, yaw, *, steps=1.0, start=(0.0, 0.0), **kw):
    n = len(position)
    args = {"position": np.array(position, float), "yaw": np.array(yaw, float),
            "speed_command": np.full(n, 1.5), "steering_deg": np.full(n, -10.0),
            "start_distance": np.array(start, float)[:n], "steps": steps, "sim_time": 0.4}
    args.update(kw)
    return builder.build(**args)


class TestHandComputed:
    """Every key on the square track, with the arithmetic in comments."""

    def setup_method(self) -> None:
        self.track = square_track()
        self.builder = ParamsBuilder(self.track, CAR, 2)
        # car 0 at (2.86, 0.3) heading +x; car 1 at (10.3, 5) heading +y; a box at (7, -0.5).
        self.p0, self.p1 = build(
            self.builder, [(2.86, 0.3), (10.3, 5.0)], [0.0, math.pi / 2],
            speed=np.array([0.0, 1.2]), off_track=np.array([False, True]),
            crashed=np.array([True, False]), obstacle_position=np.array([[7.0, -0.5]]),
            obstacle_yaw=np.array([0.0]))

    def test_all_27_keys(self) -> None:
        assert set(self.p0) == set(PARAM_KEYS) and len(PARAM_KEYS) == 27

    def test_car_geometry(self) -> None:
        p = self.p0
        # P = (2.86 + 0.14, 0.3) = (3.0, 0.3); projection on segment (0,0)-(5,0): Q = (3, 0).
        assert p["x"] == pytest.approx(3.0) and p["y"] == pytest.approx(0.3)
        assert p["projection_distance"] == pytest.approx(3.0)
        assert p["distance_from_center"] == pytest.approx(0.3)
        # Borders nearest to Q: (3, 1) and (3, -1) -> width 2; P is 0.7 from the left one.
        assert p["track_width"] == pytest.approx(2.0)
        assert p["is_left_of_center"] is True
        assert p["heading"] == 0.0
        # Wheels at x = 2.86 +- 0.082, y = 0.3 +- 0.08: between the borders.
        assert p["all_wheels_on_track"] is True
        # ndist = 3 / 40 = 0.075; bisect_right([0, .125, .125, ...], 0.075) = 1 -> [0, 1].
        assert p["closest_waypoints"] == [0, 1]
        # progress = 100 * (0.075 - 0) = 7.5 %.
        assert p["progress"] == pytest.approx(7.5)
        assert p["track_length"] == pytest.approx(40.0)

    def test_action_time_and_flags(self) -> None:
        p = self.p0
        assert (p["speed"], p["steering_angle"]) == (1.5, -10.0)
        assert p["steps"] == 1.0 and isinstance(p["steps"], float)
        assert p["sim_time"] == 0.4
        assert p["is_reversed"] is False
        assert (p["is_crashed"], p["is_offtrack"]) == (True, False)
        assert (self.p1["is_crashed"], self.p1["is_offtrack"]) == (False, True)

    def test_waypoints_are_closed_tuples_with_duplicates(self) -> None:
        wp = self.p0["waypoints"]
        assert wp == [(0.0, 0.0), (5.0, 0.0), (5.0, 0.0), (10.0, 0.0), (10.0, 10.0),
                      (0.0, 10.0), (0.0, 0.0)]
        assert all(type(w) is tuple for w in wp)

    def test_objects_of_car_0(self) -> None:
        p = self.p0
        # Obstacles first, then the other cars: [box, car 1].
        assert p["objects_location"] == [[7.0, -0.5], [10.3, 5.0]]
        # Arc positions from the start line: box 7 m; car 1 projects to (10, 5): 10 + 5 = 15.
        assert p["objects_distance"] == pytest.approx([7.0, 15.0])
        assert p["objects_distance_from_center"] == pytest.approx([0.5, 0.3])
        # Both lie right of travel (outside the band between the centre and the inner border).
        assert p["objects_left_of_center"] == [False, False]
        assert p["objects_speed"] == [0.0, 1.2]
        assert p["objects_heading"] == pytest.approx([0.0, math.pi / 2])
        # Sorted arcs [7 (box), 15 (car 1)]; bisect_right(., 3) = 0 -> ahead = box, behind
        # wraps to the last = car 1.
        assert p["closest_objects"] == [1, 0]
        # The box from the camera (3.005, 0.3): 4 m ahead, 0.8 m right -> 11.3 deg < 32.35 deg.
        assert p["object_in_camera"] is True

    def test_car_1(self) -> None:
        p = self.p1
        # P = (10.3, 5.14); Q = (10, 5.14), arc 15.14; left border point (9, 5.14) is 1.3 m
        # away, right (11, 5.14) 0.7 m -> right of centre.
        assert p["heading"] == 90.0
        assert p["projection_distance"] == pytest.approx(15.14)
        assert p["is_left_of_center"] is False
        # ndist = 15.14 / 40 = 0.3785 in (.25, .5] -> [3, 4].
        assert p["closest_waypoints"] == [3, 4]
        # Objects [box (arc 7), car 0 (arc 2.86)]: sorted [car 0, box]; bisect_right(15.14) = 2
        # -> ahead wraps to car 0 (index 1), behind = box (index 0); car 0 is behind the camera.
        assert p["objects_distance"] == pytest.approx([7.0, 2.86])
        assert p["closest_objects"] == [0, 1]
        assert p["object_in_camera"] is False


class TestBotObjects:
    """Bot cars as objects: DeepRacer's insertion order and BOT_CAR_SPEED quirk, by hand."""

    def setup_method(self) -> None:
        # The scene of TestHandComputed plus two bots: bot 0 at (10.5, 8) heading +y on the
        # right side, bot 1 at (1, 9.7) heading -x (pi) on the top side, at 0.75 m/s.
        self.p0, self.p1 = build(
            ParamsBuilder(square_track(), CAR, 2), [(2.86, 0.3), (10.3, 5.0)],
            [0.0, math.pi / 2], speed=np.array([0.0, 1.2]),
            obstacle_position=np.array([[7.0, -0.5]]), obstacle_yaw=np.array([0.0]),
            bot_position=np.array([[10.5, 8.0], [1.0, 9.7]]),
            bot_yaw=np.array([math.pi / 2, math.pi]), bot_speed=0.75)

    def test_objects_of_car_0(self) -> None:
        p = self.p0
        # Obstacles, then bots, then the other cars: [box, bot 0, bot 1, car 1].
        assert p["objects_location"] == [[7.0, -0.5], [10.5, 8.0], [1.0, 9.7], [10.3, 5.0]]
        # Arcs: box 7; bot 0 projects to (10, 8): 10 + 8 = 18; bot 1 to (1, 10):
        # 10 + 10 + (10 - 1) = 29; car 1 to (10, 5): 15.
        assert p["objects_distance"] == pytest.approx([7.0, 18.0, 29.0, 15.0])
        assert p["objects_distance_from_center"] == pytest.approx([0.5, 0.5, 0.3, 0.3])
        # Only bot 1 (y = 9.7, inside the square) lies between the centre and the inner border.
        assert p["objects_left_of_center"] == [False, False, True, False]
        # With bots, every object reports BOT_CAR_SPEED, the car's 1.2 m/s included.
        assert p["objects_speed"] == [0.75, 0.75, 0.75, 0.75]
        # Radians in (-pi, pi]: pi stays pi.
        assert p["objects_heading"] == pytest.approx([0.0, math.pi / 2, math.pi, math.pi / 2])
        # Sorted arcs: box 7 (0), car 1 15 (3), bot 0 18 (1), bot 1 29 (2); bisect_right(3.0)
        # = 0 -> ahead = box (0), behind wraps to the last = bot 1 (2).
        assert p["closest_objects"] == [2, 0]

    def test_objects_of_car_1(self) -> None:
        p = self.p1
        # [box, bot 0, bot 1, car 0]; arcs [7, 18, 29, 2.86]: sorted car 0 (3), box (0),
        # bot 0 (1), bot 1 (2); bisect_right(15.14) = 2 -> ahead = bot 0 (1), behind = box (0).
        assert p["objects_location"][3] == [2.86, 0.3]
        assert p["closest_objects"] == [0, 1]
        # Bot 0 from the camera at (10.3, 5.145) heading +y: 2.86 m ahead, 0.2 m right.
        assert p["object_in_camera"] is True

    def test_no_bots_keeps_measured_speeds(self) -> None:
        p0, _ = build(ParamsBuilder(square_track(), CAR, 2), [(2.86, 0.3), (10.3, 5.0)],
                      [0.0, math.pi / 2], speed=np.array([0.0, 1.2]),
                      obstacle_position=np.array([[7.0, -0.5]]), obstacle_yaw=np.array([0.0]),
                      bot_position=np.zeros((0, 2)), bot_yaw=np.zeros(0), bot_speed=0.75)
        assert p0["objects_speed"] == [0.0, 1.2]


class TestProgressAndIndices:
    """Progress wrap rules, the closing-duplicate index, headings, wheels, empty objects."""

    def setup_method(self) -> None:
        self.builder = ParamsBuilder(square_track(), CAR, 1)

    def at_arc(self, arc: float, **kw):
        # A car on the bottom or left edge whose model point P sits at arc ``arc``.
        if arc < 10:
            pos, yaw = (arc - 0.14, 0.0), 0.0
        else:
            pos, yaw = (0.0, 40.0 - arc + 0.14), -math.pi / 2
        return build(self.builder, [pos], [yaw], **kw)[0]

    def test_progress_relative_to_start_with_wrap(self) -> None:
        # Start at 38 m (ndist .95), P at 1 m (.025): 100 (.025 - .95) = -92.5 -> +100 = 7.5.
        assert self.at_arc(1.0, start=(38.0,))["progress"] == pytest.approx(7.5)

    def test_progress_slightly_negative_behind_start(self) -> None:
        # P at 39.8 m (.995): 99.5 > prev (0) + 50 -> 99.5 - 100 = -0.5.
        assert self.at_arc(39.8)["progress"] == pytest.approx(-0.5)

    def test_progress_capped_at_100_after_the_line(self) -> None:
        self.at_arc(39.6, steps=1.0)  # -1.0 (behind the start)
        p = self.at_arc(39.8, steps=2.0)
        assert p["progress"] == pytest.approx(-0.5)
        self.builder._prev_progress = [99.0]
        # 1.0 with prev 99 > 1 + 50 -> 101 -> capped at 100.
        assert self.at_arc(0.4, steps=3.0)["progress"] == 100.0

    def test_new_episode_resets_progress_state(self) -> None:
        self.builder._prev_progress = [99.0]
        # steps did not increase (-inf -> 1, then 1 again): a new episode, prev = 0 -> 1.0.
        self.at_arc(0.4, steps=1.0)
        assert self.at_arc(0.4, steps=1.0)["progress"] == pytest.approx(1.0)

    def test_closest_waypoint_can_be_the_closing_duplicate(self) -> None:
        # P at 39.9 m: ndist .9975; bisect_right(..., .9975) = 6 -> [5, 6] (row 6 == row 0).
        p = self.at_arc(39.9)
        assert p["closest_waypoints"] == [5, 6]
        assert p["heading"] == -90.0

    def test_heading_is_in_minus_180_exclusive_to_180(self) -> None:
        for yaw in (math.pi, -math.pi, 3 * math.pi):
            p = build(self.builder, [(3.0, 0.0)], [yaw])[0]
            assert p["heading"] == pytest.approx(180.0) and p["heading"] > 0

    def test_wheel_over_the_border(self) -> None:
        # y = 0.95: left wheels at y = 1.03 are inside the inner square (off the road).
        p = build(self.builder, [(3.0, 0.95)], [0.0])[0]
        assert p["all_wheels_on_track"] is False

    def test_no_objects(self) -> None:
        p = build(self.builder, [(3.0, 0.0)], [0.0])[0]
        for key in ("objects_location", "objects_distance", "objects_left_of_center",
                    "objects_speed", "objects_heading", "objects_distance_from_center"):
            assert p[key] == []
        assert p["closest_objects"] == [0, 0] and p["object_in_camera"] is False

    def test_copy_params_is_a_deep_copy(self) -> None:
        p = build(self.builder, [(3.0, 0.0)], [0.0],
                  obstacle_position=np.array([[7.0, 0.5]]), obstacle_yaw=np.zeros(1))[0]
        q = copy_params(p)
        assert q == copy.deepcopy(p)
        for key, value in p.items():
            if isinstance(value, list):
                assert q[key] is not value
                assert all(a is not b for a, b in zip(q[key], value) if isinstance(a, list))


def route_files() -> list[Path]:
    return sorted(ROUTES.glob("*.npy")) if ROUTES.is_dir() else []


@pytest.mark.skipif(not route_files(), reason=f"no DeepRacer route files in {ROUTES.resolve()}: "
                    "copy bundle/routes/*.npy of aws-deepracer-community/deepracer-simapp "
                    "there; see README.md, Tests")
class TestRealRoutes:
    """Params on the real route files (shared/data/deepracer_tracks)."""

    @pytest.mark.parametrize("path", route_files(), ids=lambda p: p.stem)
    def test_params_on_route(self, path: Path) -> None:
        rows = np.load(path)
        for reverse in (False, True):
            track = load_track(path)
            track = track.reversed() if reverse else track
            builder = ParamsBuilder(track, CAR, 1, is_reversed=reverse)
            s = 0.3 * track.length
            xy = track.point_at(s)
            yaw = float(track.heading_at(s))
            back = xy - 0.14 * np.array([math.cos(yaw), math.sin(yaw)])
            p = builder.build(position=back.reshape(1, 2), yaw=np.array([yaw]),
                              speed_command=np.ones(1), steering_deg=np.zeros(1),
                              start_distance=np.array([s - 0.14]), steps=1.0, sim_time=0.0)[0]
            assert set(p) == set(PARAM_KEYS)
            # Every row is a waypoint, in driving order, closing row included.
            expected = rows[::-1, :2] if reverse else rows[:, :2]
            assert p["waypoints"] == [tuple(r) for r in expected.tolist()]
            assert p["track_length"] == pytest.approx(track.length, rel=1e-9)
            # On the centre line, 0.14 m after the start: progress = 0.14 / L * 100.
            assert p["distance_from_center"] == pytest.approx(0.0, abs=1e-6)
            assert p["progress"] == pytest.approx(14.0 / track.length, abs=1e-6)
            assert p["projection_distance"] == pytest.approx(s, abs=1e-6)
            prv, nxt = p["closest_waypoints"]
            arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(expected, axis=0).T))])
            assert arc[prv] <= s + 1e-9 <= arc[nxt] + 1e-9
            # Local width (nearest border points): within the file's range of widths.
            assert 0.9 * track.width.min() <= p["track_width"] <= 1.05 * track.width.max()
            assert p["all_wheels_on_track"] and p["is_reversed"] is reverse
            if path.stem == "reinvent_base":
                assert p["track_length"] == pytest.approx(17.709, abs=1e-3)


def test_obstacle_projections_follow_moved_obstacles() -> None:
    # The builder reuses obstacle projections while the obstacles stand still; moving one
    # must give the same params as a fresh builder. Box from (7, -0.5) to (3, 0.5): its
    # arc position along the square's first side goes from 7 m to 3 m.
    track = square_track()
    warm = ParamsBuilder(track, CAR, 1)
    kw = {"obstacle_yaw": np.array([0.0])}
    build(warm, [(1.0, 0.0)], [0.0], obstacle_position=np.array([[7.0, -0.5]]), **kw)
    moved = build(warm, [(1.0, 0.0)], [0.0], steps=2.0,
                  obstacle_position=np.array([[3.0, 0.5]]), **kw)[0]
    fresh = build(ParamsBuilder(track, CAR, 1), [(1.0, 0.0)], [0.0], steps=2.0,
                  obstacle_position=np.array([[3.0, 0.5]]), **kw)[0]
    assert moved["objects_distance"] == pytest.approx([3.0])
    assert moved["objects_distance"] == fresh["objects_distance"]
    assert moved["objects_left_of_center"] == fresh["objects_left_of_center"] == [True]
