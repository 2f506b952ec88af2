"""Steering round the boxes of ``object_avoidance`` races, for the scripted drivers.

A scripted driver reads the true state (like DeepRacer's bot cars), here each box's arc
position ``core.obstacle_s`` and lateral offset ``core.obstacle_d`` (boxes stand along their
lane, ``obstacle_length`` along it and ``obstacle_width`` across). :func:`avoid_obstacles`
bends the driver's lateral target round every box near the car:

* each box is passed on the side with more room between it and the border;
* while the car's body overlaps the box along the track, its centre must stay at least
  ``obstacle_width / 2 + car.width / 2 + clearance`` from the box's centre line, on that
  side, plus, on the outside of a bend, how far the straight box's ends stick out of its
  curved lane (0.09 m in a 0.5 m corner), and ``EDGE`` inside the border (on a narrow track
  the outer wheels may cross the border: a car is off track only with all four wheels off);
* the lateral target moves over to that side along a smoothstep ramp of ``approach`` metres
  before the box (and back over ``departure`` metres after it), so the path's extra
  curvature stays near ``3 dy / approach^2`` (a lateral move dy of 0.4 m over 2 m: 0.3 1/m);
* near a box the speed command is capped at ``speed_cap`` (the detour is not on the racing
  line, and its speed profile does not know the detour), and, where the car still has to move
  across by ``dy`` before the box's front ``D`` ahead (two boxes close together in opposite
  lanes make a tight slalom), at ``D sqrt(a_lat / (2 dy))``, the speed at which a parabolic
  move across stays within the lateral acceleration ``a_lat``;
* round a box on a bend, at ``sqrt(bend_grip mu g / k)``, with ``k`` the largest curvature of
  the passing path (the lane at the passing offset) from the start of the approach ramp to the
  box's end, the part behind the car left out: on the inside it is tighter than the racing
  line the speed profile was made for, and the car slid into boxes in 0.5 m corners, and ran
  wide into boxes just past a corner it rounded on that offset.

The ramp is evaluated at the pursuit target (ahead of the car) for the way in and at the car's
front for the way out, so the body clears the box before the target moves back. Boxes are
handled nearest last, so where two boxes' ramps overlap the nearer one decides.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from h2h_racing.policies.racing_line import GRAVITY
from h2h_racing.track.lookup import wrap_arcs

if TYPE_CHECKING:
    from h2h_racing.sim.core import RaceCore

FloatArray = npt.NDArray[np.float64]

EDGE = 0.03
"""Distance kept between the car's centre and the border when passing a box [m]."""
KINK = 0.03
"""Smallest jump of the track's heading between points 2 cm apart that counts as a coarse
waypoint's corner (the shipped tracks' largest is 0.007; DeepRacer's routes have 0.1-0.6
by their boxes) [rad]."""
PATH_SAMPLES = 41
"""Points at which the passing path's curvature is read, from the start of a box's approach
ramp to the end of the box's overlap with the car's body (about 6 cm apart)."""


