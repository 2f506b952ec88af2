"""DeepRacer's reward-function ``params`` dict, built from the simulation arrays.

The semantics follow the DeepRacer simulator's code (simapp ``bundle/markov``), not the AWS
docs where the two differ:

- geometry is measured from the "model point" P, 0.14 m ahead of the car's origin
  (``agent_ctrl/constants.py RELATIVE_POSITION_OF_FRONT_OF_CAR``);
- the centre line C is the polyline through ``track.waypoints`` in driving order (every row,
  duplicates, near-duplicates, tiny backtracks and the closing row included, even where the
  track's geometry leaves such slips out: ``h2h_racing.track.io.route_geometry_rows``; so
  ``closest_waypoints`` are the route file's row indices), projected on as Shapely's ``project`` /
  ``interpolate`` do (the nearest point of the polyline; on ties the earlier segment wins);
- ``progress`` is relative to where the episode started, with the +-50 wrap rule and a cap at
  100 (``agent_ctrl/rollout_agent_ctrl.py``), keeping each car's previous progress;
- ``closest_waypoints`` brackets P by arc length (``track_geom/track_data.py``,
  ``bisect_right`` over the waypoints' normalised arc positions, the closing one being 1.0);
- ``speed`` and ``steering_angle`` are the commanded action; ``heading`` is in degrees,
  ``objects_heading`` in radians; ``steps`` is a float counted from 1;
- the objects are, in DeepRacer's insertion order, the obstacles, the bot cars
  (``bot_car_i``) and the other cars; with bot cars every object's ``objects_speed`` is the
  bots' speed (``BOT_CAR_SPEED``, DeepRacer's quirk), without them the other cars report
  their measured speed and obstacles 0.0.

Every call returns all 27 keys (``PARAM_KEYS``); without objects the lists are empty and
``closest_objects`` is ``[0, 0]``. The compiled polyline kernels that measure the geometry
live in :mod:`h2h_racing.deepracer.params_geometry`.
"""

from __future__ import annotations

import bisect
import copy
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from h2h_racing.config.env import CarParams
from h2h_racing.deepracer.params_geometry import (
    _car_kernel,
    _in_camera,
    _object_kernel,
    _Polyline,
    _project_points,
)
from h2h_racing.track.shape import Track

if TYPE_CHECKING:
    from h2h_racing.sim.core import RaceCore

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

PARAM_KEYS: tuple[str, ...] = (
    "all_wheels_on_track", "x", "y", "heading", "distance_from_center", "is_left_of_center",
    "progress", "steps", "speed", "steering_angle", "track_width", "track_length",
    "waypoints", "closest_waypoints", "is_reversed", "is_offtrack", "is_crashed",
    "closest_objects", "objects_location", "objects_distance", "objects_left_of_center",
    "objects_speed", "objects_heading", "projection_distance", "objects_distance_from_center",
    "object_in_camera", "sim_time",
)
"""The 27 keys of every params dict (23 documented by AWS + 4 undocumented)."""

FRONT_OF_CAR = 0.14
"""Distance of the model point ahead of the car's origin [m] (simapp
``RELATIVE_POSITION_OF_FRONT_OF_CAR = [0.14, 0, 0]``)."""
CAMERA_HFOV_DEG = 64.7
"""Horizontal field of view of DeepRacer's simulated camera [deg] (URDF, 1.13 rad)."""
CAMERA_RANGE = 5.0
"""Farthest distance at which ``object_in_camera`` sees an object [m] (our choice; Gazebo's
far clip is 300 m, which would make every object ahead visible)."""


def _closed(points: Any) -> FloatArray:
    """Return the rows with the first repeated at the end (unless it already is)."""
    p = np.asarray(points, dtype=np.float64)
    return p if np.array_equal(p[0], p[-1]) else np.vstack([p, p[:1]])


