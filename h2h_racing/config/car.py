"""The car's physical parameters (:class:`CarParams`): size, mass, tyres, steering and motor limits."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from h2h_racing.config.checks import _check, _finite_positive, _is_number


@dataclass(frozen=True, kw_only=True)
class CarParams:
    """Physical parameters of one 1/18-scale car (AWS DeepRacer geometry).

    Dimensions follow DeepRacer's simulator: the collision rectangle
    ``BOT_CAR_DIMENSION = (0.1961, 0.32352)`` and the URDF wheel positions
    (rear axle at x = -0.0817 m, front hinges at x = +0.0823 m, wheel track 0.16 m).
    """

    length: float = 0.3235
    """Body length [m] (collision box, along the car)."""
    width: float = 0.1961
    """Body width [m] (collision box, across the car)."""
    cg_to_front: float = 0.0823
    """Distance from the body origin (centre of mass) to the front axle, l_f [m]."""
    cg_to_rear: float = 0.0817
    """Distance from the body origin (centre of mass) to the rear axle, l_r [m]."""
    wheel_track: float = 0.16
    """Lateral distance between left and right wheel centres [m]."""
    mass: float = 1.5
    """Total mass [kg]."""
    max_steer: float = math.radians(30.0)
    """Steering limit [rad], symmetric (DeepRacer clips to +-30 deg)."""
    max_steer_rate: float = math.radians(360.0)
    """Steering servo rate limit [rad/s]."""
    max_speed: float = 4.0
    """Top commanded speed [m/s] (DeepRacer's actuator limit)."""
    max_accel: float = 3.0
    """Longitudinal acceleration limit of the speed controller [m/s^2].

    DeepRacer needs about 1.7 s to reach 4 m/s from standstill (about 2.4 m/s^2 average).
    """
    max_brake: float = 5.0
    """Longitudinal deceleration limit of the speed controller [m/s^2]."""
    speed_gain: float = 6.0
    """Proportional gain of the speed controller [1/s]: a_x = gain * (v_cmd - v_x), then limited."""
    friction: float = 1.0
    """Tyre-road friction coefficient mu (peak lateral force = mu * axle load)."""
    cornering_stiffness: float = 12.0
    """Normalised cornering stiffness per axle [1/rad]: C_alpha = value * axle load [N/rad]."""
    body_friction: float = 0.5
    """Coulomb friction between car bodies and obstacles in contacts (pymunk)."""
    body_elasticity: float = 0.2
    """Restitution of car-car and car-obstacle contacts (pymunk)."""

    def __post_init__(self) -> None:
        owner = type(self).__name__
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "body_elasticity":
                _check(_is_number(value) and 0.0 <= value <= 1.0, owner, f.name, value,
                       "a number in [0, 1]")
            elif f.name == "body_friction":
                _check(_is_number(value) and 0.0 <= value, owner, f.name, value,
                       "a number >= 0")
            else:
                _finite_positive(owner, f.name, value)
        _check(self.max_steer < math.pi / 2, owner, "max_steer", self.max_steer, "< pi/2 rad")

    @property
    def wheelbase(self) -> float:
        """Front-to-rear axle distance L = l_f + l_r [m]."""
        return self.cg_to_front + self.cg_to_rear

    @property
    def yaw_inertia(self) -> float:
        """Yaw moment of inertia of a uniform box, m (l^2 + w^2) / 12 [kg m^2]."""
        return self.mass * (self.length**2 + self.width**2) / 12.0
