"""The built-in, vectorised, progress-based reward.

Each term is a pure function of a step's events and the state, weighted by
``RewardConfig`` (arrays of shape (E, N)):

==========  =========================================================  ==============
term        value before weighting                                     default weight
==========  =========================================================  ==============
progress    metres of centre-line progress this step (negative back)   1.0
speed       forward speed [m/s] while racing                           0.0
off_track   1 on the step the car goes off track                       -5.0
crash       1 on the step the car is judged at fault in a contact      -5.0
contact     1 on the step the car is in a new contact, at fault or not  0.0
overtake    cars passed on track minus times passed                    1.0
lap         1 on the step a lap is completed                           0.0
time        1 per step while racing                                    0.0
==========  =========================================================  ==============

``contact`` exists because DeepRacer's judging (the car behind is at fault) pays a learner
for being run into: the other car's penalty is its gain, so ``crash`` alone teaches braking in
front of a follower. A ``contact`` cost makes every touch cost both cars.

The reward is the weighted sum. A car frozen by a penalty, or done, gets 0 for every term
except those of the step that penalised or ended it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from numba import njit

from h2h_racing.config.env import RewardConfig

if TYPE_CHECKING:
    from h2h_racing.sim.core import StepEvents

FloatArray = npt.NDArray[np.float64]

TERMS: tuple[str, ...] = ("progress", "speed", "off_track", "crash", "contact", "overtake", "lap",
                          "time")
"""Reward term names, in the order of ``reward_terms``' first axis."""


def weights_of(config: RewardConfig) -> FloatArray:
    """Return the weights of ``TERMS`` as an array, shape (8,)."""
    return np.array([getattr(config, name) for name in TERMS], dtype=np.float64)


def reward_terms(weights: FloatArray, events: StepEvents, speed: FloatArray,
                 racing: npt.NDArray[np.bool_]) -> tuple[FloatArray, FloatArray]:
    """Return the weighted terms and the reward of every car.

    Args:
        weights: Term weights in ``TERMS`` order, shape (8,) (see ``weights_of``).
        events: The step's events.
        speed: Forward speed after the step, (E, N), m/s.
        racing: Cars that were racing during the step, (E, N).

    Returns:
        ``(terms (8, E, N), reward (E, N))`` with ``reward = terms.sum(axis=0)``.
    """
    terms = np.empty((len(TERMS), *speed.shape))
    reward = np.empty(speed.shape)
    _reward_kernel(weights, events.progress, speed, racing, events.off_track, events.crashed,
                   events.collided, events.overtakes, events.overtaken, events.lap_completed,
                   terms, reward)
    return terms, reward


@njit(cache=True)
def _reward_kernel(weights, progress, speed, racing, off_track, crashed, collided, overtakes,
                   overtaken, lap_completed, terms, reward):  # pragma: no cover
    for e in range(progress.shape[0]):
        for i in range(progress.shape[1]):
            active = 1.0 if racing[e, i] else 0.0
            values = (progress[e, i], speed[e, i] * active, 1.0 if off_track[e, i] else 0.0,
                      1.0 if crashed[e, i] else 0.0, 1.0 if collided[e, i] else 0.0,
                      float(overtakes[e, i] - overtaken[e, i]),
                      1.0 if lap_completed[e, i] else 0.0, active)
            total = 0.0
            for k in range(8):
                term = weights[k] * values[k] + 0.0  # + 0.0 turns -0.0 into 0.0
                terms[k, e, i] = term
                total += term
            reward[e, i] = total