class ParamsBuilder:
    """Build DeepRacer ``params`` dicts for the cars of one race.

    Keeps the per-car state DeepRacer keeps between steps (the previous progress). A new
    episode is detected when ``steps`` does not increase (or after ``reset``).

    Args:
        track: The track in driving order; its ``waypoints`` define the centre line C.
        car: Car geometry (wheel centres for ``all_wheels_on_track``).
        num_cars: Number of cars N.
        obstacle_size: Obstacle box (length along its heading, width) [m], for the camera test.
        is_reversed: Whether this race drives the track against the route file's row order
            (DeepRacer's per-episode direction flag; the caller knows, the track does not).
        camera_hfov_deg: Camera field of view for ``object_in_camera`` [deg].
        camera_forward_m: Camera position ahead of the car's origin [m].
        camera_range_m: Farthest visible distance for ``object_in_camera`` [m].
    """

    def __init__(self, track: Track, car: CarParams, num_cars: int, *,
                 obstacle_size: tuple[float, float] = (0.5, 0.4), is_reversed: bool = False,
                 camera_hfov_deg: float = CAMERA_HFOV_DEG, camera_forward_m: float = 0.145,
                 camera_range_m: float = CAMERA_RANGE) -> None:
        self.track = track
        self.num_cars = num_cars
        self.is_reversed = bool(is_reversed)
        wp = _closed(track.waypoints)
        self._centre = _Polyline(wp)
        self._left = _Polyline(_closed(track.left_border))
        self._right = _Polyline(_closed(track.right_border))
        # Rings for containment (even-odd rule; the closing edge is implied).
        inner = self._left if track.is_ccw else self._right
        self._ring_inner = inner.table
        self._not_ccw = not track.is_ccw
        self.waypoints: tuple[tuple[float, float], ...] = tuple(
            (float(x), float(y)) for x, y in wp.tolist())
        """C's vertices as (x, y) tuples, closing point included (``params["waypoints"]``)."""
        # Normalised arc position of every waypoint; the closing one is 1.0 by definition
        # (track_data.py: [C.project(wp, normalized=True) for wp in coords[:-1]] + [1.0]).
        proj = np.empty(len(wp) - 1)
        _project_points(wp[:-1], self._centre.table, proj)
        self._wp_ndist = (proj / self._centre.length).tolist() + [1.0]
        self._wheels = np.array([[car.cg_to_front, 0.5 * car.wheel_track],
                                 [car.cg_to_front, -0.5 * car.wheel_track],
                                 [-car.cg_to_rear, 0.5 * car.wheel_track],
                                 [-car.cg_to_rear, -0.5 * car.wheel_track]])
        self._car_half = (0.5 * car.length, 0.5 * car.width)
        self._obstacle_half = (0.5 * obstacle_size[0], 0.5 * obstacle_size[1])
        self._half_fov = math.radians(0.5 * camera_hfov_deg)
        self._camera_forward = camera_forward_m
        self._camera_range = camera_range_m
        self._prev_progress = [0.0] * num_cars
        self._last_steps = -math.inf
        self._obstacle_cache: tuple[FloatArray, FloatArray, FloatArray, BoolArray] | None = None

    @property
    def track_length(self) -> float:
        """Length of C [m], closing segment included (``params["track_length"]``)."""
        return self._centre.length

    @property
    def waypoint_ndist(self) -> FloatArray:
        """Normalised arc position of every waypoint along C, closing one (1.0) included."""
        return np.asarray(self._wp_ndist)

    def geometry(self, position: FloatArray, yaw: FloatArray,
                 ) -> tuple[FloatArray, FloatArray, BoolArray]:
        """Model point, its arc position on C and all-wheels-on-track for many cars at once.

        Args:
            position: Car origins, shape (M, 2) [m].
            yaw: Car headings, shape (M,) [rad].

        Returns:
            ``(model_point (M, 2) [m], arc (M,) [m along C], all_wheels_on_track (M,))``, as
            ``build`` computes them for ``x``/``y``, ``projection_distance`` and
            ``all_wheels_on_track``.
        """
        position = np.ascontiguousarray(position, dtype=np.float64).reshape(-1, 2)
        yaw = np.ascontiguousarray(yaw, dtype=np.float64).reshape(-1)
        m = len(position)
        model_point = np.empty((m, 2))
        proj = np.empty(m)
        scratch = np.empty(m)
        is_left = np.empty(m, dtype=np.bool_)
        wheels_on = np.empty(m, dtype=np.bool_)
        _car_kernel(position, yaw, FRONT_OF_CAR, self._wheels, self._centre.table,
                    self._left.table, self._right.table, model_point, proj, scratch,
                    np.empty(m), is_left, wheels_on)
        return model_point, proj, wheels_on

    def reset(self) -> None:
        """Forget the previous progress of every car (call at the start of an episode)."""
        self._prev_progress = [0.0] * self.num_cars
        self._last_steps = -math.inf

    def build(self, *, position: FloatArray, yaw: FloatArray, speed_command: FloatArray,
              steering_deg: FloatArray, start_distance: FloatArray, steps: float,
              sim_time: float, speed: FloatArray | None = None,
              off_track: BoolArray | None = None, crashed: BoolArray | None = None,
              obstacle_position: FloatArray | None = None,
              obstacle_yaw: FloatArray | None = None,
              bot_position: FloatArray | None = None, bot_yaw: FloatArray | None = None,
              bot_speed: float = 0.0,
              cars: Sequence[int] | None = None) -> list[dict[str, Any] | None]:
        """Return one params dict per car (None for cars not in ``cars``).

        Args:
            position: Car origins, shape (N, 2) [m].
            yaw: Car headings, shape (N,) [rad].
            speed_command: Commanded speeds, shape (N,) [m/s] (``params["speed"]``).
            steering_deg: Commanded steering angles, shape (N,) [deg, left positive].
            start_distance: Arc position where each car's episode started, shape (N,) [m]
                (along the track's centre; taken modulo its length).
            steps: Steps of the episode so far, counted from 1.
            sim_time: Simulated time [s].
            speed: Measured forward speeds, shape (N,) [m/s] (``objects_speed`` of cars);
                None reports 0.0 as DeepRacer does for model opponents.
            off_track: Whether the off-track rule fired for each car this step, shape (N,).
            crashed: Whether each car was judged the crashing car (the car behind, or
                hitting an obstacle) this step, shape (N,).
            obstacle_position: Obstacle centres, shape (K, 2) [m].
            obstacle_yaw: Obstacle headings, shape (K,) [rad].
            bot_position: Bot car centres, shape (B, 2) [m]; they follow the obstacles in
                the objects.
            bot_yaw: Bot car headings, shape (B,) [rad].
            bot_speed: The bots' speed [m/s]; with B > 0 it is every object's
                ``objects_speed`` (DeepRacer reports ``BOT_CAR_SPEED`` for all objects).
            cars: Which cars to build params for; None for all. Only these cars' progress
                state advances.

        Returns:
            A list of length N of fresh dicts (nothing in them is shared with the builder
            or with another dict, apart from immutable tuples).
        """
        n = self.num_cars
        position = np.ascontiguousarray(position, dtype=np.float64).reshape(n, 2)
        yaw = np.asarray(yaw, dtype=np.float64).reshape(n)
        obstacle_position, obstacle_yaw = _poses(obstacle_position, obstacle_yaw)
        k = len(obstacle_position)
        bot_position, bot_yaw = _poses(bot_position, bot_yaw)
        b = len(bot_position)
        if steps <= self._last_steps:
            self.reset()
        self._last_steps = steps
        # Objects in DeepRacer's insertion order: obstacles, bot cars, cars.
        movers = np.concatenate((bot_position, position)) if b else position
        objects = np.concatenate((obstacle_position, movers))
        m = len(objects)
        model_point = np.empty((n, 2))
        proj = np.empty(n)
        dist = np.empty(n)
        width = np.empty(n)
        is_left = np.empty(n, dtype=np.bool_)
        wheels_on = np.empty(n, dtype=np.bool_)
        obj_proj = np.empty(m)
        obj_dist = np.empty(m)
        obj_band = np.empty(m, dtype=np.bool_)
        _car_kernel(position, yaw, FRONT_OF_CAR, self._wheels, self._centre.table,
                    self._left.table, self._right.table, model_point, proj, dist, width,
                    is_left, wheels_on)
        # Obstacles stand still within an episode: their projections (a full scan of the
        # centre line and two ring tests each) are reused while their positions are equal.
        cached = self._obstacle_cache
        if cached is None or not np.array_equal(cached[0], obstacle_position):
            o_proj, o_dist = np.empty(k), np.empty(k)
            o_band = np.empty(k, dtype=np.bool_)
            _object_kernel(obstacle_position, self._centre.table, self._ring_inner, o_proj,
                           o_dist, o_band)
            cached = self._obstacle_cache = (obstacle_position.copy(), o_proj, o_dist, o_band)
        obj_proj[:k], obj_dist[:k], obj_band[:k] = cached[1], cached[2], cached[3]
        _object_kernel(movers, self._centre.table, self._ring_inner, obj_proj[k:],
                       obj_dist[k:], obj_band[k:])
        length = self._centre.length
        # Scalars from here on: with a handful of cars, Python floats beat small numpy ops.
        start = [(v / self.track.length) % 1.0 for v in np.ravel(start_distance).tolist()]
        yaw_l = yaw.tolist()
        obj_yaw = obstacle_yaw.tolist() + bot_yaw.tolist() + yaw_l
        # objects_heading: the yaw in radians in (-pi, pi].
        obj_heading_l = [math.atan2(math.sin(a), math.cos(a)) for a in obj_yaw]
        obj_heading_l = [a + 2.0 * math.pi if a <= -math.pi else a for a in obj_heading_l]
        if b:
            obj_speed = [float(bot_speed)] * m
        else:
            obj_speed = [0.0] * k + (np.ravel(speed).tolist() if speed is not None
                                     else [0.0] * n)
        # objects_left_of_center (track_data.py): inner_poly.contains(obj) XOR (not is_ccw),
        # inner_poly = Polygon(C, [inner_border]).
        obj_left = [b != self._not_ccw for b in obj_band.tolist()]
        obj_loc = objects.tolist()
        obj_proj_l, obj_dist_l = obj_proj.tolist(), obj_dist.tolist()
        off = [False] * n if off_track is None else [bool(v) for v in np.ravel(off_track)]
        crash = [False] * n if crashed is None else [bool(v) for v in np.ravel(crashed)]
        mp = model_point.tolist()
        rows = zip(proj.tolist(), dist.tolist(), width.tolist(), is_left.tolist(),
                   wheels_on.tolist(), np.ravel(speed_command).tolist(),
                   np.ravel(steering_deg).tolist(), off, crash)
        wanted = set(range(n)) if cars is None else set(cars)
        steps_f = float(steps)
        time_f = float(sim_time)
        wp_ndist = self._wp_ndist
        last_wp = len(wp_ndist) - 1
        out: list[dict[str, Any] | None] = []
        prev_progress = self._prev_progress
        for i, (p, dc, w, left, on, sp, st, of, cr) in enumerate(rows):
            if i not in wanted:
                out.append(None)
                continue
            nd = p / length
            # Progress (rollout_agent_ctrl.py): relative to the episode's start point, +100
            # when <= 0, wrapped by the +-50 rule against the previous step, capped at 100.
            pg = 100.0 * (nd - start[i])
            if pg <= 0.0:
                pg += 100.0
            prev = prev_progress[i]
            if prev > pg + 50.0:
                pg += 100.0
            if pg > prev + 50.0:
                pg -= 100.0
            pg = min(pg, 100.0)
            prev_progress[i] = pg
            # heading: the yaw in degrees in (-180, 180].
            hd = math.degrees(math.atan2(math.sin(yaw_l[i]), math.cos(yaw_l[i])))
            if hd <= -180.0:
                hd += 360.0
            nxt = bisect.bisect_right(wp_ndist, nd)
            prv = nxt - 1 if nxt > 0 else last_wp
            nxt = 0 if nxt > last_wp else nxt
            # Objects: obstacles first, then the bots, then the other cars, each in
            # insertion order.
            kb = k + b
            order = list(range(kb)) + [kb + j for j in range(n) if j != i]
            if order:
                o_proj = [obj_proj_l[j] for j in order]
                closest = _closest_objects(o_proj, p)
                ahead = order[closest[1]]
                half = self._obstacle_half if ahead < k else self._car_half
                in_camera = bool(_in_camera(
                    mp[i][0], mp[i][1], yaw_l[i], self._camera_forward - FRONT_OF_CAR,
                    self._half_fov, self._camera_range, obj_loc[ahead][0], obj_loc[ahead][1],
                    obj_heading_l[ahead], half[0], half[1]))
            else:
                o_proj, closest, in_camera = [], [0, 0], False
            out.append({
                "all_wheels_on_track": on, "x": mp[i][0], "y": mp[i][1], "heading": hd,
                "distance_from_center": dc, "is_left_of_center": left, "progress": pg,
                "steps": steps_f, "speed": sp, "steering_angle": st, "track_width": w,
                "track_length": length, "waypoints": list(self.waypoints),
                "closest_waypoints": [prv, nxt], "is_reversed": self.is_reversed,
                "is_offtrack": of, "is_crashed": cr, "closest_objects": closest,
                "objects_location": [list(obj_loc[j]) for j in order],
                "objects_distance": o_proj,
                "objects_left_of_center": [obj_left[j] for j in order],
                "objects_speed": [obj_speed[j] for j in order],
                "objects_heading": [obj_heading_l[j] for j in order],
                "projection_distance": p,
                "objects_distance_from_center": [obj_dist_l[j] for j in order],
                "object_in_camera": in_camera, "sim_time": time_f,
            })
        return out

    def from_core(self, core: RaceCore, *, steering_deg: FloatArray | None = None,
                  events: Any = None, cars: Sequence[int] | None = None,
                  env_index: int = 0) -> list[dict[str, Any] | None]:
        """Return params for the cars of one env copy of a ``RaceCore``.

        Args:
            core: The core, after its step.
            steering_deg: Commanded steering angles, shape (N,) [deg]; None converts the
                core's ``steer_command`` (radians).
            events: The step's ``StepEvents`` (for ``is_offtrack`` and ``is_crashed``);
                None reports False for both.
            cars: Which cars to build; None for all.
            env_index: The env copy.

        Returns:
            As ``build``.
        """
        e = env_index
        if steering_deg is None:
            steering_deg = np.degrees(core.steer_command[e])
        position, yaw = core.position[e], core.yaw[e]
        if events is not None:
            # A car whose episode ended this step has already been parked off the track;
            # its last params describe where it was when it ended.
            ended = events.terminated[e] | events.truncated[e]
            if ended.any():
                position = np.where(ended[:, None], core.final_position[e], position)
                yaw = np.where(ended, core.final_yaw[e], yaw)
        return self.build(
            position=position, yaw=yaw, speed_command=core.speed_command[e],
            steering_deg=steering_deg, start_distance=core.start_distance[e],
            steps=float(core.steps[e]), sim_time=float(core.time[e]), speed=core.speed[e],
            off_track=None if events is None else events.off_track[e],
            crashed=None if events is None else events.crashed[e],
            obstacle_position=core.obstacle_position[e], obstacle_yaw=core.obstacle_yaw[e],
            bot_position=core.bot_position[e], bot_yaw=core.bot_yaw[e],
            bot_speed=core.config.bot_speed, cars=cars)


