"""Path tracking near the grip limit: the planner's steering and speed safety.

The planner's kernel keeps a path as an offset ``d_p(s)`` from the centre line (a lane, or a
blend onto one) and reports its offset, slope ``d_p'`` and curvature ``kappa_p`` at the car's
arc position and a short preview ahead. The steering commands a curvature: the path's, plus
linear feedback on the car's offset and heading errors (the kinematic Frenet-frame law of
path-following control, e.g. De Luca, Oriolo and Samson, *Feedback control of a
nonholonomic car-like robot*, 1998, sec. 4, linearised):

    e       = d - d_p(s)                                 offset error [m]
    theta   = (psi + b beta) - psi_c(s) - atan(d_p' / (1 - kappa_c d_p))
                                                          heading error [rad]
    kappa   = kappa_p(s + v tau) - k_e e - k_theta sin(theta)

which, with ``e' = sin(theta)`` and ``theta' = kappa - kappa_p``, closes the errors as
``e'' + k_theta e' + k_e e = 0`` per metre driven. The car model is neutral steer
(``l_f C_f = l_r C_r``), so the kinematic angle ``delta = atan(L kappa)`` holds up to the grip
limit, as in pure pursuit; a yaw-rate damper counter-steers ``YAW_DAMPING (r - v kappa)``.

Why not pure pursuit: it steers at a point on the path a look-ahead away, so its curvature
lags the path's on entry and exit of every bend; near the grip limit that lag is what slides
the car. With the path's own curvature as feed-forward the planner laps every shipped track,
50 random ones and the 40 DeepRacer routes of ../shared/data clean alone at every grip up to
``mu g`` (pure pursuit: 0.65; at 0.85 it left 8 of the 7 shipped and 20 random tracks).

``beta`` is the car's sideslip (its course minus its heading). Only half of it (``b =
SLIP_SHARE``) enters the heading error: the sideslip answers a steering change within one
control step, so the whole of it closes a loop at the step rate (the steering alternated
step by step, and the car slid off in chicanes of random tracks); none of it lets the car
drift wide at the limit.

The steering moves ``STEER_SMOOTH`` of the way from its present angle to that one each step.

A commanded curvature the tyres cannot give at the car's speed is met by braking: the speed
command is at most ``sqrt(SPEED_GRIP mu g / |kappa|)`` (braking does not take lateral grip
in this car model). So is a slide: a yaw rate ``SLIDE_RATE`` above the commanded one means
both axles are at their limit (the yaw rate then stays put whatever the steering does), and
the car brakes until it grips again.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from h2h_racing.sim.dynamics import GRAVITY

if TYPE_CHECKING:
    from h2h_racing.sim.core import RaceCore

FloatArray = npt.NDArray[np.float64]

OFFSET_GAIN = 2.0
"""``k_e``: commanded curvature per metre of offset error [1/m^2]."""
HEADING_GAIN = 2.5
"""``k_theta``: commanded curvature per unit of ``sin(theta)`` [1/m]. With ``OFFSET_GAIN``
the errors decay like a second-order system of ``sqrt(2)`` rad/m and damping 0.88 per metre
driven. Alone at grip 0.85 on the shipped and 20 random tracks (10 starts each), 1.5-3.5 and
1-4 left 2-5 tracks unclean when the whole sideslip entered the heading error; these are the
middle of that range."""
SLIP_SHARE = 0.5
"""``b``: share of the sideslip in the heading error. Alone on the shipped and 20 random
tracks (10 starts each, measured before ``STEER_SMOOTH``): 1 left ``random:7`` unclean at
every grip from 0.65 to 0.95, 0 left one or two tracks at 0.8 and 0.85, 0.25 and 0.5 none at
0.8 and 0.9; on 40 more random tracks, 0.25 and 0.5 none at 0.85 and 0.95 (0.5 the faster
laps: 1.024 x the minimum-time reference at 0.85)."""
CURVATURE_PREVIEW = 0.05
"""``tau``: the path's curvature is read this far ahead of the car [s], about the steering's
lag within a control step."""
YAW_DAMPING = 0.1
"""Counter-steer per rad/s of yaw rate above the commanded one [s] (as with pure pursuit)."""
STEER_SMOOTH = 0.7
"""Share of the step from the present steering angle to the computed one that is commanded.
The yaw rate answers the steering within a control step, so the damper and the heading
feedback close a loop at the step rate; at full share the steering alternated step by step
on routes with uneven curvature. Alone on the shipped, 20 random and 30 hard random tracks
(narrow, chicanes, tight circuits; 10 starts each), at grips 0.7 and 0.95: 1.0 left 2 and 1
tracks unclean, 0.7 none; 0.5 left 3 at 0.95."""
SLIDE_RATE = 1.0
"""Yaw rate above the commanded one [rad/s] at which the car is taken to slide: both axles
at their grip limit, the yaw rate stuck, steering without effect. It then brakes. Alone on
the shipped, 20 random and 30 hard random tracks at grip 0.8 (10 starts each): without it 3
tracks unclean (10 off-tracks), 1 none, 0.5 none but 2 % slower laps."""
SLIDE_BRAKE = 1.0
"""Speed command below the present speed while sliding [m/s] (the speed controller brakes
at up to ``speed_gain`` times that)."""
SPEED_GRIP = 0.95
"""Share of ``mu g`` the commanded curvature may take at the commanded speed."""


def preview(speed: FloatArray, look: FloatArray) -> FloatArray:
    """Arc distances ahead of the car [m] where the kernel reports the path, (E, 2): the car's
    own position and the curvature preview (within the steering look-ahead ``look``)."""
    return np.stack([np.zeros_like(speed),
                     np.minimum(CURVATURE_PREVIEW * speed, look - 0.05)], axis=1)


def track_path(core: RaceCore, car: int, curvature_c: FloatArray, heading_error: FloatArray,
               path: FloatArray, speed_command: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Steering angle [rad] and speed command [m/s], each (E,), that hold car ``car`` on
    its path.

    Args:
        core: The simulation core.
        car: The car driven.
        curvature_c: Centre-line curvature at the car [1/m], (E,).
        heading_error: The car's heading minus the centre line's [rad], (E,), in (-pi, pi].
        path: The kernel's report at ``preview``'s distances, (E, 2, 3): offset [m], slope
            and curvature [1/m] of the path.
        speed_command: The plan's speed command [m/s], (E,).
    """
    params = core.config.car
    velocity = core.velocity[:, car]
    speed = core.speed[:, car]
    yaw = core.yaw[:, car]
    course = np.arctan2(velocity[:, 1], velocity[:, 0])
    slip = np.remainder(course - yaw + math.pi, 2.0 * math.pi) - math.pi
    slip = np.where(speed > 0.5, slip, 0.0)  # a standing car has no course
    path_angle = np.arctan(path[:, 0, 1] / np.maximum(1.0 - curvature_c * path[:, 0, 0], 0.2))
    theta = heading_error + SLIP_SHARE * slip - path_angle
    offset_error = core.d[:, car] - path[:, 0, 0]
    kappa = path[:, 1, 2] - OFFSET_GAIN * offset_error - HEADING_GAIN * np.sin(theta)
    steer = (np.arctan(params.wheelbase * kappa)
             - YAW_DAMPING * (core.yaw_rate[:, car] - speed * kappa))
    steer = core.steer[:, car] + STEER_SMOOTH * (steer - core.steer[:, car])
    grip = SPEED_GRIP * params.friction * GRAVITY
    command = np.minimum(speed_command, np.sqrt(grip / np.maximum(np.abs(kappa), 1e-6)))
    sliding = np.abs(core.yaw_rate[:, car]) > np.abs(speed * kappa) + SLIDE_RATE
    return steer, np.where(sliding, np.minimum(command, speed - SLIDE_BRAKE), command)
