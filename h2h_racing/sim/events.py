"""What one step of the batched core reports: ``StepEvents``, per car of every env copy.

``RaceCore.step`` (``h2h_racing.sim.core``) returns one; the env turns it into rewards, infos and
the viz's event lines.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]


@dataclass
class StepEvents:
    """What happened during one step, per car, shape (E, N) unless noted."""

    terminated: BoolArray
    """The car's episode ended for a reason inside the task (finished or retired)."""
    truncated: BoolArray
    """The car's episode was cut short by the time limit or ``max_cycles``."""

    off_track: BoolArray
    """The car went off track (all four wheels off) this step."""
    crashed: BoolArray
    """The car was judged at fault for a contact (it was behind, or hit an obstacle)."""
    collided: BoolArray
    """The car was in a new contact, at fault or not."""
    reversed: BoolArray
    """The car drove the wrong way for ``rules.reversed_steps`` steps."""
    immobilised: BoolArray
    """The car did not move for ``rules.immobilised_steps`` steps."""
    penalised: BoolArray
    """The car received a time penalty (race mode) this step."""
    replaced: BoolArray
    """The car was put back on the track after its penalty this step."""
    lap_completed: BoolArray
    """The car completed a lap this step."""
    finished: BoolArray
    """The car reached the lap target this step."""
    progress: FloatArray
    """Metres of track progress this step (negative when going backwards)."""
    overtakes: IntArray
    """Cars this car passed on track this step."""
    overtaken: IntArray
    """Cars that passed this car this step."""
    defences: IntArray
    """Defences completed by this car this step."""
    collisions: list[tuple[int, int, int, bool]] = field(default_factory=list)
    """``(env, car at fault, other car or obstacle index, other_is_obstacle)``."""
    bot_contacts: list[tuple[int, int, int, bool]] = field(default_factory=list)
    """New contacts between cars and bots: ``(env, car, bot, car_at_fault)``;
    ``car_at_fault`` False means the bot ran into the car from behind (the bots paused)."""
    bots_paused: BoolArray | None = None
    """Env copies whose bots started (or extended) a ``bot_penalty`` pause this step, (E,);
    None when no bot paused."""
    passes: list[tuple[int, int, int]] = field(default_factory=list)
    """``(env, car that passed, car passed)``."""
