"""Scripted drivers: privileged, batched baselines and opponents.

A driver controls one car index in every env copy of a :class:`~h2h_racing.sim.core.RaceCore`
at once and reads the true state (like DeepRacer's bot cars). It returns actions in the
env's continuous action space, ``[steer, speed]`` in ``[-1, 1]``, one row per env copy.

| name | driver | behaviour |
|---|---|---|
| ``pure_pursuit`` | :class:`PurePursuit` | centre line, modest speed capped by the curvature ahead |
| ``racing_line`` | :class:`RacingLine` | minimum-curvature line and its speed profile |
| ``blocker`` | :class:`Blocker` | inner lane; moves across to cover an attacker close behind |
| ``random`` | :class:`Random` | uniform random actions (fuzzing; it does not finish laps) |
| ``planner`` | :class:`~h2h_racing.policies.planner.Planner` | plans passes, defends a corner |

The drivers steer by pure pursuit (:mod:`h2h_racing.policies.steering`).

Each driver class declares the settings a driver spec may give it (``SETTINGS``, e.g.
``racing_line:grip_factor=0.7``; see :mod:`h2h_racing.policies.registry`, which builds
drivers by spec with ``make_driver``).

Run ``python -m h2h_racing.policies`` for the lap-time table of every driver on
every catalogue track (:mod:`h2h_racing.policies.lap_times`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.policies.obstacles import avoid_obstacles
from h2h_racing.policies.planner import Planner
from h2h_racing.policies.racing_line import GRAVITY, RaceLine, compute_race_line
from h2h_racing.policies.registry import Setting, make_driver  # make_driver: re-exported
from h2h_racing.policies.steering import (  # re-exported: the drivers' shared helpers
    lookahead,
    pursuit_steer,
    to_action,
)
from h2h_racing.track.lookup import wrap_arcs
from h2h_racing.track.shape import Track

FloatArray = npt.NDArray[np.float64]
ActionArray = npt.NDArray[np.float32]
REJOIN = 1.2
"""Distance behind ``racing_line`` within which a car it has just passed keeps its return to
the line gradual [m]."""
REJOIN_STEP = 0.2
"""Largest lateral distance from the car to its target while it rejoins the line [m]."""


@runtime_checkable
class Driver(Protocol):
    """A batched scripted driver for one car index of a :class:`RaceCore`."""

    name: str
    """Registry name of the driver."""

    def reset(self, core: RaceCore) -> None:
        """Prepare for a new episode; called after ``core.reset`` (precompute per track)."""

    def act(self, core: RaceCore, car: int) -> ActionArray:
        """Return the actions of car ``car`` in every env copy, shape (E, 2), float32,
        ``[steer, speed]`` in [-1, 1]."""


# ---------------------------------------------------------------------- helpers


def _offset_curvature(kappa: FloatArray, d: FloatArray | float) -> FloatArray:
    """Curvature of a path at constant offset ``d`` from a centre line of curvature ``kappa``.

    A parallel curve has radius ``1/kappa - d`` (left offsets shrink left turns):
    ``kappa / (1 - kappa d)``; the denominator is floored for safety.
    """
    return kappa / np.maximum(1.0 - kappa * d, 0.2)


def _curvature_speed(core: RaceCore, s: FloatArray, d: FloatArray | float, horizon: float,
                     a_lat: float) -> FloatArray:
    """Highest speed [m/s] at which the largest curvature over ``[s, s + horizon]`` of the
    path at offset ``d`` stays within the lateral acceleration ``a_lat``, shape (E,)."""
    samples = s[:, None] + np.linspace(0.0, horizon, max(2, math.ceil(horizon / 0.1) + 1))
    d_arr = np.asarray(d, dtype=np.float64)
    d_col = d_arr[:, None] if d_arr.ndim else d_arr
    kappa = np.abs(_offset_curvature(core.track.curvature_at(samples), d_col)).max(axis=1)
    return np.sqrt(a_lat / np.maximum(kappa, 1e-6))


# ---------------------------------------------------------------------- drivers


class PurePursuit:
    """Follow the centre line at a modest speed, capped by the curvature ahead.

    Args:
        cruise_speed: Speed on straights [m/s].
        lateral_accel: Lateral acceleration budget in corners, as a fraction of ``mu g``.
        preview: Distance ahead over which the largest curvature caps the speed [m].
        lookahead_base: Look-ahead distance at standstill [m].
        lookahead_gain: Extra look-ahead per m/s of speed [s].
        offset: Lateral offset of the followed line from the centre line [m], left positive.
        box_clearance: Gap kept between the car's side and a box's side [m]. Its longer
            look-ahead cuts nearer a box on a bend than the racing line's: at 0.1 m it hit 9
            boxes in 30 random-layout races and looped at one box of ``reInvent2019_track``'s
            default layout; at 0.15 m none.
    """

    name = "pure_pursuit"
    SETTINGS = {  # what a spec may set (h2h_racing.policies.registry); its pace: the first two
        "cruise_speed": Setting(0.0, 4.0, "speed on straights [m/s]", low_open=True),
        "lateral_accel": Setting(0.0, 1.0, "fraction of mu g in corners", low_open=True),
        "preview": Setting(0.0, 5.0, "distance whose curvature caps the speed [m]"),
        "lookahead_base": Setting(0.0, 2.0, "look-ahead at standstill [m]", low_open=True),
        "lookahead_gain": Setting(0.0, 1.0, "look-ahead per m/s [s]"),
        "offset": Setting(-0.5, 0.5, "lateral offset from the centre line [m], left +"),
        "box_clearance": Setting(0.0, 0.5, "gap kept from a box's side [m]"),
    }

    def __init__(self, cruise_speed: float = 2.5, lateral_accel: float = 0.45,
                 preview: float = 2.0, lookahead_base: float = 0.35,
                 lookahead_gain: float = 0.2, offset: float = 0.0,
                 box_clearance: float = 0.15) -> None:
        if not cruise_speed > 0:
            raise ValueError(f"cruise_speed must be > 0 m/s, got {cruise_speed}")
        if not 0 < lateral_accel <= 1:
            raise ValueError(f"lateral_accel must be a fraction of mu g in (0, 1], got "
                             f"{lateral_accel}")
        self.cruise_speed = cruise_speed
        self.lateral_accel = lateral_accel
        self.preview = preview
        self.lookahead_base = lookahead_base
        self.lookahead_gain = lookahead_gain
        self.offset = offset
        if not box_clearance >= 0:
            raise ValueError(f"box_clearance must be >= 0 m, got {box_clearance}")
        self.box_clearance = box_clearance

    def reset(self, core: RaceCore) -> None:
        """Nothing to precompute: the centre line is the track's own."""

    def _drive(self, core: RaceCore, car: int, offset: FloatArray | float) -> ActionArray:
        """Pursue the line at lateral ``offset`` (scalar or (E,)) with the speed cap."""
        s = core.s[:, car]
        v = core.speed[:, car]
        ld = lookahead(v, self.lookahead_base, self.lookahead_gain, 1.5)
        a_lat = self.lateral_accel * core.config.car.friction * GRAVITY
        limit = _curvature_speed(core, s, offset, self.preview, a_lat)
        speed = np.minimum(self.cruise_speed, limit)
        offset = np.broadcast_to(np.asarray(offset, dtype=np.float64), s.shape)
        offset, speed = avoid_obstacles(core, car, s + ld, offset, speed,
                                        clearance=self.box_clearance)
        target = core.track.point_at(s + ld, offset)
        steer = pursuit_steer(core, car, target)
        return to_action(core, steer, speed)

    def act(self, core: RaceCore, car: int) -> ActionArray:
        """Return (E, 2) actions for car ``car``."""
        return self._drive(core, car, self.offset)


