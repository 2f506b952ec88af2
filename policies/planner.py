"""``planner``: a scripted driver that races: it plans passes from behind and defends.

A local planner in the spirit of Frenet-frame sampling (Werling et al., ICRA 2010) and TUM's
graph-based planner (Stahl et al., ITSC 2019), batched over env copies:

* **Lanes** (once per track, cached): the racing line at the driver's grip, the racing line
  shifted 0.15, 0.3 and 0.45 m to each side and two lanes at 0.85 of the half-width, each with
  its curvature and its closed-loop quasi-steady-state speed profile
  (:func:`~h2h_racing.policies.racing_line.speed_profile`; ``LANE_GRIP`` of the grip off the
  racing line).
* **Candidates** (every step, every copy, :mod:`h2h_racing.policies.planner_kernel`): the path
  being tracked, blends onto each lane over a short and a long transition (hold the line, pass
  left, pass right, come back) and, beside a car, a hold of its own offset, each with its
  speed profile over a horizon of a few metres. Every other car and bot is predicted along
  the track (its acceleration and pace, its lateral speed, but not towards the car while the
  two overlap unless it comes across fast, ``DRIFT_FAST``: a car alongside leaves room, and
  the planner leaves the cars alongside room in turn, ``ROOM``, ``_keep_room``); a car that
  drives the racing line (``LINE_FIT``) is predicted on it, and at its scaled profile's speed
  while it keeps to that (``ON_PROFILE``), braking for a bend to the bend's speed; a candidate
  that leaves the track or comes within a car length and width plus margins of a predicted
  car is not free. The free one that reaches the horizon soonest wins; a blocked one is
  tried again held, where it overlaps the blocking car, to the speed that car will have a car
  length further on (across behind it, then past): it follows in space, not in time, so that
  it closes in under braking rather than braking when the car ahead does; with none free it
  follows, and after ``RUNUP_AFTER`` seconds stuck it drops back for a run-up. No lane change
  starts in a tight bend (``SWITCH_CURVATURE``): a pass there is set up on the approach.
* **Defence**: with a car close behind (``cover_gap``) on a corner's approach (within
  ``COVER_RANGE`` of its apex, past the last bend the other way), it takes the inside lane of
  that corner once, if that costs at most ``COVER_BONUS``, until the apex, then its line
  again. With a car close behind and none alongside or ahead, its lane changes may be
  steeper (``DEFEND_SLOPE``).
* **Tracking** (:mod:`~h2h_racing.policies.tracking`): the path's own curvature as
  feed-forward, with feedback on the offset and heading errors and a yaw-rate damper, and a
  speed command that makes the car's speed controller deliver the profile's acceleration (to
  its lowest speed over ``SPEED_PREVIEW``) rather than lag it, braking where the tyres cannot
  give the commanded curvature.

``grip_factor`` sets the pace: the share of ``mu g`` used in corners (``racing_line`` uses
0.6). Boxes (``object_avoidance``) are kept clear of as by ``racing_line``
(:func:`~h2h_racing.policies.obstacles.avoid_obstacles`). Measured against issue 34's targets
in experiments/planner/README.md.
"""

from __future__ import annotations

import math
import weakref
from typing import Any

import numpy as np
import numpy.typing as npt

from h2h_racing.sim.core import RaceCore
from h2h_racing.policies import planner_kernel as kernel
from h2h_racing.policies import tracking
from h2h_racing.policies.obstacles import avoid_obstacles
from h2h_racing.policies.racing_line import (GRAVITY, compute_race_line, line_curvature,
                                             speed_profile)
from h2h_racing.policies.registry import Setting
from h2h_racing.policies.steering import lookahead, pursuit_steer, to_action
from h2h_racing.track.lookup import wrap_arcs
from h2h_racing.track.shape import Track

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