def _smoothstep(x: FloatArray) -> FloatArray:
    """``3x^2 - 2x^3`` on [0, 1], clamped outside."""
    t = np.clip(x, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _presence(x: FloatArray, front: FloatArray, back: FloatArray, approach: float,
              departure: float) -> FloatArray:
    """1 on ``[front, back]``, smoothstep ramps of ``approach`` before and ``departure`` after,
    0 elsewhere (all arc positions relative to the car, same shape)."""
    rise = _smoothstep((x - (front - approach)) / approach)
    fall = 1.0 - _smoothstep((x - back) / departure)
    return np.where(x < front, rise, np.where(x > back, fall, 1.0))


def bend_protrusion(curvature: FloatArray, box_d: FloatArray,
                     half_len: float) -> tuple[FloatArray, FloatArray]:
    """How far a box's ends reach beyond its sides' lines on a bend, to the left and to the
    right of the lane (each >= 0, same shape as ``box_d``) [m].

    The box lies along the tangent of its lane at its centre. The lane at offset ``d`` of a
    centre line of curvature ``k`` (left positive) has curvature ``k_l = k / (1 - k d)``, radius
    ``R = 1 / |k_l|``; an end ``h = half_len`` along the tangent is ``sqrt(R^2 + h^2)`` from
    the bend's centre, so it sticks out by ``sqrt(R^2 + h^2) - R = h^2 |k_l| / (1 +
    sqrt(1 + (h k_l)^2))``, on the side away from the centre: the right on a left-hander.
    """
    k_lane = curvature / np.maximum(1.0 - curvature * box_d, 0.1)
    out = half_len * half_len * np.abs(k_lane) / (1.0 + np.sqrt(1.0 + (half_len * k_lane) ** 2))
    return np.where(k_lane < 0.0, out, 0.0), np.where(k_lane > 0.0, out, 0.0)


def avoid_obstacles(core: RaceCore, car: int, s_target: FloatArray, offset: FloatArray,
                    speed: FloatArray, *, clearance: float = 0.1, approach: float = 1.6,
                    departure: float = 0.4, speed_cap: float = 2.2,
                    lateral_accel: float = 0.4, min_speed: float = 0.6,
                    bend_grip: float = 0.6, edge: float = EDGE,
                    edge_room: float | None = None) -> tuple[FloatArray, FloatArray]:
    """Bend the lateral target of car ``car`` round the boxes near it (see the module docstring).

    Args:
        core: The simulation core (true state).
        car: The car index.
        s_target: Arc position of the pursuit target in each env copy, shape (E,) [m].
        offset: Lateral target offset the driver wants there, shape (E,) [m], left positive.
        speed: Speed command the driver wants, shape (E,) [m/s].
        clearance: Gap kept between the car's side and the box's side [m].
        approach: Length of the ramp onto the passing side before a box [m].
        departure: Length of the ramp back after a box [m].
        speed_cap: Highest speed command within the ramps of a box [m/s].
        lateral_accel: Lateral acceleration budget of a move across to a box's passing
            side, as a fraction of ``mu g``.
        min_speed: Lowest speed command the move-across limit gives [m/s].
        bend_grip: Lateral acceleration budget round a box on a bend, on the passing path's
            radius, as a fraction of ``mu g``.
        edge: Distance kept between the car's centre and the border beside a box [m]; where
            the clearance does not fit, this decides the gap to the box. Negative: the centre
            outside the border (the car is on track while a wheel is: 0.08 m either side).
        edge_room: Where given, ``edge`` holds only beside the boxes whose room on the passing
            side (box side to border, as ``room_left``/``room_right`` below) is under it [m];
            beside the others the centre keeps ``EDGE``. None: ``edge`` beside every box.

    Returns:
        ``(offset, speed)``, each shape (E,).
    """
    if core.num_obstacles == 0:
        return offset, speed
    cfg = core.config
    params = cfg.car
    length = core.track.length
    s_car = core.s[:, car]
    half_body = 0.5 * params.length
    # Arc position of each box relative to the car, wrapped to (-L/2, L/2].
    gap = wrap_arcs(core.obstacle_s - s_car[:, None], length)
    half_len = 0.5 * cfg.obstacle_length
    # Where the body overlaps the box along the track, 5 cm to spare (relative to the car).
    front = gap - half_len - half_body - 0.05
    back = gap + half_len + half_body + 0.05
    # The target's and the car's front arc positions, relative to the car.
    ahead = np.remainder(s_target - s_car, length)[:, None]
    hold = np.full_like(ahead, half_body)
    near = (back + departure > 0.0) & (front - approach < ahead)
    if not near.any():
        return offset, speed
    presence = np.maximum(_presence(ahead, front, back, approach, departure),
                          _presence(hold, front, back, approach, departure))
    presence = np.where(near, presence, 0.0)
    left, right = core.track.half_widths_at(core.obstacle_s)
    box_d = core.obstacle_d
    half_w = 0.5 * cfg.obstacle_width
    # A straight box on a bend: its ends stick out of its lane towards the outside.
    out_left, out_right = bend_protrusion(core.track.curvature_at(core.obstacle_s), box_d,
                                          half_len)
    room_left = left - (box_d + half_w + out_left)
    room_right = (box_d - half_w - out_right) + right
    side = np.where(room_left >= room_right, 1.0, -1.0)
    # Where the track is drawn through a coarse waypoint by the box, its heading jumps there by
    # the whole corner and the box lies along one segment: the car passes it turned to it by
    # up to those corners, its ends swinging out by half its length times the sine of them.
    # (On a finely drawn bend the jumps are under a hundredth of a radian: no swing.)
    # Only the boxes near a car are looked at: the others' bounds are not used.
    along = np.linspace(-1.0, 1.0, 41) * (half_len + half_body)
    heading = core.track.heading_at(core.obstacle_s[near][:, None] + along)
    jump = np.abs(np.remainder(np.diff(heading, axis=-1) + np.pi, 2.0 * np.pi) - np.pi)
    kink = np.where(jump > KINK, jump, 0.0).sum(axis=-1)
    swing = np.zeros(near.shape)
    swing[near] = half_body * np.sin(np.minimum(kink, 0.5 * np.pi))
    need = (half_w + 0.5 * params.width + clearance + np.where(side > 0, out_left, out_right)
            + swing)
    # Beside a box on a narrow track the car may put its outer wheels over the border (it is
    # off track only with all four off), keeping its centre `edge` inside.
    if edge_room is not None:
        # Only the tight boxes get the given edge: the labels beside the ordinary boxes of a
        # narrow track stay where EDGE puts them (step 10 of obstacle_generalist: an edge at
        # every clipped box taught the student to ride the border on the open track too).
        passing_room = np.where(side > 0, room_left, room_right)
        edge = np.where(passing_room < edge_room, edge, EDGE)
    bound = np.clip(box_d + side * need, -right + edge, left - edge)
    out = np.asarray(offset, dtype=np.float64).copy()
    rows = np.arange(core.num_envs)
    # Nearest box last: it decides where ramps overlap (a loop over the K boxes, not the cars).
    for k in np.argsort(-np.abs(gap), axis=1).T:
        f = presence[rows, k]
        b = bound[rows, k]
        wrong = np.where(side[rows, k] > 0, out < b, out > b)
        out = np.where(wrong, out + f * (b - out), out)
    capped = np.where(presence.max(axis=1) > 0.0, np.minimum(speed, speed_cap), speed)
    # Round a box on a bend the detour's radius is the lane's at the passing offset, tighter
    # than the racing line's on the inside: keep v^2 |k| within bend_grip of mu g there. The
    # car is steered onto that offset over the approach ramp, so a bend it rounds on its way
    # to the box counts too, not only the box's own (boxes 1-1.5 m past 0.55-0.75 m corners on 3
    # DeepRacer routes: the car took the corner's inside at the box's own bend speed, ran
    # wide and hit the box). The path behind the car's rear no longer matters.
    along = np.linspace(-(half_len + half_body + 0.05 + approach), half_len + half_body,
                        PATH_SAMPLES)
    ahead_of_rear = gap[near][:, None] + along >= -half_body
    k_near = core.track.curvature_at(core.obstacle_s[near][:, None] + along)
    k_lane = np.abs(k_near / np.maximum(1.0 - k_near * bound[near][:, None], 0.1))
    k_path = np.zeros(near.shape)
    k_path[near] = np.where(ahead_of_rear, k_lane, 0.0).max(axis=-1)
    v_bend = np.sqrt(bend_grip * params.friction * GRAVITY / np.maximum(k_path, 1e-6))
    capped = np.minimum(capped, np.where(presence > 0.0, v_bend, np.inf).min(axis=1))
    # Slow down where the car must still move over by dy before a box's front, D ahead: a
    # parabolic move of dy over D curves at 2 dy / D^2, so v <= D sqrt(a_lat / (2 dy)).
    my_d = core.d[:, car][:, None]
    still = np.maximum(side * (bound - my_d), 0.0)
    room = np.maximum(front, 0.05)
    a_lat = lateral_accel * params.friction * GRAVITY
    feasible = room * np.sqrt(a_lat / np.maximum(2.0 * still, 1e-9))
    feasible = np.where(near & (back > 0.0) & (still > 0.02), feasible, np.inf)
    capped = np.minimum(capped, np.maximum(feasible.min(axis=1), min_speed))
    return out, capped