def copy_params(params: dict[str, Any]) -> dict[str, Any]:
    """Return a deep copy of a params dict, fast.

    Equal to ``copy.deepcopy(params)`` for the dicts ``ParamsBuilder`` makes: every list is
    new, while numbers, bools, strings and the waypoints' (x, y) tuples of floats are shared
    (``deepcopy`` returns those immutable objects as they are, too). Values of other types
    go through ``copy.deepcopy``.
    """
    out = dict(params)
    for key, value in params.items():
        kind = type(value)
        if kind in _ATOMIC:
            continue
        if kind is list:
            if key == "waypoints":
                out[key] = list(value)  # tuples of floats: immutable, shared as deepcopy does
            else:
                out[key] = [v if type(v) in _ATOMIC else
                            (list(v) if type(v) is list and all(type(x) in _ATOMIC for x in v)
                             else copy.deepcopy(v)) for v in value]
        else:
            out[key] = copy.deepcopy(value)
    return out


_ATOMIC = frozenset((bool, int, float, str, type(None)))


def _closest_objects(proj: list[float], model_proj: float) -> list[int]:
    """``[behind, ahead]`` indices by arc position, cyclic (track_data.py find_prev_next)."""
    order = sorted(range(len(proj)), key=proj.__getitem__)
    sorted_proj = [proj[j] for j in order]
    nxt = bisect.bisect_right(sorted_proj, model_proj)
    prv = nxt - 1 if nxt > 0 else len(order) - 1
    nxt = 0 if nxt == len(order) else nxt
    return [order[prv], order[nxt]]


def _poses(position: Any, yaw: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(position (K, 2), yaw (K,))`` as float64 arrays; None means no objects (K = 0)."""
    if position is None:
        return np.zeros((0, 2)), np.zeros(0)
    return (np.asarray(position, dtype=np.float64).reshape(-1, 2),
            np.asarray(yaw, dtype=np.float64).reshape(-1))