SHIFTS = (-0.45, -0.3, -0.15, 0.15, 0.3, 0.45)
"""Sideways shifts of the racing line that make lanes [m] (clipped to the track, smoothed)."""
SHARES = (-0.85, 0.85)
"""Lanes at these shares of the half-width less the margin (left positive): beside a car on
the racing line, every shifted line may end up too near it where the line hugs a border."""
RUNUP_AFTER = 1.5
"""Time stuck behind a car after which the driver drops back for a run-up [s]."""
RUNUP_TIME = 1.5
"""How long a run-up holds the larger gap [s]."""
SPEED_PREVIEW = 0.25
"""Horizon of the speed command [s]: the lowest speed of the plan's profile over it, so that
the car is at a bend's speed before the bend (racing_line's speed_preview is 0.3 s). Alone on
the shipped tracks and 20 random ones (10 starts each, pure pursuit tracking): 0 left 4 of 27
tracks unclean, 0.15 one, 0.25 none, at 3.2 % off racing_line's laps against 4 %."""
ACCEL_FACTOR = 1.0
"""Share of the car's acceleration used in the speed profiles (the car's own limit)."""
FOLLOW_COST = 0.05
"""Cost of a candidate that must slow behind a car, on top of its time [s]: following gives
up the pace margin that a free line keeps. Once a car on the racing line was predicted
braking to its bend's speed, not to a stop (``ON_PROFILE``), a follow candidate's time became
a fair one, and a larger cost sent the planner onto free side lanes slower than following:
behind `racing_line` on the tuning tracks (200 races) 75, 80, 86, 80, 70 and 64 won at 0,
0.03, 0.05, 0.07, 0.1 and 0.2 (experiments/planner, item 16)."""
SWITCH_COST = 0.05
"""Cost of leaving the path being tracked for another lane [s] (against dithering)."""
SWITCH_CURVATURE = 1.0
"""Largest centre-line curvature over a transition to another lane [1/m] (radius 1 m): lane
changes in the tightest bends at the planner's grip leave the track. Until the planner
followed in space (``planner_motion._speed_ahead``) it was 0.3 (radius 3.3 m), which barred
every lane change on twisty tracks (``technical`` has no 2.5 m without one); at 1.0 the
4-car field from the back won 91 of 200 races on the tuning tracks against 73, with 4
off-tracks in 200 races behind `racing_line` against 1 (experiments/planner, item 13)."""
BOX_REANCHOR = 0.8
"""``kernel.REANCHOR`` while the car steers round a box [m]."""
PREDICT_STEPS = 30
"""Steps of ``kernel.PREDICT_DT`` over which other cars are predicted (3 s)."""
ACCEL_TIME = 0.3
"""Time over which another car's acceleration is smoothed [s]."""
PACE_TIME = 1.0
"""Time over which another car's pace ratio is smoothed [s]."""
TOP_DECAY = 0.3
"""Rate at which the top speed remembered of each car fades [m/s per s]."""
HOLD_GRIP = 0.8
"""Share of the driver's grip used when holding an offset beside a car (parallel to the
centre line, whose bends are less smooth than the lanes')."""
LANE_GRIP = 0.9
"""Share of the driver's grip used on lanes other than the racing line."""
APEX_CURVATURE = 0.5
"""Least racing-line curvature of a corner's apex [1/m] (radius 2 m)."""
COVER_RANGE = 5.0
"""Distance before a corner's apex within which a car close behind makes the driver cover
its inside [m]."""
COVER_OPPOSITE = 0.3
"""Centre-line curvature the other way [1/m] that ends a corner's approach: no cover starts
before it (``Lanes.approach``). Covering a left-hander's inside from within the right-hander
before it drives that bend on its outside; on 20 tuning tracks, from the front against
`league_racer` (200 races), 122 won with covers started up to ``COVER_RANGE`` before the apex
and 129 with covers started on the approach (experiments/planner, item 17)."""
COVER_BONUS = 0.1
"""Time the driver gives up to cover a corner's inside [s]: the inside lane is taken if it
is at most this much slower to the horizon. Covers on the approach, from the front against
`league_racer` on the tuning tracks (200 races): 129, 133 and 135 won and 10, 8 and 6
crashes at 0.5, 0.2 and 0.1 s; 137 and 4 without covering at all (item 17)."""
ROOM = 0.3
"""Arc gap beyond the two cars' overlap (a car length, centre to centre) within which another
car counts as leaving this one room: its drift towards it is not extrapolated [m]. The
scripted drivers leave room from 0.15 m; expecting it from 0.3 m commits the planner to a
pass that draws level before the car ahead's turn-in reaches it (tuning tracks, 200 races
each, from behind: 44 won against `racing_line` at 0.3, 26 at 0.15)."""
DRIFT_FAST = 0.3
"""Sideways speed towards the planner above which a car alongside is not trusted to leave room
[m/s]: it is coming across faster than a steering correction, and its drift is extrapolated
for ``DRIFT_TIME``. Slower drifts (a car turning in to its apex, its tracking's sway) are not
extrapolated at all."""
DRIFT_TIME = 0.1
"""How long the drift of a car coming across fast is extrapolated [s]: the time its steering
takes to stop it (four planners on 30 procedural tracks drawn like the real routes: 19
contacts in 300 races, against 33 without; 0.5 m/s: 28)."""
ROOM_RUN = 1.0
"""Least run of track over which the path it tracks may close on the room it leaves a car
alongside [m] (``_keep_room``): its slope towards it is at most the room left over this."""
LINE_FIT = 0.1
"""Mean distance from the racing line (smoothed over ``FIT_TIME``) under which another car
counts as driving it [m]: it is predicted along the line (``kernel._span``)."""
FIT_TIME = 1.0
"""Time over which another car's distance from the racing line is smoothed [s]."""
ON_PROFILE = 0.2
"""Share of the scaled profile speed within which a car that drives the racing line counts as
keeping to that profile: it is predicted to keep to it (``kernel.predict``), braking for a
bend only to the bend's scaled speed, not extrapolated to a stop."""
ROOM_KEPT = 0.15
"""Distance beyond a car width kept from a car alongside (ahead within a car length and this
along the track, or behind and overlapping), as the scripted drivers keep [m]."""

