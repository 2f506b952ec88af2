"""The built-in, vectorised, progress-based reward.

Each term is a pure function of a step's events and the state, weighted by
``RewardConfig`` (arrays of shape (E, N)):

==========  =========================================================  ============
term        value before weighting                                     default weight
==========  =========================================================  ============
progress    metres of centre-line progress this step (negative back)   1.0
speed       forward speed [m/s] while racing                           0.0
off_track   1 on the step the car goes off track                       -5.0
crash       1 on the step the car is judged at fault in a contact      -5.0
overtake    cars passed on track minus times passed                    1.0
lap         1 on the step a lap is completed                           0.0
time        1 per step while racing                                    0.0
==========  =========================================================  ============

The reward is the weighted sum. A frozen (penalised) or finished car gets 0 for every
term except those of its penalising step.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from h2h_racing.config import RewardConfig

if TYPE_CHECKING:
    from h2h_racing.core import StepEvents

FloatArray = npt.NDArray[np.float64]


def reward_terms(weights: RewardConfig, events: StepEvents, speed: FloatArray,
                 racing: npt.NDArray[np.bool_]) -> dict[str, FloatArray | None]:
    """Return each weighted reward term, shape (E, N), keyed by term name.

    Terms whose weight is 0 are not computed and map to None (they contribute 0).

    Args:
        weights: Term weights.
        events: The step's events.
        speed: Forward speed after the step, (E, N), m/s.
        racing: Cars that were racing during the step, (E, N).
    """
    values = {
        "progress": lambda: events.progress,
        "speed": lambda: speed * racing,
        "off_track": lambda: events.off_track,
        "crash": lambda: events.crashed,
        "overtake": lambda: events.overtakes - events.overtaken,
        "lap": lambda: events.lap_completed,
        "time": lambda: racing,
    }
    return {name: (weight * value() if (weight := getattr(weights, name)) else None)
            for name, value in values.items()}


def total_reward(terms: dict[str, FloatArray | None], shape: tuple[int, ...]) -> FloatArray:
    """Sum the weighted terms into an array of ``shape`` (E, N)."""
    total = np.zeros(shape)
    for value in terms.values():
        if value is not None:
            total += value
    return total