class RacingLine:
    """Drive the track's minimum-curvature racing line at its speed profile.

    The line and its profile are computed once per track (see
    :mod:`h2h_racing.policies.racing_line`) and tracked with pure pursuit. The speed
    command is the lowest profile speed over the next ``speed_preview`` seconds, which
    makes the speed controller (a first-order lag) brake early enough.

    Opponent handling is minimal and conservative: when another racing car (or a bot car) is
    within ``follow_gap`` metres ahead and overlaps the line, the driver steers to the side of
    it with more room and caps its speed at the other car's speed plus ``closing_speed``. A
    bot changing lanes counts as wide as the span from its offset to its new lane's, so that
    the pass does not cross its path (every bot crash of the margin teacher in 180
    head-to-bot laps was a bot swinging across the line 0.2 s ahead: 18 crashes, 5 since).

    Args:
        grip_factor: Fraction of ``mu g`` the speed profile uses in corners (at 0.7 the
            rear axle saturated in quick S-bends and the car spun out: docs/deepracer.md).
        margin: Distance kept by the line from each border [m].
        speed_preview: Horizon of the speed command [s].
        lookahead_base: Look-ahead distance at standstill [m].
        lookahead_gain: Extra look-ahead per m/s of speed [s].
        follow_gap: Distance ahead within which another car is avoided [m].
        closing_speed: Largest speed excess over a car being avoided [m/s].
        box_clearance: Gap kept between the car's side and a box's side
            (``avoid_obstacles``' ``clearance``) [m].
        box_speed_cap: Highest speed command near a box (``speed_cap``) [m/s].
        box_bend_grip: Fraction of ``mu g`` round a box on a bend (``bend_grip``). A teacher
            for a learner that copies it within some error keeps wider margins: 0.2 m, 1.8
            m/s and 0.35 (experiments/obstacles/README.md).
        box_edge: Distance kept between the car's centre and the border beside a box
            (``avoid_obstacles``' ``edge``) [m]; None keeps ``obstacles.EDGE`` (0.03 m).
            Where ``box_clearance`` does not fit beside a box (narrow tracks), this sets the
            gap: a teacher for a learner that passes such boxes closer than it gives it room
            (experiments/routes/retrain/step9_obstacle).
        box_edge_room: Where given (with ``box_edge``), ``box_edge`` holds only beside boxes
            with less room than this between the box's side and the border on the passing
            side [m] (``avoid_obstacles``' ``edge_room``); the others keep ``obstacles.EDGE``.
            None: ``box_edge`` beside every box (experiments/routes/retrain/step10_obstacle).
    """

    name = "racing_line"
    SETTINGS = {  # what a spec may set (h2h_racing.policies.registry); its pace: grip_factor
        "grip_factor": Setting(0.0, 1.0, "fraction of mu g in corners", low_open=True),
        "margin": Setting(0.0, 0.3, "distance kept from each border [m]"),
        "speed_preview": Setting(0.0, 2.0, "horizon of the speed command [s]"),
        "lookahead_base": Setting(0.0, 2.0, "look-ahead at standstill [m]", low_open=True),
        "lookahead_gain": Setting(0.0, 1.0, "look-ahead per m/s [s]"),
        "follow_gap": Setting(0.0, 5.0, "distance ahead within which a car is avoided [m]"),
        "closing_speed": Setting(0.0, 4.0, "speed excess over a car avoided [m/s]"),
        "box_clearance": Setting(0.0, 0.5, "gap kept from a box's side [m]"),
        "box_speed_cap": Setting(0.0, 4.0, "speed cap near a box [m/s]", low_open=True),
        "box_bend_grip": Setting(0.0, 1.0, "fraction of mu g round a box on a bend",
                                 low_open=True),
        "box_edge": Setting(-0.08, 0.2, "car centre's distance inside the border beside a box "
                            "[m]"),
        "box_edge_room": Setting(0.0, 1.0, "room beside a box under which box_edge holds [m]",
                                 low_open=True, needs="box_edge"),
    }

    def __init__(self, grip_factor: float = 0.6, margin: float = 0.12,
                 speed_preview: float = 0.3, lookahead_base: float = 0.35,
                 lookahead_gain: float = 0.15, follow_gap: float = 1.2,
                 closing_speed: float = 0.5, box_clearance: float = 0.1,
                 box_speed_cap: float = 2.2, box_bend_grip: float = 0.6,
                 box_edge: float | None = None,
                 box_edge_room: float | None = None) -> None:
        if not 0 < grip_factor <= 1:
            raise ValueError(f"grip_factor must be in (0, 1], got {grip_factor}")
        if not (box_clearance >= 0 and box_speed_cap > 0 and 0 < box_bend_grip <= 1):
            raise ValueError(f"box_clearance must be >= 0 [m], box_speed_cap > 0 [m/s] and "
                             f"box_bend_grip in (0, 1], got {box_clearance}, {box_speed_cap} "
                             f"and {box_bend_grip}")
        self.grip_factor = grip_factor
        self.margin = margin
        self.speed_preview = speed_preview
        self.lookahead_base = lookahead_base
        self.lookahead_gain = lookahead_gain
        self.follow_gap = follow_gap
        self.closing_speed = closing_speed
        self.box_margins = {"clearance": box_clearance, "speed_cap": box_speed_cap,
                            "bend_grip": box_bend_grip}
        if box_edge is not None:
            # Off the track only with all four wheels off: the centre at most half the wheel
            # track (0.08 m) outside the border. The range is SETTINGS' (one place).
            edge = self.SETTINGS["box_edge"]
            if not edge.low <= box_edge <= edge.high:
                raise ValueError(f"box_edge must be in [{edge.low:g}, {edge.high:g}] m (the "
                                 f"car's centre inside the border beside a box; negative: "
                                 f"outside, still on track with its inner wheels), got "
                                 f"{box_edge}")
            self.box_margins["edge"] = box_edge
        if box_edge_room is not None:
            if box_edge is None:
                raise ValueError(f"box_edge_room ({box_edge_room} m) limits where box_edge "
                                 f"holds, but box_edge is not given: give box_edge too, or "
                                 f"leave box_edge_room out")
            room = self.SETTINGS["box_edge_room"]
            if not room.low < box_edge_room <= room.high:
                raise ValueError(f"box_edge_room must be in ({room.low:g}, {room.high:g}] m "
                                 f"(the room beside a box under which box_edge holds), got "
                                 f"{box_edge_room}")
            self.box_margins["edge_room"] = box_edge_room
        self.line: RaceLine | None = None
        self._track: Track | None = None

    def reset(self, core: RaceCore) -> None:
        """Compute (or fetch from the per-track cache) the racing line of ``core.track``."""
        if self.line is None or self._track is not core.track:
            self.line = compute_race_line(core.track, core.config.car, core.config.max_speed,
                                          margin=self.margin, grip_factor=self.grip_factor)
            self._track = core.track

    def act(self, core: RaceCore, car: int) -> ActionArray:
        """Return (E, 2) actions for car ``car``."""
        if self.line is None or self._track is not core.track:
            self.reset(core)
        line = self.line
        assert line is not None
        s = core.s[:, car]
        v = core.speed[:, car]
        ld = lookahead(v, self.lookahead_base, self.lookahead_gain, 1.5)
        s_target = s + ld
        offset = on_line = line.offset_at(s_target)
        horizon = np.maximum(v, 1.0) * self.speed_preview
        speed = line.min_speed_ahead(s, horizon)
        if core.num_cars > 1 or core.num_bots:
            offset, speed = self._avoid(core, car, s_target, offset, speed)
        offset, speed = avoid_obstacles(core, car, s_target, offset, speed, **self.box_margins)
        # On the line, its own point: near a coarse waypoint the track's frame, whose normal
        # turns there, puts the line's offset a few cm off it. Off the line (round a car or a
        # box) the track's frame, in which the others are placed, rules.
        target = line.point_at(s_target)
        moved = offset != on_line
        if moved.any():
            target[moved] = core.track.point_at(s_target[moved], offset[moved])
        steer = pursuit_steer(core, car, target)
        return to_action(core, steer, speed)

    def _avoid(self, core: RaceCore, car: int, s_target: FloatArray, offset: FloatArray,
               speed: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Keep clear of the nearest racing car or bot alongside or ahead (per env copy).

        A car alongside (track gap below a car length plus 0.15 m) pushes the lateral
        target to at least a car width plus 0.15 m from it, on the side we are already on.
        A car ahead within ``follow_gap`` that overlaps the line is passed on the side with
        more room, and the speed is capped at its speed plus a closing speed that shrinks
        to zero as the gap closes, so a pass that finds no room becomes a follow. A bot
        changing lanes occupies every offset between its own and its new lane's.
        """
        params = core.config.car
        gap = core.distance - core.distance[:, car : car + 1]  # (E, N), > 0: ahead
        others = core.racing & (np.arange(core.num_cars) != car)[None, :]
        lateral_of, speed_of = core.d, core.speed
        # Each candidate occupies the lateral span [low_of, high_of]: a racing car its
        # offset, a bot changing lanes everything between its offset and its new lane's.
        low_of = high_of = core.d
        if core.num_bots:
            # Bots join the candidates (columns N..N+B-1), by their wrapped arc gap.
            length = core.track.length
            bot_gap = wrap_arcs(core.bot_s - core.s[:, car : car + 1], length)
            gap = np.concatenate([gap, bot_gap], axis=1)
            others = np.concatenate([others, np.ones(bot_gap.shape, dtype=bool)], axis=1)
            lateral_of = np.concatenate([core.d, core.bot_d], axis=1)
            speed_of = np.concatenate([core.speed, core.bot_speed], axis=1)
            # A lane's offset is half the half-width on its side (bots.move_kernel).
            bot_left, bot_right = core.track.half_widths_at(core.bot_s)
            lane_d = core.bot_lane * 0.5 * np.where(core.bot_lane >= 0, bot_left, bot_right)
            low_of = np.concatenate([core.d, np.minimum(core.bot_d, lane_d)], axis=1)
            high_of = np.concatenate([core.d, np.maximum(core.bot_d, lane_d)], axis=1)
        # Just past a car (up to REJOIN behind it), the target comes back to the line by at
        # most REJOIN_STEP from where the car is: a line on the far side of the track is
        # rejoined over a few steps, not with one swing at full speed.
        passed = (others & (gap < -params.length - 0.15) & (gap > -REJOIN)).any(axis=1)
        my_d = core.d[:, car]
        offset = np.where(passed, my_d + np.clip(offset - my_d, -REJOIN_STEP, REJOIN_STEP),
                          offset)
        near = others & (gap > -params.length - 0.15) & (gap < self.follow_gap)
        if not near.any():
            return offset, speed
        rows = np.arange(core.num_envs)
        nearest = np.argmin(np.where(near, np.abs(gap), np.inf), axis=1)
        found = near[rows, nearest]
        other_gap = gap[rows, nearest]
        other_d = lateral_of[rows, nearest]
        other_low, other_high = low_of[rows, nearest], high_of[rows, nearest]
        other_v = speed_of[rows, nearest]
        left, right = core.track.half_widths_at(s_target)
        lo, hi = -right + self.margin, left - self.margin
        clearance = params.width + 0.15
        alongside = found & (other_gap < params.length + 0.15)
        side_now = np.where(my_d >= other_d, 1.0, -1.0)
        room_side = np.where(left - other_high >= other_low + right, 1.0, -1.0)
        side = np.where(alongside, side_now, room_side)
        lateral = np.maximum(0.0, np.maximum(other_low - offset, offset - other_high))
        in_the_way = found & (alongside | (lateral < clearance))
        wanted = np.where(side > 0, other_high, other_low) + side * clearance
        keep_off = np.where(side > 0, np.maximum(offset, wanted), np.minimum(offset, wanted))
        offset = np.where(in_the_way, np.clip(keep_off, lo, hi), offset)
        ahead = found & (other_gap > 0.0) & ~alongside & (lateral < clearance)
        closing = self.closing_speed * np.clip(
            (other_gap - params.length - 0.1) / self.follow_gap, 0.0, 1.0)
        speed = np.where(ahead, np.minimum(speed, other_v + closing), speed)
        return offset, speed


class Blocker(PurePursuit):
    """Drive a lane and move across to cover an attacker close behind.

    The car follows the inner (or outer) DeepRacer lane at a moderate, curvature-capped
    speed. When another racing car is within ``cover_gap`` metres of track distance behind
    it, the lateral target moves to that car's lateral offset (kept ``margin`` inside the
    borders) to hold it off; otherwise it returns to the lane.

    Args:
        lane: ``"inner"`` or ``"outer"``.
        cruise_speed: Speed on straights [m/s].
        cover_gap: Distance behind within which an attacker is covered [m].
        margin: Distance kept from each border by the lateral target [m].
        **kwargs: Further :class:`PurePursuit` arguments.
    """

    name = "blocker"
    SETTINGS = {  # its own, then PurePursuit's but the offset (it steers for its lane)
        "lane": Setting(None, None, "lane it drives", choices=("inner", "outer")),
        "cover_gap": Setting(0.0, 5.0, "distance behind within which it covers [m]"),
        "margin": Setting(0.0, 0.3, "distance kept from each border when covering [m]"),
        **{k: v for k, v in PurePursuit.SETTINGS.items() if k != "offset"},
    }

    def __init__(self, lane: str = "inner", cruise_speed: float = 2.2, cover_gap: float = 1.5,
                 margin: float = 0.15, **kwargs: Any) -> None:
        if lane not in ("inner", "outer"):
            raise ValueError(f"lane must be 'inner' or 'outer', got {lane!r}")
        super().__init__(cruise_speed=cruise_speed, **kwargs)
        self.lane = lane
        self.cover_gap = cover_gap
        self.margin = margin

    def lateral_target(self, core: RaceCore, car: int) -> FloatArray:
        """Return the lateral offset the blocker steers for, shape (E,) [m]."""
        s = core.s[:, car]
        left, right = core.track.half_widths_at(s)
        inner = core.inner_sign if self.lane == "inner" else -core.inner_sign
        lane_d = 0.5 * np.where(inner > 0, left, -right)
        if core.num_cars == 1:
            return lane_d
        behind = core.distance[:, car : car + 1] - core.distance  # > 0: the other is behind
        others = core.racing & (np.arange(core.num_cars) != car)[None, :]
        close = others & (behind > 0.0) & (behind < self.cover_gap)
        nearest = np.argmin(np.where(close, behind, np.inf), axis=1)
        rows = np.arange(core.num_envs)
        cover = np.clip(core.d[rows, nearest], -right + self.margin, left - self.margin)
        return np.where(close[rows, nearest], cover, lane_d)

    def act(self, core: RaceCore, car: int) -> ActionArray:
        """Return (E, 2) actions for car ``car``."""
        return self._drive(core, car, self.lateral_target(core, car))


class Random:
    """Uniform random actions in [-1, 1]^2, for fuzzing (it does not finish laps).

    Args:
        rng: The generator every action is drawn from (explicit, for reproducibility).
    """

    name = "random"

    def __init__(self, rng: np.random.Generator) -> None:
        if not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}; "
                            f"use np.random.default_rng(seed)")
        self.rng = rng

    def reset(self, core: RaceCore) -> None:
        """Nothing to prepare (the generator continues across episodes)."""

    def act(self, core: RaceCore, car: int) -> ActionArray:
        """Return (E, 2) uniform random actions."""
        return self.rng.uniform(-1.0, 1.0, size=(core.num_envs, 2)).astype(np.float32)


# ---------------------------------------------------------------------- registry

DRIVERS: dict[str, Callable[..., Driver]] = {
    "pure_pursuit": PurePursuit,
    "racing_line": RacingLine,
    "blocker": Blocker,
    "random": Random,
    "planner": Planner,
}
"""Driver constructors by registry name."""
TEACHERS = ("racing_line", "pure_pursuit", "blocker", "planner")
"""Drivers that can label actions for imitation learning (deterministic functions of the state;
``random`` teaches nothing)."""


# ---------------------------------------------------------------------- running races


def drive(core: RaceCore, drivers: Sequence[Driver], max_steps: int | None = None) -> int:
    """Run the core with one driver per car until every car is done.

    Calls each driver's ``reset`` (the core must already be reset), then steps. Actions are
    mapped back to radians and m/s exactly as ``RacingEnv`` does.

    Args:
        core: A reset core with ``len(drivers)`` cars.
        drivers: Driver of car i at index i.
        max_steps: Optional step cap (the core's own time limit applies anyway).

    Returns:
        The number of steps taken.
    """
    if len(drivers) != core.num_cars:
        raise ValueError(f"expected one driver per car ({core.num_cars}), got {len(drivers)}")
    for driver in drivers:
        driver.reset(core)
    steps = 0
    while not core.done.all() and (max_steps is None or steps < max_steps):
        actions = np.stack([d.act(core, i) for i, d in enumerate(drivers)], axis=1)
        core.step(*core.config.commands(actions))
        steps += 1
    return steps


def race_core(track: str | Track, num_cars: int, laps: int = 1, num_envs: int = 1,
              seed: int = 0, **config: Any) -> RaceCore:
    """Return a reset ``RaceCore`` for a race of ``laps`` laps with a fixed grid (car i in slot i).

    Args:
        track: Catalogue name or ``Track``.
        num_cars: Number of cars.
        laps: Lap target.
        num_envs: Env copies.
        seed: Reset seed.
        **config: Further ``EnvConfig`` fields.
    """
    from h2h_racing.track.io import load_track

    track_obj = track if isinstance(track, Track) else load_track(track)
    cfg = EnvConfig(track=track_obj.name, num_cars=num_cars, grid="fixed",
                    rules=RaceRules(laps=laps, time_limit=120.0), **config)
    core = RaceCore(cfg, track_obj, num_envs=num_envs)
    core.reset(seed=seed)
    return core