DEFEND_SLOPE = 0.35
"""Steepest lateral slope dd/ds of a lane change while defending (a car within ``cover_gap``
behind, none alongside or ahead within it), against ``kernel.MAX_SLOPE`` (0.2) otherwise:
off the grid the car on pole could not move across to cover the first bend's inside in
time (0.54 m took 5 m). From the front against `league_racer` on the tuning tracks (200
races): 135 won (33 losses in the first 3 s) at 0.2, 151 (27) at 0.35, 154 at 0.5; four
planners 6, 4 and 7 contacts; behind `racing_line` (87), `blocker` (187, 80 crashes) and
the 4-car field (99-100) unchanged at 0.35. Steeper lane changes everywhere (0.35) won 151
in front too, but 60 rather than 87 behind `racing_line` (experiments/planner, item 19)."""

_CACHE: weakref.WeakKeyDictionary[Track, dict[tuple[float, ...], Lanes]] = (
    weakref.WeakKeyDictionary())


class Lanes:
    """The planner's lanes on one track and its corners (arrays read-only).

    Attributes:
        offset: Lateral offset of each lane, (NL, K) [m]; lane 0 is the racing line.
        speed: Profile speed of each lane at the driver's grip, (NL, K) [m/s].
        curvature: Curvature of each lane, (NL, K) [1/m].
        centre: Centre line's curvature [1/m], left and right half-widths [m], (3, K).
        inv_ds: Grid density, K / L [1/m].
        length: Lap length L [m].
        apex_s: Arc position of each corner's apex, (C,) [m].
        inside_lane: Lane that covers the inside of each corner, (C,).
        approach: Run of track before each apex back to where the centre line last bends the
            other way beyond ``COVER_OPPOSITE`` (the lap length if it never does), (C,) [m].
        lap_time: The racing line's profile lap time at this grip [s].
    """

    def __init__(self, track: Track, car: Any, v_max: float, grip: float, accel: float,
                 brake: float, margin: float) -> None:
        line = compute_race_line(track, car, v_max, margin=margin, grip_factor=grip,
                                 accel_factor=accel, brake_factor=brake)
        s = line.s
        left, right = track.half_widths_at(s)
        lo, hi = -(right - margin), left - margin
        offsets = [np.asarray(line.d)]
        offsets += [_smooth(np.clip(line.d + shift, lo, hi), lo, hi) for shift in SHIFTS]
        offsets += [share * hi if share >= 0 else -share * lo for share in SHARES]
        # Lanes off the racing line are driven at LANE_GRIP of its grip: the car reaches
        # them through a transition, and a car at the limit on the outside has no room left.
        a_lat = LANE_GRIP * grip * car.friction * GRAVITY
        speeds, curvatures = [np.asarray(line.speed)], [np.asarray(line.curvature)]
        for d in offsets[1:]:
            kappa, seg = line_curvature(track.point_at(s, d), smooth=2)
            speeds.append(speed_profile(kappa, seg, v_max, a_lat, accel * car.max_accel,
                                        brake * car.max_brake))
            curvatures.append(kappa)
        self.offset = np.ascontiguousarray(offsets)
        self.speed = np.ascontiguousarray(speeds)
        self.curvature = np.ascontiguousarray(curvatures)
        self.centre = np.ascontiguousarray([track.curvature_at(s), left, right])
        self.length = float(track.length)
        self.inv_ds = len(s) / self.length
        self.lap_time = float(line.lap_time)
        self.apex_s, sign = _apexes(s, np.asarray(line.curvature))
        # The lane most to the inside 1 m before each apex covers that corner's inside.
        before = np.searchsorted(s, np.remainder(self.apex_s - 1.0, self.length)) % len(s)
        self.inside_lane = np.argmax(self.offset[:, before] * sign[None, :], axis=0)
        # Each corner's approach: the run back from its apex to where the track last bends
        # the other way (centre line, beyond COVER_OPPOSITE), or the whole lap.
        count = len(s)
        back = np.arange(1, count)
        index = np.searchsorted(s, self.apex_s)[:, None] - back[None, :]
        opposite = self.centre[0][index % count] * sign[:, None] < -COVER_OPPOSITE
        steps = np.where(opposite.any(axis=1), opposite.argmax(axis=1) + 1, count)
        self.approach = steps * (self.length / count)
        for arr in (self.offset, self.speed, self.curvature, self.centre, self.apex_s,
                    self.inside_lane, self.approach):
            arr.flags.writeable = False

    def at(self, row: FloatArray, s: FloatArray) -> FloatArray:
        """``row`` (one lane's table, (K,)) at arc positions ``s`` (any shape, any real
        number) [m]: periodic linear interpolation over the lap."""
        return np.interp(np.remainder(s, self.length) * self.inv_ds, np.arange(len(row) + 1),
                         np.append(row, row[0]))


