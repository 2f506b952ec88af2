"""Frozen, validated configuration dataclasses.

Every physical quantity is SI (metres, seconds, radians, kilograms) unless its
docstring says otherwise. Configs are immutable: derive a variant with
``dataclasses.replace``. ``EnvConfig.from_dict`` rejects unknown keys.

:class:`EnvConfig` (here) holds everything that defines an environment; its parts live in
their own modules and are importable from here too: :class:`CarParams`
(:mod:`h2h_racing.config.car`), :class:`RaceRules` (:mod:`h2h_racing.config.rules`),
:class:`CameraConfig` and :class:`LidarConfig` (:mod:`h2h_racing.config.sensors`), with the
shared validation helpers in :mod:`h2h_racing.config.checks`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from h2h_racing.config.car import CarParams
from h2h_racing.config.checks import _check, _finite_positive, _is_int, _is_number
from h2h_racing.config.rules import RACE_TYPES, RULE_MODES, RaceType, Ranking, RaceRules, RuleMode
from h2h_racing.config.sensors import LIDAR_MAX_RANGE, CameraConfig, LidarConfig

FloatArray = npt.NDArray[np.float64]

ActionType = Literal["continuous", "discrete"]

MAX_BOTS = 12
"""Most bot cars per env copy (DeepRacer's community races allow 6; the league qualifier runs 6)."""
MAX_CARS = 16
"""Most cars per env copy (``EnvConfig.num_cars``)."""
MAX_OPPONENT_SLOTS = MAX_CARS - 1 + MAX_BOTS
"""Most opponent slots of the state observation: every other car and every bot."""
MAX_OBSTACLE_SLOTS = 32
"""Most obstacle slots of the state observation: every box (``num_obstacles`` <= 32)."""
MAX_CAMERA_VALUES_ALL_CARS = 2**26
"""Most camera values one step renders for all cars of a copy (``num_cars * width * height *
cameras * frame_stack``): 64 MiB of uint8 frames, held several times over (the observation, its
space's bounds, the frame stack); 16 cars of 160 x 120 with 32 frames are 9.8 M. Past it a
config asked for gigabytes before the first step."""
SENSORS: tuple[str, ...] = ("state", "camera", "lidar")

__all__ = [
    "DEFAULT_DISCRETE_ACTIONS", "LIDAR_MAX_RANGE", "MAX_BOTS", "RACE_TYPES", "RULE_MODES", "SENSORS", "ActionType", "CameraConfig",
    "CarParams", "EnvConfig", "LidarConfig", "RaceRules", "RaceType", "Ranking", "RewardConfig", "RuleMode",
]


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
    obstacle_min_gap: float = 2.0
    """Smallest arc distance between neighbouring randomised obstacles, centre to centre [m]
    (DeepRacer's ``MIN_DISTANCE_BETWEEN_OBSTACLES``). Closer, two boxes in opposite lanes of a
    0.76 m track make a slalom no car can steer through. Where the lap has no room for it,
    the obstacles are spaced evenly."""
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
        _check(_is_int(self.num_cars) and 1 <= self.num_cars <= MAX_CARS, owner, "num_cars",
               self.num_cars, f"an int in [1, {MAX_CARS}]")
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
        _check(_is_number(self.obstacle_min_gap) and 0.0 <= self.obstacle_min_gap < math.inf,
               owner, "obstacle_min_gap", self.obstacle_min_gap, "a finite number >= 0 [m]")
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
        for name, most in (("opponent_slots", MAX_OPPONENT_SLOTS),
                           ("obstacle_slots", MAX_OBSTACLE_SLOTS)):
            value = getattr(self, name)
            _check(_is_int(value) and 0 <= value <= most, owner, name, value,
                   f"an int in [0, {most}]")
        if "camera" in self.sensors:
            cam = self.camera
            values = self.num_cars * cam.width * cam.height * cam.channels
            _check(values <= MAX_CAMERA_VALUES_ALL_CARS, owner, "camera", cam,
                   f"at most {MAX_CAMERA_VALUES_ALL_CARS} camera values a step for all cars "
                   f"(h2h_racing.config.env.MAX_CAMERA_VALUES_ALL_CARS, 64 MiB; num_cars * width * "
                   f"height * (2 if stereo else 1) * frame_stack = {self.num_cars} * {cam.width} * "
                   f"{cam.height} * {cam.cameras} * {cam.frame_stack} = {values}): use fewer "
                   f"cars, frames or pixels")

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
