"""What a learner races against: ``RaceSettings``, the ``[race]`` table of a training run
(``TrainConfig.race``): DeepRacer's race type, boxes on the lanes (object avoidance) and bot
cars (head-to-bot).

DeepRacer trains its object-avoidance models against ``NUMBER_OF_OBSTACLES`` boxes (6 by
default) whose places and lanes are re-drawn every episode (``RANDOMIZE_OBSTACLE_LOCATIONS``),
and its head-to-bot models against ``NUMBER_OF_BOT_CARS`` scripted cars that drive their lane
at ``BOT_CAR_SPEED`` and change lanes from time to time (``IS_LANE_CHANGE``). Here every env
copy of the training VecEnv draws its own boxes and bots from the VecEnv's seeded generator at
each of its episode resets (``h2h_racing.training.vec_env``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from h2h_racing.config.env import MAX_BOTS, RACE_TYPES
from h2h_racing.config.checks import _check, _is_int, _is_number
from h2h_racing.training.tight_boxes import TightBoxes

MAX_BOXES = 32
"""Most boxes per env copy (``EnvConfig.num_obstacles``' bound)."""


@dataclass(frozen=True, kw_only=True)
class RaceSettings:
    """``[race]``: the race type the learners train for, and its boxes and bots."""

    race_type: str | None = None
    """``"time_trial"``, ``"head_to_head"``, ``"object_avoidance"`` or ``"head_to_bot"``;
    None means ``time_trial`` for one car per copy and ``head_to_head`` for more."""
    race_types: tuple[str, ...] = ()
    """Race types a procedural run (``track = "procedural"``) takes in turn, one per random
    track (``[procedural] every`` iterations each), instead of ``race_type``: e.g.
    ``["object_avoidance", "head_to_bot", "time_trial"]`` trains one learner for all three,
    each with its own default boxes and bots (6 boxes and no bot, then no box and 3 bots,
    then neither) unless ``boxes`` or ``bots`` is given. Only the boxes and bots change
    between tracks: every turn keeps the rules of the first race type listed other than
    ``time_trial`` (``rules_type``), so a ``time_trial`` turn is a lap with the track to
    itself under the same rules as the others."""
    boxes: int | None = None
    """Boxes on the lanes per env copy; None means the race type's default (6 for
    ``object_avoidance``, DeepRacer's ``NUMBER_OF_OBSTACLES``, else 0). A count other than
    None puts that many boxes in any race type."""
    randomize_boxes: bool = True
    """Draw each copy's box places and lanes at every episode reset (DeepRacer's
    ``RANDOMIZE_OBSTACLE_LOCATIONS``: each box uniform within its share of the lap, on a random
    lane); False keeps DeepRacer's fixed layout, evenly spaced on alternating lanes."""
    bots: int | None = None
    """Bot cars per env copy; None means the race type's default (3 for ``head_to_bot``,
    DeepRacer-for-Cloud's ``NUMBER_OF_BOT_CARS``, else 0). A count other than None puts that
    many bots in any race type."""
    bot_speed: float = 0.75
    """Speed of the bots along their lane [m/s] (``BOT_CAR_SPEED``; the DeepRacer league's
    head-to-bot qualifier ran 0.75 m/s)."""
    bot_lane_change: bool = True
    """Bots change lanes every 3-5 s of driving (``IS_LANE_CHANGE``)."""
    randomize_bots: bool = True
    """Draw each copy's bot places (at least 2 m apart, ahead of the start) and lanes at every
    episode reset (``RANDOMIZE_BOT_CAR_LOCATIONS``; DeepRacer's default, False, spaces them
    evenly on alternating lanes)."""
    tight_box_share: float = 0.0
    """Share of box layouts (one per copy and episode) in which one box is moved to a place
    where the room beside it is within ``tight_box_room`` (``h2h_racing.training.tight_boxes``):
    training only, never the env's or ``evaluate``'s placement. 0 (the default) moves and draws
    nothing. Bowtie_track has such a box in 77 % of its layouts, step 7's training tracks in
    2.9 % (``experiments/routes/retrain/obstacle_fine/bowtie``)."""
    tight_box_room: tuple[float, float] = (0.21, 0.24)
    """``(low, high)`` free width beside a moved box [m]; Bowtie's tight boxes leave
    0.22-0.23 m (``box_room.py`` calls a box tight under 0.24 m), a 0.6 m wide straight
    0.25 m; the car is 0.196 m wide."""

    def __post_init__(self) -> None:
        owner = "[race]"
        _check(self.race_type is None or self.race_type in RACE_TYPES, owner, "race_type",
               self.race_type, f"one of {RACE_TYPES} (or left out)")
        _check(isinstance(self.race_types, tuple)
               and all(t in RACE_TYPES for t in self.race_types)
               and (not self.race_types or set(self.race_types) != {"time_trial"}),
               owner, "race_types",
               self.race_types, f"a list of race types from {RACE_TYPES}, at least one of them "
               "other than 'time_trial' (for one race type, give race_type instead)")
        _check(not (self.race_types and self.race_type is not None), owner, "race_types",
               self.race_types, f"left out when race_type is given (got race_type "
               f"{self.race_type!r}): give one or the other")
        _check(self.boxes is None or (_is_int(self.boxes) and 0 <= self.boxes <= MAX_BOXES),
               owner, "boxes", self.boxes,
               f"an int in [0, {MAX_BOXES}] (or left out for the race type's default)")
        _check(self.bots is None or (_is_int(self.bots) and 0 <= self.bots <= MAX_BOTS),
               owner, "bots", self.bots,
               f"an int in [0, {MAX_BOTS}] (or left out for the race type's default)")
        _check(_is_number(self.bot_speed) and math.isfinite(self.bot_speed)
               and self.bot_speed > 0, owner, "bot_speed", self.bot_speed,
               "a finite number > 0 [m/s] (DeepRacer's races use 0.2-6)")
        for name in ("randomize_boxes", "bot_lane_change", "randomize_bots"):
            _check(isinstance(getattr(self, name), bool), owner, name, getattr(self, name),
                   "true or false")
        self.tight_boxes()  # checks tight_box_share and tight_box_room

    def tight_boxes(self) -> TightBoxes | None:
        """The tight-box settings a training VecEnv applies, or None when they move nothing."""
        settings = TightBoxes(self.tight_box_share, self.tight_box_room)
        return settings if settings.share > 0 else None

    def resolved_type(self, num_cars: int) -> str:
        """The race type in force for ``num_cars`` cars per copy (the first of
        ``race_types`` when they take turns)."""
        if self.race_types:
            return self.race_types[0]
        if self.race_type is not None:
            return self.race_type
        return "time_trial" if num_cars == 1 else "head_to_head"

    def rules_type(self, num_cars: int) -> str:
        """The race type whose rules every turn keeps: the first of ``race_types`` other than
        ``time_trial`` (their rules are the same: 3 laps, 5 s penalties), else
        ``resolved_type``."""
        racing = [t for t in self.race_types if t != "time_trial"]
        return racing[0] if racing else self.resolved_type(num_cars)

    def env_fields(self) -> dict[str, Any]:
        """The ``EnvConfig`` fields of the boxes and bots (counts left None take the race
        type's default there)."""
        return {"num_obstacles": self.boxes, "randomize_obstacles": self.randomize_boxes,
                "num_bots": self.bots, "bot_speed": float(self.bot_speed),
                "bot_lane_change": self.bot_lane_change, "randomize_bots": self.randomize_bots}