def _smooth(d: FloatArray, lo: FloatArray, hi: FloatArray, width: int = 5,
            passes: int = 3) -> FloatArray:
    """Circular moving average of ``d`` (``passes`` times), kept within ``[lo, hi]``."""
    for _ in range(passes):
        d = sum(np.roll(d, j) for j in range(-(width // 2), width // 2 + 1)) / width
        d = np.clip(d, lo, hi)
    return d


def _apexes(s: FloatArray, kappa: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Apexes of a closed line: local peaks of ``|kappa|`` above ``APEX_CURVATURE``, at most
    one per metre; returns their arc positions and the sign of their turn (+1 left)."""
    k = len(s)
    window = max(1, round(1.0 / (s[1] - s[0])))
    mag = np.abs(kappa)
    peak = mag >= APEX_CURVATURE
    for j in range(1, window + 1):
        peak &= (mag >= np.roll(mag, j)) & (mag > np.roll(mag, -j))
    index = np.flatnonzero(peak)
    if k and not len(index):
        return np.zeros(0), np.zeros(0)
    return s[index].astype(np.float64), np.sign(kappa[index])


class Planner:
    """A racing driver: plans passes, defends once per corner, tracks at its grip.

    Args:
        grip_factor: Share of ``mu g`` used in corners: the driver's pace (``racing_line``
            uses 0.6). Alone it laps every shipped track and every DeepRacer route of
            ../shared/data clean at every grip from 0.65 to 1 (10 starts each); its laps
            differ by under 1 % from 0.85 to 1 (the tracking brakes out of slides), and 0.85
            caused the fewest crashes in races against ``blocker`` on the shipped tracks.
        brake_factor: Share of the car's braking used in the speed profiles.
        margin: Distance kept by the lanes from each border [m].
        cover_gap: Distance behind within which an attacker makes it defend [m].
        lateral_margin: Gap kept beside a predicted car, beyond the two half-widths [m].
        long_margin: Gap kept behind a predicted car, beyond the two half-lengths [m].
        follow_gap: Bumper gap held behind a car it follows [m].
        follow_time: Extra follow gap per m/s of its own speed [s].
        runup_gap: Extra follow gap of a run-up, after ``RUNUP_AFTER`` seconds stuck behind
            a car [m] (0: none).
        steady_gap: Bumper gap held instead, when smaller, behind a lone car (no other within
            ``PACK_RANGE``) whose recent top speed is near the planner's: right behind a
            rival of equal top speed it is alongside when that car brakes earlier for a bend.
            A slower car (one to pass at once) and a pack keep the follow gap.

    Raises:
        ValueError: A setting out of its range (``SETTINGS``), in one line.
    """

    name = "planner"
    SETTINGS = {  # what a spec may set (h2h_racing.policies.registry); its pace: grip_factor
        "grip_factor": Setting(0.3, 1.0, "fraction of mu g used in corners (its pace)"),
        "brake_factor": Setting(0.2, 1.0, "fraction of the car's braking in the profiles"),
        "margin": Setting(0.05, 0.3, "distance kept by the lanes from each border [m]"),
        "cover_gap": Setting(0.0, 5.0, "distance behind within which it defends [m]"),
        "lateral_margin": Setting(0.0, 0.5, "gap kept beside a car, beyond the widths [m]"),
        "long_margin": Setting(0.0, 1.0, "gap kept behind a car, beyond the lengths [m]"),
        "follow_gap": Setting(0.0, 2.0, "bumper gap held behind a car it follows [m]"),
        "follow_time": Setting(0.0, 1.0, "extra follow gap per m/s [s]"),
        "runup_gap": Setting(0.0, 5.0, "extra gap of a run-up behind a car it is stuck behind [m]"),
        "steady_gap": Setting(0.0, 2.0, "bumper gap behind a lone rival as fast as it [m]"),
    }

    def __init__(self, grip_factor: float = 0.85, brake_factor: float = 0.8,
                 margin: float = 0.12, cover_gap: float = 1.5, lateral_margin: float = 0.1,
                 long_margin: float = 0.15, follow_gap: float = 0.15, follow_time: float = 0.03,
                 runup_gap: float = 2.0, steady_gap: float = 0.0) -> None:
        given = {"grip_factor": grip_factor, "brake_factor": brake_factor, "margin": margin,
                 "cover_gap": cover_gap, "lateral_margin": lateral_margin,
                 "long_margin": long_margin, "follow_gap": follow_gap,
                 "follow_time": follow_time, "runup_gap": runup_gap, "steady_gap": steady_gap}
        for key, value in given.items():
            try:
                setattr(self, key, self.SETTINGS[key].check(value))
            except ValueError as allowed:
                raise ValueError(f"planner: {key} must be {allowed}, got {value!r}") from None
        self.lanes: Lanes | None = None
        self._track: Track | None = None
        self._plan = (np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0), np.zeros(0),
                      np.zeros(0), np.zeros(0))
        self._cover = np.zeros(0, dtype=np.int64)
        self._covered = np.zeros(0, dtype=np.int64)
        self._ratio = np.ones((0, 0))
        self._speed = np.zeros((0, 0))
        self._accel = np.zeros((0, 0))
        self._top = np.zeros((0, 0))
        self._reanchor = np.zeros(0)
        self._stuck = np.zeros(0)
        self._runup_left = np.zeros(0)
        self._packed = np.zeros(0)
        self._fit = np.zeros((0, 0))

    def reset(self, core: RaceCore) -> None:
        """Build (or fetch) the lanes of ``core.track`` and clear every copy's plan."""
        if self.lanes is None or self._track is not core.track:
            key = (self.grip_factor, self.brake_factor, ACCEL_FACTOR, self.margin,
                   core.config.max_speed, *core.config.car.__dict__.values())
            per_track = _CACHE.setdefault(core.track, {})
            if key not in per_track:
                per_track[key] = Lanes(core.track, core.config.car, core.config.max_speed,
                                       self.grip_factor, ACCEL_FACTOR, self.brake_factor,
                                       self.margin)
            self.lanes = per_track[key]
            self._track = core.track
        e = core.num_envs
        self._plan = (np.full(e, -1, dtype=np.int64), np.zeros(e), np.zeros(e), np.zeros(e),
                      np.ones(e), np.zeros(e))
        self._cover = np.full(e, -1, dtype=np.int64)
        self._covered = np.full(e, -1, dtype=np.int64)
        self._ratio = np.ones((e, core.num_cars))
        self._speed = np.zeros((e, core.num_cars))
        self._accel = np.zeros((e, core.num_cars))
        self._top = np.full((e, core.num_cars), core.config.max_speed)
        self._reanchor = np.full(e, kernel.REANCHOR)
        self._stuck = np.zeros(e)
        self._runup_left = np.zeros(e)
        self._packed = self._params(core)
        self._fit = np.full((e, core.num_cars), 3.0 * LINE_FIT)

    def _params(self, core: RaceCore) -> FloatArray:
        """The kernel's packed parameters (``kernel.P_*``) for ``core``'s car and rules."""
        car = core.config.car
        params = np.zeros(kernel.NUM_PARAMS)
        params[kernel.P_A_LAT] = self.grip_factor * car.friction * GRAVITY
        params[kernel.P_A_ACC] = ACCEL_FACTOR * car.max_accel
        params[kernel.P_A_BRK] = self.brake_factor * car.max_brake
        params[kernel.P_EDGE] = self.margin - 0.04
        params[kernel.P_HALF_LEN] = 0.5 * car.length
        params[kernel.P_HALF_WID] = 0.5 * car.width
        params[kernel.P_LONG_MARGIN] = self.long_margin
        params[kernel.P_LAT_MARGIN] = self.lateral_margin
        params[kernel.P_CLOSING_MARGIN] = 0.2
        params[kernel.P_SWITCH_COST] = SWITCH_COST
        params[kernel.P_DEV_COST] = 0.02
        params[kernel.P_GAIN] = car.speed_gain
        params[kernel.P_DT] = core.dt
        params[kernel.P_FOLLOW_GAP] = self.follow_gap
        params[kernel.P_FOLLOW_TIME] = self.follow_time
        params[kernel.P_FOLLOW_GAIN] = 1.5
        params[kernel.P_V_MAX] = core.config.max_speed
        params[kernel.P_FOLLOW_COST] = FOLLOW_COST
        params[kernel.P_SWITCH_CURVATURE] = SWITCH_CURVATURE
        params[kernel.P_A_LANE] = HOLD_GRIP * params[kernel.P_A_LAT]
        params[kernel.P_SPEED_PREVIEW] = SPEED_PREVIEW
        params[kernel.P_STEADY_GAP] = self.steady_gap
        params[kernel.P_ROOM] = ROOM
        return params

    def act(self, core: RaceCore, car: int) -> npt.NDArray[np.float32]:
        """Return (E, 2) actions for car ``car``."""
        if (self.lanes is None or self._track is not core.track
                or self._ratio.shape != (core.num_envs, core.num_cars)):
            self.reset(core)
        lanes = self.lanes
        assert lanes is not None
        track = core.track
        s = core.s[:, car].copy()
        d = core.d[:, car].copy()
        v = core.speed[:, car].copy()
        psi = track.heading_at(core.s)  # every car's, (E, N)
        kc = track.curvature_at(s)
        err = np.remainder(core.yaw[:, car] - psi[:, car] + math.pi, 2.0 * math.pi) - math.pi
        slope = np.clip(np.tan(np.clip(err, -1.2, 1.2)) * (1.0 - kc * d), -1.0, 1.0)
        objects = self._objects(core, car, psi, self._off_line(core, lanes))
        cap, ratio, accel, top = self._pace(core, car, lanes)
        traj = np.empty(objects[0].shape + (PREDICT_STEPS + 1,))
        kernel.predict(objects[0], objects[3], cap, ratio, s, lanes.speed[:1], lanes.inv_ds,
                       lanes.length, accel, traj)
        transitions = np.stack([0.8 + 0.5 * v, 1.2 + 1.0 * v], axis=1)
        horizon = np.clip(np.maximum(transitions[:, 1] + 1.0, 1.6 * v), 3.0, 8.0)
        look = lookahead(v, 0.35, 0.15, 1.5)
        bonus = self._defence(core, car, lanes)
        e = core.num_envs
        choice = np.empty(e, dtype=np.int64)
        d_look = np.empty(e)
        v_cmd = np.empty(e)
        self.report = np.empty((e, lanes.offset.shape[0] + 1, transitions.shape[1], 3))
        track_at = tracking.preview(v, look)
        path = np.empty((e, track_at.shape[1], 3))
        kernel.plan(s, d, slope, v, lanes.offset, lanes.speed, lanes.curvature, lanes.centre,
                    lanes.inv_ds, lanes.length, transitions, horizon, 30, *objects[:3], traj,
                    *objects[3:], top, bonus,
                    *self._plan, self._packed, self._reanchor, self._max_slope(core, car),
                    self._runup(core),
                    look, choice, d_look, v_cmd, self.report, track_at, path)
        self.choice = choice
        self._stuck = np.where(choice < 0, self._stuck + core.dt, 0.0)
        planned = d_look
        d_look, v_cmd = avoid_obstacles(core, car, s + look, d_look, v_cmd)
        # Round a box the car leaves its path on purpose: keep the path to come back to.
        self._reanchor = np.where(np.abs(d_look - planned) > 0.01, BOX_REANCHOR,
                                  kernel.REANCHOR)
        self._keep_room(core, car, objects[0][:, : core.num_cars], path, track_at)
        steer, tracked_cmd = tracking.track_path(core, car, kc, err, path, v_cmd)
        # Round a box the car steers at a point off its path (pure pursuit, as racing_line):
        # the path's curvature says nothing of that detour. The pursuit arc's curvature
        # times speed is the yaw rate it asks for (r = v tan(delta) / L).
        boxed = np.abs(d_look - planned) > 0.01
        if not boxed.any():  # no box in the way: the usual step, no pursuit to compute
            return to_action(core, steer, tracked_cmd)
        pursuit = pursuit_steer(core, car, track.point_at(s + look, d_look))
        pursuit -= tracking.YAW_DAMPING * (core.yaw_rate[:, car]
                                           - v * np.tan(pursuit) / core.config.car.wheelbase)
        return to_action(core, np.where(boxed, pursuit, steer),
                         np.where(boxed, v_cmd, tracked_cmd))

    def _keep_room(self, core: RaceCore, car: int, gap: FloatArray, path: FloatArray,
                   ahead: FloatArray) -> None:
        """Leave the cars alongside room, as the scripted drivers do and as it expects of
        others (``ROOM``): the offsets of the path it tracks (``path[..., 0]``, (E, P) [m])
        are kept a car width and ``ROOM_KEPT`` from every car ahead within a car length and
        ``ROOM_KEPT`` along the track and every car behind that overlaps it (within a car
        length: its nose past the planner's tail), to the left of those on its right and to
        the right of those on its left (a car at its own offset counts as on its right), each
        bound held within the track less ``margin``; squeezed between two, it takes the
        middle. A car behind whose nose has not reached its tail is not alongside: there the
        planner may close the door, as racing's rules allow (room for one up to 0.15 m short
        of it too: 89 of 200 races won in front of `league_racer` on the tuning tracks; only
        for one that overlaps: 123, four planners' contacts 5 and 14 in 200 races).
        The path's slope at the car is kept from closing on a bound within ``ROOM_RUN`` of
        track, and where a bound holds the path its curvature is the bound's (parallel to the
        centre line): the tracking steers by the slope and curvature as much as by the
        offset, and a path clamped in offset alone still turned the car into the other one.
        ``gap`` is every car's wrapped arc gap ahead of this one, (E, N) [m] (``_objects``'
        first N columns); ``ahead`` the arc distances of the path's points ahead of the car,
        (E, P) [m] (``tracking.preview``)."""
        params = core.config.car
        alongside = (core.racing & (gap < params.length + ROOM_KEPT) & (gap > -params.length)
                     & (np.arange(core.num_cars) != car)[None, :])
        if not alongside.any():
            return
        room = params.width + ROOM_KEPT
        left, right = core.track.half_widths_at(core.s[:, car])
        on_left = core.d > core.d[:, car : car + 1]
        upper = np.min(np.where(alongside & on_left, core.d - room, np.inf), axis=1)
        lower = np.max(np.where(alongside & ~on_left, core.d + room, -np.inf), axis=1)
        upper = np.maximum(upper, -right + self.margin)
        lower = np.minimum(lower, left - self.margin)
        squeezed = lower > upper  # both finite then
        middle = 0.5 * (np.where(squeezed, lower, 0.0) + np.where(squeezed, upper, 0.0))
        upper = np.where(squeezed, middle, upper)[:, None]
        lower = np.where(squeezed, middle, lower)[:, None]
        offset = np.minimum(np.maximum(path[..., 0], lower), upper)
        held = offset != path[..., 0]
        path[..., 0] = offset
        path[:, 0, 1] = np.clip(path[:, 0, 1], (lower[:, 0] - offset[:, 0]) / ROOM_RUN,
                                (upper[:, 0] - offset[:, 0]) / ROOM_RUN)
        kappa = core.track.curvature_at(core.s[:, car : car + 1] + ahead)
        path[..., 2] = np.where(held, kappa / np.maximum(1.0 - kappa * offset, 0.2),
                                path[..., 2])

    def _attackers(self, core: RaceCore, car: int) -> tuple[BoolArray, BoolArray]:
        """Per copy, (E,) each: whether a car is within ``cover_gap`` behind (beyond a car
        length and 0.05 m: not alongside), and whether one is alongside or ahead within
        ``cover_gap``."""
        behind = core.distance[:, car : car + 1] - core.distance
        others = ~core.done & (np.arange(core.num_cars) != car)[None, :]
        clear = core.config.car.length + 0.05
        attacked = (others & (behind > clear) & (behind < self.cover_gap)).any(axis=1)
        pressed = (others & (behind <= clear) & (behind > -self.cover_gap)).any(axis=1)
        return attacked, pressed

    def _max_slope(self, core: RaceCore, car: int) -> FloatArray:
        """Steepest lateral slope of a lane change, (E,): ``DEFEND_SLOPE`` with a car within
        ``cover_gap`` behind (and none alongside or ahead within ``cover_gap``), else
        ``kernel.MAX_SLOPE``."""
        attacked, pressed = self._attackers(core, car)
        return np.where(attacked & ~pressed, DEFEND_SLOPE, kernel.MAX_SLOPE)

    def _runup(self, core: RaceCore) -> FloatArray:
        """Extra follow gap (E,) [m]: after ``RUNUP_AFTER`` seconds stuck behind a car
        (following, no candidate free), drop back to ``runup_gap`` for ``RUNUP_TIME`` seconds,
        then close again with speed. A car that covers whoever is close behind it (``blocker``)
        goes back to its line, and the next approach comes with the pace to pass before it
        moves across."""
        start = (self._stuck > RUNUP_AFTER) & (self._runup_left <= 0.0)
        self._runup_left = np.where(start, RUNUP_TIME, self._runup_left - core.dt)
        self._stuck = np.where(start, 0.0, self._stuck)
        return np.where(self._runup_left > 0.0, self.runup_gap, 0.0)

    def _pace(self, core: RaceCore, car: int,
              lanes: Lanes) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Top speed, pace ratio and acceleration of each object slot (E, N + B) for
        ``kernel.predict``.

        A car's pace ratio is its speed over the planner's racing-line profile where that
        profile is below top speed (in and near corners), smoothed over ``PACE_TIME``: a
        ``racing_line`` at grip 0.6 settles near ``sqrt(0.6 / grip_factor)``. It starts at 1
        (as fast as the planner). A car that drives the racing line (``_fit``) within
        ``ON_PROFILE`` of that scaled profile's speed gets a nan acceleration: ``predict``
        keeps it to the profile. Bots keep their own constant speed.
        """
        profile = lanes.at(lanes.speed[0], core.s)
        cornering = core.racing & (profile < 0.95 * core.config.max_speed)
        rate = min(1.0, core.dt / PACE_TIME)
        seen = np.clip(core.speed / np.maximum(profile, 0.1), 0.3, 1.5)
        self._ratio = np.where(cornering, self._ratio + rate * (seen - self._ratio),
                               self._ratio)
        # Each car's acceleration, smoothed over ACCEL_TIME (a new episode's first step reads
        # 0): it keeps it in the prediction.
        seen_accel = (core.speed - self._speed) / core.dt
        self._accel += min(1.0, core.dt / ACCEL_TIME) * (seen_accel - self._accel)
        self._speed = core.speed.copy()
        self._top = np.maximum(np.where(core.racing, core.speed, 0.0),
                               self._top - TOP_DECAY * core.dt)
        top = self._top
        cap = np.full(self._ratio.shape, core.config.max_speed)
        ratio, accel = self._ratio, np.clip(self._accel, -core.config.car.max_brake,
                                           core.config.car.max_accel)
        on_profile = ((self._fit < LINE_FIT) & core.racing
                      & (np.abs(core.speed - self._ratio * profile) < ON_PROFILE * profile))
        accel = np.where(on_profile, np.nan, accel)
        if core.num_bots:
            cap = np.concatenate([cap, core.bot_speed], axis=1)
            ratio = np.concatenate([ratio, np.full(core.bot_speed.shape, 10.0)], axis=1)
            accel = np.concatenate([accel, np.zeros(core.bot_speed.shape)], axis=1)
            top = np.concatenate([top, core.bot_speed], axis=1)
        return (np.ascontiguousarray(cap), np.ascontiguousarray(ratio),
                np.ascontiguousarray(accel), np.ascontiguousarray(top))

    def _off_line(self, core: RaceCore, lanes: Lanes) -> FloatArray:
        """Every car's offset from the racing line, (E, N) [m]; updates how far each keeps
        from it on average (``_fit``, smoothed over ``FIT_TIME``), which says whether it
        drives the line (under ``LINE_FIT``)."""
        off_line = core.d - lanes.at(lanes.offset[0], core.s)
        self._fit += min(1.0, core.dt / FIT_TIME) * (np.abs(off_line) - self._fit)
        return off_line

    def _objects(self, core: RaceCore, car: int, psi: FloatArray,
                 off_line: FloatArray) -> tuple[Any, ...]:
        """Other cars and bots as the kernel's object slots (E, N + B) (see ``plan``);
        ``psi`` is the track's heading at every car, (E, N) [rad], ``off_line`` every car's
        offset from the racing line (``_off_line``), (E, N) [m]."""
        length = core.track.length
        car_len, car_wid = 0.5 * core.config.car.length, 0.5 * core.config.car.width
        gap = wrap_arcs(core.s - core.s[:, car : car + 1], length)
        valid = ~core.done
        valid[:, car] = False
        speed = np.where(core.racing, core.speed, 0.0)
        dd = -core.velocity[..., 0] * np.sin(psi) + core.velocity[..., 1] * np.cos(psi)
        # A car alongside leaves this one room, as the scripted drivers do (they keep a car
        # width and 0.15 m from a car within a car length and 0.15 m of them, ahead or
        # behind), as racing's rules ask once two cars overlap, and as the planner itself does
        # (_keep_room): its drift towards this one is not extrapolated. Extrapolated, a car
        # ahead turning in to its apex closed every pass on the inside that had drawn level.
        beside = np.abs(gap) < 2.0 * car_len + ROOM
        toward = (core.d - core.d[:, car : car + 1]) * dd < 0.0
        # One coming across faster than DRIFT_FAST is not trusted to stop in time: its drift
        # ends up extrapolated for DRIFT_TIME (the kernel moves a car by dd * LATERAL_PREVIEW
        # in all).
        fast = np.where(np.abs(dd) > DRIFT_FAST, dd * (DRIFT_TIME / kernel.LATERAL_PREVIEW), 0.0)
        dd = np.where(beside & toward, fast, dd)
        # A car that drives the racing line (racing_line, another planner) is predicted along
        # it (kernel._span), unless it is beside this one now: then it leaves room, as above.
        err = np.where((self._fit < LINE_FIT) & ~beside & core.racing, off_line, np.nan)
        lo = hi = core.d
        half_len = np.full(gap.shape, car_len)
        half_wid = np.full(gap.shape, car_wid)
        if core.num_bots:
            bot_gap = wrap_arcs(core.bot_s - core.s[:, car : car + 1], length)
            left, right = core.track.half_widths_at(core.bot_s)
            lane_d = core.bot_lane * 0.5 * np.where(core.bot_lane >= 0, left, right)
            gap = np.concatenate([gap, bot_gap], axis=1)
            lo = np.concatenate([lo, np.minimum(core.bot_d, lane_d)], axis=1)
            hi = np.concatenate([hi, np.maximum(core.bot_d, lane_d)], axis=1)
            speed = np.concatenate([speed, core.bot_speed], axis=1)
            dd = np.concatenate([dd, np.zeros(bot_gap.shape)], axis=1)
            half_len = np.concatenate([half_len, np.full(bot_gap.shape, car_len)], axis=1)
            half_wid = np.concatenate([half_wid, np.full(bot_gap.shape, car_wid)], axis=1)
            valid = np.concatenate([valid, np.ones(bot_gap.shape, dtype=bool)], axis=1)
            err = np.concatenate([err, np.full(bot_gap.shape, np.nan)], axis=1)
        return (np.ascontiguousarray(gap), np.ascontiguousarray(lo), np.ascontiguousarray(hi),
                np.ascontiguousarray(speed), np.ascontiguousarray(dd), half_len, half_wid,
                np.ascontiguousarray(valid), np.ascontiguousarray(err))

    def _defence(self, core: RaceCore, car: int, lanes: Lanes) -> FloatArray:
        """Lane bonus (E, NL) [s]: ``COVER_BONUS`` on the inside lane of the next corner,
        from when an attacker within ``cover_gap`` behind finds the car on that corner's
        approach (``Lanes.approach``, at most ``COVER_RANGE``) until its apex, once per
        corner."""
        e = core.num_envs
        bonus = np.zeros((e, lanes.offset.shape[0]))
        if core.num_cars < 2 or not len(lanes.apex_s) or self.cover_gap <= 0:
            return bonus
        length = lanes.length
        s = core.s[:, car]
        to_apex = np.remainder(lanes.apex_s[None, :] - s[:, None], length)
        upcoming = np.argmin(to_apex, axis=1)
        rows = np.arange(e)
        attacked, _ = self._attackers(core, car)
        near = to_apex[rows, upcoming] < np.minimum(COVER_RANGE, lanes.approach[upcoming])
        start = (self._cover < 0) & attacked & near & (upcoming != self._covered)
        self._cover = np.where(start, upcoming, self._cover)
        active = self._cover >= 0
        left = to_apex[rows, np.maximum(self._cover, 0)]
        done = active & ((left < 0.3) | (left > length - 2.0))
        self._covered = np.where(done, self._cover, self._covered)
        self._cover = np.where(done, -1, self._cover)
        active &= ~done
        lane = lanes.inside_lane[np.maximum(self._cover, 0)]
        bonus[rows[active], lane[active]] = COVER_BONUS
        return bonus
