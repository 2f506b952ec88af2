"""Frozen, validated configuration dataclasses.

Every physical quantity is SI (metres, seconds, radians, kilograms) unless its
docstring says otherwise. Configs are immutable: derive a variant with
``dataclasses.replace``. ``EnvConfig.from_dict`` rejects unknown keys.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Literal

RaceType = Literal["time_trial", "head_to_head", "object_avoidance"]
RuleMode = Literal["training", "race"]
ActionType = Literal["continuous", "discrete"]
Ranking = Literal["total_time", "best_lap"]

RACE_TYPES: tuple[str, ...] = ("time_trial", "head_to_head", "object_avoidance")
RULE_MODES: tuple[str, ...] = ("training", "race")


def _check(condition: bool, owner: str, name: str, value: Any, allowed: str) -> None:
    """Raise a ValueError naming the field, the value and what is allowed."""
    if not condition:
        raise ValueError(f"{owner}.{name} must be {allowed}, got {value!r}")


def _finite_positive(owner: str, name: str, value: float) -> None:
    _check(
        isinstance(value, (int, float)) and math.isfinite(value) and value > 0,
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
                _check(0.0 <= value <= 1.0, owner, f.name, value, "in [0, 1]")
            elif f.name == "body_friction":
                _check(0.0 <= value, owner, f.name, value, ">= 0")
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
    re-places it on the nearest lane at its last valid progress (DeepRacer evaluation).
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
        _check(isinstance(self.laps, int) and self.laps >= 0, owner, "laps", self.laps,
               "an int >= 0")
        _check(self.time_limit > 0, owner, "time_limit", self.time_limit, "> 0 (math.inf allowed)")
        _check(self.laps > 0 or math.isfinite(self.time_limit), owner, "time_limit",
               self.time_limit, "finite when laps == 0 (otherwise the race never ends)")
        for name in ("off_track_penalty", "crash_penalty", "reversed_penalty",
                     "immobilised_penalty"):
            value = getattr(self, name)
            _check(math.isfinite(value) and value >= 0, owner, name, value, "finite and >= 0")
        _check(self.max_resets_per_lap is None or self.max_resets_per_lap >= 0, owner,
               "max_resets_per_lap", self.max_resets_per_lap, "None or an int >= 0")
        for name in ("reversed_steps", "immobilised_steps"):
            _check(getattr(self, name) >= 1, owner, name, getattr(self, name), "an int >= 1")
        for name in ("immobilised_distance", "defence_gap", "defence_time"):
            _finite_positive(owner, name, getattr(self, name))

    @classmethod
    def preset(cls, race_type: str, mode: str = "race") -> RaceRules:
        """Return the rules of a race type.

        ``time_trial``: 4 minutes, best valid lap, a lap with more than 3 resets is void
        (DeepRacer physical-event format). ``head_to_head`` and ``object_avoidance``:
        3 laps, total time, 5 s penalties (DeepRacer league format), 180 s limit.
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
    overtake: float = 1.0
    """Per car passed on track; the car passed gets the negative."""
    lap: float = 0.0
    """On completing a lap."""
    time: float = 0.0
    """Per step (use a negative value to reward finishing early)."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            _check(isinstance(value, (int, float)) and math.isfinite(value), "RewardConfig",
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
    """``"time_trial"``, ``"head_to_head"`` or ``"object_avoidance"``."""
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
    opponent_slots: int = 2
    """How many nearest opponents the state observation describes."""
    obstacle_slots: int = 2
    """How many nearest obstacles ahead the state observation describes."""

    def __post_init__(self) -> None:
        owner = type(self).__name__
        _check(isinstance(self.num_cars, int) and 1 <= self.num_cars <= 16, owner, "num_cars",
               self.num_cars, "an int in [1, 16]")
        _check(self.race_type in RACE_TYPES, owner, "race_type", self.race_type,
               f"one of {RACE_TYPES}")
        _check(self.rules is None or isinstance(self.rules, RaceRules), owner, "rules",
               self.rules, "None or a RaceRules")
        _check(self.action_type in ("continuous", "discrete"), owner, "action_type",
               self.action_type, "'continuous' or 'discrete'")
        _check(0.0 <= self.min_speed < self.max_speed <= self.car.max_speed, owner,
               "min_speed/max_speed", (self.min_speed, self.max_speed),
               f"0 <= min_speed < max_speed <= car.max_speed ({self.car.max_speed})")
        _check(len(self.discrete_actions) >= 1, owner, "discrete_actions",
               self.discrete_actions, "a non-empty tuple of (steering_deg, speed) pairs")
        for i, pair in enumerate(self.discrete_actions):
            _check(len(pair) == 2 and all(math.isfinite(v) for v in pair), owner,
                   f"discrete_actions[{i}]", pair, "a pair of finite numbers")
        _check(self.num_obstacles is None or (isinstance(self.num_obstacles, int)
                                              and 0 <= self.num_obstacles <= 32),
               owner, "num_obstacles", self.num_obstacles, "None or an int in [0, 32]")
        if self.obstacle_positions is not None:
            for i, pos in enumerate(self.obstacle_positions):
                _check(len(pos) == 2 and 0.0 <= pos[0] < 1.0 and pos[1] in (-1, 1), owner,
                       f"obstacle_positions[{i}]", pos,
                       "(fraction of the lap in [0, 1), lane +1 or -1)")
        for name in ("obstacle_length", "obstacle_width", "grid_spacing", "step_dt"):
            _finite_positive(owner, name, getattr(self, name))
        _check(self.grid in ("random", "fixed"), owner, "grid", self.grid, "'random' or 'fixed'")
        _check(isinstance(self.physics_substeps, int) and 1 <= self.physics_substeps <= 32,
               owner, "physics_substeps", self.physics_substeps, "an int in [1, 32]")
        _check(isinstance(self.max_cycles, int) and self.max_cycles >= 1, owner, "max_cycles",
               self.max_cycles, "an int >= 1")
        _check(self.opponent_slots >= 0 and self.obstacle_slots >= 0, owner,
               "opponent_slots/obstacle_slots", (self.opponent_slots, self.obstacle_slots),
               "ints >= 0")

    @property
    def race_rules(self) -> RaceRules:
        """The rules in force: ``rules`` or the race type's preset."""
        return self.rules if self.rules is not None else RaceRules.preset(self.race_type)

    @property
    def obstacle_count(self) -> int:
        """Number of obstacles in force (``num_obstacles`` or the race type's default)."""
        if self.num_obstacles is not None:
            return self.num_obstacles
        if self.obstacle_positions is not None:
            return len(self.obstacle_positions)
        return 6 if self.race_type == "object_avoidance" else 0

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> EnvConfig:
        """Build a config from a plain dict (e.g. parsed TOML), rejecting unknown keys."""
        data = dict(data)
        nested = {"car": CarParams, "reward": RewardConfig, "rules": RaceRules}
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
        return cls(**data)

    def to_dict(self) -> dict[str, Any]:
        """Return a plain, JSON-serialisable dict of this config."""
        return dataclasses.asdict(self)
