"""Race rules (:class:`RaceRules`): what an infraction does, when a race ends, how it is ranked."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

from h2h_racing.config.checks import _check, _finite_positive, _is_int, _is_number

RaceType = Literal["time_trial", "head_to_head", "object_avoidance", "head_to_bot"]
RuleMode = Literal["training", "race"]
Ranking = Literal["total_time", "best_lap"]

RACE_TYPES: tuple[str, ...] = ("time_trial", "head_to_head", "object_avoidance", "head_to_bot")
RULE_MODES: tuple[str, ...] = ("training", "race")


@dataclass(frozen=True, kw_only=True)
class RaceRules:
    """Race rules: what an infraction does, when a race ends, how it is ranked.

    ``mode="training"`` ends a car's episode at its first infraction (DeepRacer training);
    ``mode="race"`` freezes the car for a time penalty while the clock runs and then
    re-places it on the nearest lane at its last valid progress (DeepRacer evaluation), or,
    after a crash into a box, 1 m behind the box on the other lane (DeepRacer's
    ``RESET_BEHIND_DIST``; where that is taken, up that lane to 0.25 m behind the box), on
    the first spot there or up to 3.5 m back (that lane first, then the other) whose box
    clears every other body by 7 cm; with none
    clear it stays frozen, parked off the track, until one is (``h2h_racing.sim.replacement``).
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
