"""Frozen, validated configuration dataclasses.

Every physical quantity is SI (metres, seconds, radians, kilograms) unless its
docstring says otherwise. Configs are immutable: derive a variant with
``dataclasses.replace``. ``EnvConfig.from_dict`` rejects unknown keys.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

RaceType = Literal["time_trial", "head_to_head", "object_avoidance", "head_to_bot"]
RuleMode = Literal["training", "race"]
ActionType = Literal["continuous", "discrete"]
Ranking = Literal["total_time", "best_lap"]

RACE_TYPES: tuple[str, ...] = ("time_trial", "head_to_head", "object_avoidance", "head_to_bot")
MAX_BOTS = 12
"""Most bot cars per env copy (DeepRacer's community races allow 6; the league qualifier runs 6)."""
SENSORS: tuple[str, ...] = ("state", "camera", "lidar")
RULE_MODES: tuple[str, ...] = ("training", "race")


def _check(condition: bool, owner: str, name: str, value: Any, allowed: str) -> None:
    """Raise a ValueError naming the field, the value and what is allowed."""
    if not condition:
        raise ValueError(f"{owner}.{name} must be {allowed}, got {value!r}")


def _is_int(value: Any) -> bool:
    """Whether ``value`` is an int (a bool is not a count, though Python calls it an int)."""
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    """Whether ``value`` is an int or a float (not a bool, a string or None)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _finite_positive(owner: str, name: str, value: float) -> None:
    _check(
        _is_number(value) and math.isfinite(value) and value > 0,
        owner,
        name,
        value,
        "a finite number > 0",
    )


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


@dataclass(frozen=True, kw_only=True)
class RaceRules:
    """Race rules: what an infraction does, when a race ends, how it is ranked.

    ``mode="training"`` ends a car's episode at its first infraction (DeepRacer training);
    ``mode="race"`` freezes the car for a time penalty while the clock runs and then
    re-places it on the nearest lane at its last valid progress (DeepRacer evaluation), on the
    first spot there or up to 3.5 m back whose box clears every other body by 7 cm; with none
    clear it stays frozen, parked off the track, until one is (``h2h_racing.replacement``).
    """

    mode: RuleMode = "race"
    """``"training"`` or ``"race"``."""
    laps: int = 3
    """Lap target; a car that completes it has finished. 0 means no lap target."""
    time_limit: float = 180.0
    """Simulated seconds after which the race (episode) is truncated; ``math.inf`` for none."""
    ranking: Ranking = "total_time"
    """``"total_time"`` (laps first, then time) or ``"best_lap"`` (best valid lap time)."""
    off_track_penalty: float = 5.0
    """Seconds a car stays frozen after going off track (race mode)."""
    crash_penalty: float = 5.0
    """Seconds a car stays frozen after a crash it is judged to have caused (race mode)."""
    reversed_penalty: float = 5.0
    """Seconds a car stays frozen after driving the wrong way (race mode)."""
    immobilised_penalty: float = 5.0
    """Seconds a car stays frozen after being immobilised (race mode)."""
    max_resets_per_lap: int | None = None
    """A lap with more resets than this is void (not a valid lap); None for no limit."""
    crash_is_infraction: bool = True
    """Whether a crash counts as an infraction for the car judged at fault."""
    reversed_steps: int = 15
    """Consecutive steps of decreasing progress that make a car 'reversed' (DeepRacer: 15)."""
    immobilised_steps: int = 15
    """Consecutive steps of no movement that make a car 'immobilised' (DeepRacer: 15)."""
    immobilised_distance: float = 0.003
    """A car that moves at most this far in one step [m] counts as not moving."""
    defence_gap: float = 1.0
    """An attacker closer than this behind a car [m of track] puts it under pressure."""
    defence_time: float = 2.0
    """Seconds of pressure, without being passed, that make a defence [s]."""

    def __post_init__(self) -> None:
        owner = type(self).__name__
        _check(self.mode in RULE_MODES, owner, "mode", self.mode, f"one of {RULE_MODES}")
        _check(self.ranking in ("total_time", "best_lap"), owner, "ranking", self.ranking,
               "'total_time' or 'best_lap'")
        _check(_is_int(self.laps) and self.laps >= 0, owner, "laps", self.laps,
               "an int >= 0")
        _check(_is_number(self.time_limit) and self.time_limit > 0, owner, "time_limit",
               self.time_limit, "a number > 0 (math.inf allowed)")
        _check(self.laps > 0 or math.isfinite(self.time_limit), owner, "time_limit",
               self.time_limit, "finite when laps == 0 (otherwise the race never ends)")
        for name in ("off_track_penalty", "crash_penalty", "reversed_penalty",
                     "immobilised_penalty"):
            value = getattr(self, name)
            _check(_is_number(value) and math.isfinite(value) and value >= 0, owner, name,
                   value, "a finite number >= 0")
        _check(self.max_resets_per_lap is None
               or (_is_int(self.max_resets_per_lap) and self.max_resets_per_lap >= 0), owner,
               "max_resets_per_lap", self.max_resets_per_lap, "None or an int >= 0")
        _check(isinstance(self.crash_is_infraction, bool), owner, "crash_is_infraction",
               self.crash_is_infraction, "a bool")
        for name in ("reversed_steps", "immobilised_steps"):
            _check(_is_int(getattr(self, name)) and getattr(self, name) >= 1, owner, name,
                   getattr(self, name), "an int >= 1")
        for name in ("immobilised_distance", "defence_gap", "defence_time"):
            _finite_positive(owner, name, getattr(self, name))

    @classmethod
    def preset(cls, race_type: str, mode: str = "race") -> RaceRules:
        """Return the rules of a race type.

        ``time_trial``: 4 minutes, best valid lap, a lap with more than 3 resets is void
        (DeepRacer physical-event format). ``head_to_head``, ``object_avoidance`` and
        ``head_to_bot``: 3 laps, total time, 5 s penalties (DeepRacer league format), 180 s
        limit.
        ``mode="training"`` keeps the limits but ends a car's episode at its first
        infraction and at one lap.
        """
        if race_type not in RACE_TYPES:
            raise ValueError(f"race_type must be one of {RACE_TYPES}, got {race_type!r}")
        if mode not in RULE_MODES:
            raise ValueError(f"rules must be one of {RULE_MODES} or a RaceRules, got {mode!r}")
        if race_type == "time_trial":
            rules = cls(laps=0, time_limit=240.0, ranking="best_lap", max_resets_per_lap=3)
        else:
            rules = cls(laps=3, time_limit=180.0, ranking="total_time")
        if mode == "training":
            rules = dataclasses.replace(rules, mode="training", laps=1,
                                        time_limit=min(rules.time_limit, 120.0))
        return rules


@dataclass(frozen=True, kw_only=True)
class RewardConfig:
    """Weights of the built-in reward terms (each term is reported in ``infos``)."""

    progress: float = 1.0
    """Per metre of track progress along the centre line (negative when driving backwards)."""
    speed: float = 0.0
    """Per (m/s of forward speed) per step."""
    off_track: float = -5.0
    """On a step where the car goes off track (all four wheels off)."""
    crash: float = -5.0
    """On a step where the car is judged at fault in a crash."""
    contact: float = 0.0
    """On a step where the car is in a new contact with another car, a bot or an obstacle, at
    fault or not (DeepRacer's judging pays a car for being run into; see ``rewards``)."""
    overtake: float = 1.0
    """Per car passed on track; the car passed gets the negative."""
    lap: float = 0.0
    """On completing a lap."""
    time: float = 0.0
    """Per step (use a negative value to reward finishing early)."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            _check(_is_number(value) and math.isfinite(value), "RewardConfig",
                   f.name, value, "a finite number")


def _camera_fail(name: str, value: object, expected: str) -> None:
    raise ValueError(f"CameraConfig.{name} must be {expected}, got {value!r}; fix the value "
                     f"passed to CameraConfig")


@dataclass(frozen=True, kw_only=True)
class CameraConfig:
    """Where the camera sits, what it resolves and how frames are produced.

    The defaults reproduce DeepRacer's ``FRONT_FACING_CAMERA`` observation (160 x 120
    greyscale, stack 1); ``stereo=True`` gives ``STEREO_CAMERAS`` (two channels).
    """

    width: int = 160
    """Image width [px]."""
    height: int = 120
    """Image height [px]."""
    stereo: bool = False
    """Two cameras side by side (channel 0 left, 1 right) instead of one."""
    stereo_baseline_m: float = 0.06
    """Distance between the two optical centres with ``stereo`` [m]."""
    frame_stack: int = 1
    """Frames per observation, oldest first; a new episode repeats its first frame."""
    height_m: float = 0.13
    """Height of the optical centre above the ground [m]."""
    forward_m: float = 0.145
    """Distance of the optical centre ahead of the car's origin [m]."""
    pitch_deg: float = 15.0
    """Downward pitch of the optical axis [deg]."""
    hfov_deg: float = 64.7
    """Horizontal field of view [deg]; the vertical one follows from square pixels."""
    near_m: float = 0.02
    """Near clipping distance along the optical axis [m] (Gazebo's clip)."""
    texture_resolution_m: float = 0.01
    """Size of one ground-texture pixel [m/px]."""
    max_texture_px: int = 8192
    """Largest ground-texture side [px]; a larger track gets a coarser resolution."""
    interpolation: Literal["linear", "nearest"] = "linear"
    """Ground-texture sampling (bilinear is smoother, nearest is a little faster)."""
    car_height_m: float = 0.12
    """Height of the car boxes [m]."""
    obstacle_height_m: float = 0.2
    """Height of the obstacle boxes [m]."""

    def __post_init__(self) -> None:
        for name in ("width", "height", "frame_stack", "max_texture_px"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool):
                _camera_fail(name, value, "an int")
        if not 8 <= self.width <= 4096:
            _camera_fail("width", self.width, "in [8, 4096] px")
        if not 8 <= self.height <= 4096:
            _camera_fail("height", self.height, "in [8, 4096] px")
        if not 1 <= self.frame_stack <= 32:
            _camera_fail("frame_stack", self.frame_stack, "in [1, 32]")
        if not 64 <= self.max_texture_px <= 32767:
            _camera_fail("max_texture_px", self.max_texture_px, "in [64, 32767] (OpenCV's limit)")
        if not isinstance(self.stereo, bool):
            _camera_fail("stereo", self.stereo, "a bool")
        for name in ("stereo_baseline_m", "height_m", "near_m", "texture_resolution_m",
                     "car_height_m", "obstacle_height_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                _camera_fail(name, value, "a finite number > 0")
        if not (isinstance(self.forward_m, (int, float)) and math.isfinite(self.forward_m)):
            _camera_fail("forward_m", self.forward_m, "a finite number")
        if not -80.0 <= self.pitch_deg <= 80.0:
            _camera_fail("pitch_deg", self.pitch_deg, "in [-80, 80] deg")
        if not 1.0 <= self.hfov_deg <= 170.0:
            _camera_fail("hfov_deg", self.hfov_deg, "in [1, 170] deg")
        if self.interpolation not in ("linear", "nearest"):
            _camera_fail("interpolation", self.interpolation, "'linear' or 'nearest'")

    @property
    def cameras(self) -> int:
        """Cameras per car: 2 with ``stereo``, else 1."""
        return 2 if self.stereo else 1

    @property
    def channels(self) -> int:
        """Channels of an observation: ``cameras * frame_stack``."""
        return self.cameras * self.frame_stack

    @property
    def focal_px(self) -> float:
        """Focal length in pixels, ``fx = fy = (W / 2) / tan(hfov / 2)``."""
        return 0.5 * self.width / math.tan(math.radians(0.5 * self.hfov_deg))

    @property
    def horizon_row(self) -> float:
        """Image row of the horizon, ``cy - fy tan(pitch)`` (may lie outside the image)."""
        return 0.5 * (self.height - 1) - self.focal_px * math.tan(math.radians(self.pitch_deg))

    def to_dict(self) -> dict[str, object]:
        """Return a plain, JSON-serialisable dict of this config."""
        return dataclasses.asdict(self)


LIDAR_MAX_RANGE = 12.0
"""Longest allowed ``LidarConfig.max_range`` [m] (DeepRacer's simulated hardware)."""


def _lidar_fail(name: str, value: object, expected: str) -> None:
    raise ValueError(f"LidarConfig.{name} must be {expected}, got {value!r}; fix the value "
                     f"passed to LidarConfig")


@dataclass(frozen=True, kw_only=True)
class LidarConfig:
    """Beams, ranges, noise and mode of the lidar (defaults: DeepRacer's ``LIDAR``)."""

    beams: int = 64
    """Number of beams B."""
    fov_deg: float = 300.0
    """Angle from the first to the last beam [deg] (+-150 deg)."""
    min_range: float = 0.15
    """Shortest reading [m]; nearer hits read this."""
    max_range: float = 1.0
    """Longest reading [m] (DeepRacer clips to 1.0 for the network; at most 12)."""
    noise_std: float = 0.0
    """Standard deviation of the Gaussian range noise [m] (DeepRacer's Gazebo: 0.01)."""
    mode: Literal["lidar", "sector_lidar"] = "lidar"
    """``"lidar"``: B ranges; ``"sector_lidar"``: ``sectors`` binary flags."""
    sectors: int = 8
    """Sectors of ``"sector_lidar"`` (must divide ``beams``)."""
    sector_clip: float = 0.5
    """A sector reads 1 when something is nearer than this [m]."""
    mount_forward_m: float = 0.0
    """Position of the scanner ahead of the car's origin [m]."""
    mount_left_m: float = 0.0
    """Position of the scanner left of the car's axis [m]."""

    def __post_init__(self) -> None:
        for name in ("beams", "sectors"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or not 1 <= value <= 4096:
                _lidar_fail(name, value, "an int in [1, 4096]")
        for name in ("fov_deg", "min_range", "max_range", "noise_std", "sector_clip",
                     "mount_forward_m", "mount_left_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                _lidar_fail(name, value, "a finite number")
        if not 0.0 < self.fov_deg <= 360.0:
            _lidar_fail("fov_deg", self.fov_deg, "in (0, 360] deg")
        if not 0.0 <= self.min_range < self.max_range <= LIDAR_MAX_RANGE:
            _lidar_fail("min_range/max_range", (self.min_range, self.max_range),
                  f"0 <= min_range < max_range <= {LIDAR_MAX_RANGE} m")
        if self.noise_std < 0.0:
            _lidar_fail("noise_std", self.noise_std, ">= 0 m")
        if self.mode not in ("lidar", "sector_lidar"):
            _lidar_fail("mode", self.mode, "'lidar' or 'sector_lidar'")
        if self.beams % self.sectors:
            _lidar_fail("sectors", self.sectors, f"a divisor of beams ({self.beams})")
        if not 0.0 < self.sector_clip <= LIDAR_MAX_RANGE:
            _lidar_fail("sector_clip", self.sector_clip, f"in (0, {LIDAR_MAX_RANGE}] m")

    @property
    def size(self) -> int:
        """Length of one observation: ``beams`` or ``sectors``."""
        return self.beams if self.mode == "lidar" else self.sectors

    @property
    def angles(self) -> FloatArray:
        """Bearing of each beam from the car's heading, (B,) [rad], CCW positive."""
        half = 0.5 * math.radians(self.fov_deg)
        if self.beams == 1:
            return np.zeros(1)
        return np.linspace(-half, half, self.beams)

    def to_dict(self) -> dict[str, object]:
        """Return a plain, JSON-serialisable dict of this config."""
        return dataclasses.asdict(self)


DEFAULT_DISCRETE_ACTIONS: tuple[tuple[float, float], ...] = tuple(
    (steer, speed) for steer in (-30.0, -15.0, 0.0, 15.0, 30.0) for speed in (1.0, 2.0, 3.0)
)
"""DeepRacer console style (steering 5 values in [-30, 30] deg) x (speed 3 values up to 3 m/s)."""


@dataclass(frozen=True, kw_only=True)
class EnvConfig:
    """Everything that defines an environment, apart from the track geometry itself."""

    track: str = "speedway"
    """Catalogue name or path of a track file (.json, .npy, .csv)."""
    num_cars: int = 2
    """Number of cars (agents ``car_0`` ... ``car_{N-1}``)."""
    race_type: RaceType = "head_to_head"
    """``"time_trial"``, ``"head_to_head"``, ``"object_avoidance"`` or ``"head_to_bot"``."""
    rules: RaceRules | None = None
    """Race rules; None takes ``RaceRules.preset(race_type)``."""
    car: CarParams = field(default_factory=CarParams)
    """Car parameters, shared by every car."""
    reward: RewardConfig = field(default_factory=RewardConfig)
    """Weights of the built-in reward."""
    action_type: ActionType = "continuous"
    """``"continuous"``: Box([-1, 1]^2) = (steer, speed); ``"discrete"``: an index into
    ``discrete_actions``."""
    min_speed: float = 0.5
    """Commanded speed for a speed action of -1 [m/s]."""
    max_speed: float = 4.0
    """Commanded speed for a speed action of +1 [m/s]; at most ``car.max_speed``."""
    min_steer_deg: float | None = None
    """Commanded steering for a steer action of -1 [deg, left positive]; None (with
    ``max_steer_deg`` None) means ``-car.max_steer``. DeepRacer's continuous action spaces
    map [-1, 1] linearly to [low, high] (``ScalableBoxActionSpace``)."""
    max_steer_deg: float | None = None
    """Commanded steering for a steer action of +1 [deg]; None means ``+car.max_steer``."""
    discrete_actions: tuple[tuple[float, float], ...] = DEFAULT_DISCRETE_ACTIONS
    """(steering angle [deg, left positive], speed [m/s]) pairs of the discrete action space."""
    num_obstacles: int | None = None
    """Box obstacles on the lanes; None means the race type's default (6 for
    ``object_avoidance``, else 0)."""
    obstacle_positions: tuple[tuple[float, int], ...] | None = None
    """Fixed obstacles as (fraction of the lap in [0, 1), lane +1 left / -1 right);
    None spaces them evenly with alternating lanes."""
    randomize_obstacles: bool = False
    """Re-draw obstacle positions and lanes at every reset (DeepRacer's randomisation)."""
    obstacle_length: float = 0.5
    """Obstacle box length along the lane [m] (DeepRacer's judged rectangle)."""
    obstacle_width: float = 0.4
    """Obstacle box width across the lane [m]."""
    num_bots: int | None = None
    """Scripted bot cars per env copy (DeepRacer's ``NUMBER_OF_BOT_CARS``); None means the race
    type's default (3 for ``head_to_bot``, DeepRacer-for-Cloud's default, else 0). An explicit
    count overrides the race type: 0 bots in ``head_to_bot``, bots in ``head_to_head``. At most
    ``MAX_BOTS``."""
    bot_speed: float = 0.75
    """Constant speed of the bots along their lane [m/s] (``BOT_CAR_SPEED``; the DeepRacer
    league's head-to-head qualifier ran 0.75 m/s)."""
    bot_lane_change: bool = True
    """Bots change lanes from time to time (``IS_LANE_CHANGE``)."""
    bot_lane_change_min: float = 3.0
    """Shortest time between the end of a lane change and the start of the next [s] of bot
    driving time (``LOWER_LANE_CHANGE_TIME``); each gap is drawn uniformly from
    [``bot_lane_change_min``, ``bot_lane_change_max``]."""
    bot_lane_change_max: float = 5.0
    """Longest time between lane changes [s] (``UPPER_LANE_CHANGE_TIME``)."""
    bot_lane_change_distance: float = 1.0
    """Track distance a lane change takes [m] (``LANE_CHANGE_DISTANCE``); it lasts
    ``bot_lane_change_distance / bot_speed`` seconds."""
    bot_penalty: float = 5.0
    """Seconds every bot of an env copy stands still after a bot ran into a car ahead of it
    (``DR_H2B_BOT_CAR_PENALTY``)."""
    randomize_bots: bool = False
    """Draw the bots' start positions (at least ``BOT_MIN_GAP`` = 2 m apart) and lanes at every
    reset (``RANDOMIZE_BOT_CAR_LOCATIONS``) instead of spacing them evenly on alternating
    lanes."""
    round_robin_starts: bool = False
    """Move each env copy's start forward by ``round_robin_advance`` of the lap at every reset
    of that copy (DeepRacer's training starts, ``CHANGE_START_POSITION``); the first episode
    starts on the start line."""
    round_robin_advance: float = 0.05
    """Start advance per episode with ``round_robin_starts``, as a fraction of the lap
    (``ROUND_ROBIN_ADVANCE_DIST``)."""
    alternate_direction: bool = False
    """Drive the track the other way round on every second episode
    (``ALTERNATE_DRIVING_DIRECTION``); DeepRacer params then report ``is_reversed``. The first
    episode drives the track's own direction."""
    grid: Literal["random", "fixed"] = "random"
    """Start-slot assignment at reset: ``"random"`` draws a permutation from the seed
    (seat fairness), ``"fixed"`` puts car i in slot i."""
    grid_spacing: float = 0.75
    """Distance between consecutive grid slots along the track [m] (DeepRacer: 0.75)."""
    step_dt: float = 1.0 / 15.0
    """Simulated seconds per env step (DeepRacer: 15 steps per second)."""
    physics_substeps: int = 4
    """pymunk sub-steps per env step (contacts are resolved at step_dt / substeps)."""
    max_cycles: int = 10_000
    """Env steps after which every car is truncated."""
    sensors: tuple[str, ...] = ("state",)
    """Observation keys, in order: any of ``"state"``, ``"camera"``, ``"lidar"``. With only
    ``"state"`` the observation is the state vector itself; otherwise a ``Dict``. Any
    sequence of names is accepted (JSON and YAML give lists) and stored as a tuple."""
    camera: CameraConfig = field(default_factory=CameraConfig)
    """Camera settings (used when ``"camera"`` is in ``sensors``)."""
    lidar: LidarConfig = field(default_factory=LidarConfig)
    """Lidar settings (used when ``"lidar"`` is in ``sensors``)."""
    opponent_slots: int = 2
    """How many nearest opponents the state observation describes."""
    obstacle_slots: int = 2
    """How many nearest obstacles ahead the state observation describes."""

    def __post_init__(self) -> None:
        owner = type(self).__name__
        _check(_is_int(self.num_cars) and 1 <= self.num_cars <= 16, owner, "num_cars",
               self.num_cars, "an int in [1, 16]")
        _check(self.race_type in RACE_TYPES, owner, "race_type", self.race_type,
               f"one of {RACE_TYPES}")
        _check(self.rules is None or isinstance(self.rules, RaceRules), owner, "rules",
               self.rules, "None or a RaceRules")
        _check(self.action_type in ("continuous", "discrete"), owner, "action_type",
               self.action_type, "'continuous' or 'discrete'")
        _check(isinstance(self.car, CarParams), owner, "car", self.car, "a CarParams")
        _check(isinstance(self.reward, RewardConfig), owner, "reward", self.reward,
               "a RewardConfig")
        _check(_is_number(self.min_speed) and _is_number(self.max_speed)
               and 0.0 <= self.min_speed < self.max_speed <= self.car.max_speed, owner,
               "min_speed/max_speed", (self.min_speed, self.max_speed),
               f"0 <= min_speed < max_speed <= car.max_speed ({self.car.max_speed})")
        limit = math.degrees(self.car.max_steer)
        _check((self.min_steer_deg is None) == (self.max_steer_deg is None), owner,
               "min_steer_deg/max_steer_deg", (self.min_steer_deg, self.max_steer_deg),
               "both None or both numbers")
        if self.min_steer_deg is not None:
            _check(_is_number(self.min_steer_deg) and _is_number(self.max_steer_deg)
                   and -limit - 1e-9 <= self.min_steer_deg < self.max_steer_deg <= limit + 1e-9,
                   owner, "min_steer_deg/max_steer_deg", (self.min_steer_deg, self.max_steer_deg),
                   f"numbers with -{limit:g} <= min_steer_deg < max_steer_deg <= {limit:g} "
                   f"(car.max_steer in degrees)")
        actions = self.discrete_actions
        _check(isinstance(actions, (tuple, list)) and len(actions) >= 1,
               owner, "discrete_actions", actions,
               "a non-empty tuple of (steering_deg, speed) pairs")
        for i, pair in enumerate(self.discrete_actions):
            _check(isinstance(pair, (tuple, list)) and len(pair) == 2
                   and all(_is_number(v) and math.isfinite(v) for v in pair), owner,
                   f"discrete_actions[{i}]", pair, "a pair of finite numbers")
        _check(self.num_obstacles is None or (_is_int(self.num_obstacles)
                                              and 0 <= self.num_obstacles <= 32),
               owner, "num_obstacles", self.num_obstacles, "None or an int in [0, 32]")
        _check(self.obstacle_positions is None
               or isinstance(self.obstacle_positions, (tuple, list)),
               owner, "obstacle_positions", self.obstacle_positions,
               "None or a tuple of (fraction of the lap, lane) pairs")
        if self.obstacle_positions is not None:
            for i, pos in enumerate(self.obstacle_positions):
                _check(isinstance(pos, (tuple, list)) and len(pos) == 2 and _is_number(pos[0])
                       and 0.0 <= pos[0] < 1.0 and _is_number(pos[1]) and pos[1] in (-1, 1),
                       owner,
                       f"obstacle_positions[{i}]", pos,
                       "(fraction of the lap in [0, 1), lane +1 or -1)")
        for name in ("obstacle_length", "obstacle_width", "grid_spacing", "step_dt"):
            _finite_positive(owner, name, getattr(self, name))
        _check(self.num_bots is None or (_is_int(self.num_bots)
                                         and 0 <= self.num_bots <= MAX_BOTS),
               owner, "num_bots", self.num_bots,
               f"None (the race type's default) or an int in [0, {MAX_BOTS}]")
        for name in ("bot_speed", "bot_lane_change_min", "bot_lane_change_distance"):
            _finite_positive(owner, name, getattr(self, name))
        _check(_is_number(self.bot_lane_change_max)
               and math.isfinite(self.bot_lane_change_max)
               and self.bot_lane_change_max >= self.bot_lane_change_min, owner,
               "bot_lane_change_min/bot_lane_change_max",
               (self.bot_lane_change_min, self.bot_lane_change_max),
               "finite numbers with 0 < bot_lane_change_min <= bot_lane_change_max [s]")
        _check(_is_number(self.bot_penalty) and math.isfinite(self.bot_penalty)
               and self.bot_penalty >= 0, owner, "bot_penalty", self.bot_penalty,
               "a finite number >= 0 [s]")
        for name in ("bot_lane_change", "randomize_bots", "round_robin_starts",
                     "alternate_direction"):
            _check(isinstance(getattr(self, name), bool), owner, name, getattr(self, name),
                   "a bool")
        _check(_is_number(self.round_robin_advance)
               and math.isfinite(self.round_robin_advance)
               and 0.0 < self.round_robin_advance < 1.0, owner, "round_robin_advance",
               self.round_robin_advance, "a fraction of the lap in (0, 1) (DeepRacer: 0.05)")
        _check(self.grid in ("random", "fixed"), owner, "grid", self.grid, "'random' or 'fixed'")
        _check(_is_int(self.physics_substeps) and 1 <= self.physics_substeps <= 32,
               owner, "physics_substeps", self.physics_substeps, "an int in [1, 32]")
        _check(_is_int(self.max_cycles) and self.max_cycles >= 1, owner, "max_cycles",
               self.max_cycles, "an int >= 1")
        if isinstance(self.sensors, str):
            object.__setattr__(self, "sensors", (self.sensors,))
        elif isinstance(self.sensors, Sequence):
            object.__setattr__(self, "sensors", tuple(self.sensors))
        _check(isinstance(self.sensors, tuple) and len(self.sensors) >= 1
               and len(set(self.sensors)) == len(self.sensors)
               and all(k in SENSORS for k in self.sensors), owner, "sensors", self.sensors,
               f"a non-empty sequence of distinct names from {SENSORS}")
        _check(isinstance(self.camera, CameraConfig), owner, "camera", self.camera,
               "a CameraConfig")
        _check(isinstance(self.lidar, LidarConfig), owner, "lidar", self.lidar, "a LidarConfig")
        for name in ("opponent_slots", "obstacle_slots"):
            value = getattr(self, name)
            _check(_is_int(value) and value >= 0, owner, name, value, "an int >= 0")

    @property
    def race_rules(self) -> RaceRules:
        """The rules in force: ``rules`` or the race type's preset."""
        return self.rules if self.rules is not None else RaceRules.preset(self.race_type)

    @property
    def steer_range(self) -> tuple[float, float]:
        """Steering commanded by continuous actions -1 and +1 [rad]."""
        if self.min_steer_deg is None or self.max_steer_deg is None:
            return -self.car.max_steer, self.car.max_steer
        return math.radians(self.min_steer_deg), math.radians(self.max_steer_deg)

    @property
    def action_affine(self) -> tuple[float, float, float, float]:
        """``(steer_mid, steer_half, speed_mid, speed_half)``: a continuous action ``a`` in
        [-1, 1]^2 commands ``steer_mid + a0 * steer_half`` [rad] and
        ``speed_mid + a1 * speed_half`` [m/s]."""
        low, high = self.steer_range
        return (0.5 * (high + low), 0.5 * (high - low), 0.5 * (self.max_speed + self.min_speed),
                0.5 * (self.max_speed - self.min_speed))

    def commands(self, actions: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Clip continuous actions ``(..., 2)`` to [-1, 1] and map them to the car commands
        ``(steer [rad], speed [m/s])``, each of shape ``(...)`` (see ``action_affine``)."""
        steer_mid, steer_half, speed_mid, speed_half = self.action_affine
        a = np.clip(np.asarray(actions, dtype=np.float64), -1.0, 1.0)
        return steer_mid + a[..., 0] * steer_half, speed_mid + a[..., 1] * speed_half

    @property
    def obstacle_count(self) -> int:
        """Number of obstacles in force (``num_obstacles`` or the race type's default)."""
        if self.num_obstacles is not None:
            return self.num_obstacles
        if self.obstacle_positions is not None:
            return len(self.obstacle_positions)
        return 6 if self.race_type == "object_avoidance" else 0

    @property
    def bot_count(self) -> int:
        """Number of bot cars per env copy (``num_bots`` or the race type's default)."""
        if self.num_bots is not None:
            return self.num_bots
        return 3 if self.race_type == "head_to_bot" else 0

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> EnvConfig:
        """Build a config from a plain dict (e.g. parsed TOML), rejecting unknown keys."""
        data = dict(data)
        nested = {"car": CarParams, "reward": RewardConfig, "rules": RaceRules,
                  "camera": CameraConfig, "lidar": LidarConfig}
        valid = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - valid)
        if unknown:
            raise ValueError(f"EnvConfig: unknown keys {unknown}; valid keys are {sorted(valid)}")
        for key, sub in nested.items():
            if isinstance(data.get(key), dict):
                sub_valid = {f.name for f in dataclasses.fields(sub)}
                sub_unknown = sorted(set(data[key]) - sub_valid)
                if sub_unknown:
                    raise ValueError(f"EnvConfig.{key}: unknown keys {sub_unknown}; valid keys "
                                     f"are {sorted(sub_valid)}")
                data[key] = sub(**data[key])
        for key in ("discrete_actions", "obstacle_positions"):
            if isinstance(data.get(key), list):
                data[key] = tuple(tuple(v) for v in data[key])
        if isinstance(data.get("sensors"), (list, str)):
            sensors = data["sensors"]
            data["sensors"] = (sensors,) if isinstance(sensors, str) else tuple(sensors)
        return cls(**data)

    def to_dict(self) -> dict[str, Any]:
        """Return a plain, JSON-serialisable dict of this config."""
        return dataclasses.asdict(self)
