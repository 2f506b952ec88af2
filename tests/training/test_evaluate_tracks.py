"""``training.evaluate_tracks``: drivers on many tracks as the copies of one core give, to the
bit, the figures of ``evaluate`` and ``evaluate_races`` on each track alone."""

from __future__ import annotations

import numpy as np
import pytest

from h2h_racing.config.env import EnvConfig
from h2h_racing.track.io import load_track
from h2h_racing.training.evaluate import evaluate, evaluate_races, race_config
from h2h_racing.training.evaluate_tracks import (MAX_COPIES, Run, batchable, batches, lap_runs,
                                                 race_runs)
from h2h_racing.sim.tracks import MAX_OVERLAID_TRACKS

NAMES = ("oval", "kidney", "speedway")


class Centre:
    """Pure pursuit of the centre line at 2.5 m/s, blind to boxes and bots (it crashes)."""

    name = "centre"

    def reset(self, core) -> None:
        pass

    def act(self, core, car: int) -> np.ndarray:
        from h2h_racing.policies.steering import pursuit_steer, to_action

        target = core.track.point_at(core.s[:, car] + 0.6)
        return to_action(core, pursuit_steer(core, car, target), np.full(core.num_envs, 2.5))


def test_lap_runs_are_evaluate_to_the_bit() -> None:
    import torch

    from h2h_racing.training.evaluate_routes import one_torch_thread

    assert torch.get_num_threads() >= 1
    with one_torch_thread():  # a 4-copy batch: one thread is many times faster on 2 cores
        lap_runs_against_evaluate()


def lap_runs_against_evaluate() -> None:
    tracks = [load_track(n) for n in NAMES]
    # The longest track first: its runs' laps (8-9 s on speedway against 6 s on oval) end
    # after the others', whatever the policy, so the runs finish out of their order.
    runs = [Run(driver, track, seed) for track, seed in
            sorted(zip(tracks, (0, 5, 9)), key=lambda pair: -pair[0].length)
            for driver in ("ppo_generalist", "racing_line")]
    finished: list[int] = []
    got = lap_runs(runs, 4, lambda k, figures: finished.append(k))
    want = [evaluate(run.driver, run.track, episodes=4, seed=run.seed) for run in runs]
    assert got == want
    assert sorted(finished) == list(range(len(runs)))
    # Each run's copies kept racing until its own last attempt ended, not the batch's.
    assert finished != list(range(len(runs)))


@pytest.mark.parametrize("race_type, races", [("object_avoidance", 10), ("head_to_bot", 16),
                                              ("object_avoidance", 2)])
def test_race_runs_are_evaluate_races_to_the_bit(race_type: str, races: int) -> None:
    """10 races of 7 bodies and 16 of 4 are 64 bodies or more (batched); 2 races of 7 are not
    (a core each)."""
    runs = [Run(Centre(), load_track(n), seed) for n, seed in zip(NAMES, (1, 2, 3))]
    got = race_runs(runs, race_type, races, 1)
    want = [evaluate_races(Centre(), run.track, race_type, races=races, laps=1,
                           seed=run.seed) for run in runs]
    assert got == want
    assert sum(r.crashes for r in got) > 0


def test_what_is_batched() -> None:
    lap = EnvConfig(num_cars=1)
    assert batchable(lap, 1)  # one car, nothing to touch
    boxes = race_config("oval", "object_avoidance", 3)
    assert not batchable(boxes, 9) and batchable(boxes, 10)  # 63 and 70 bodies
    assert not batchable(race_config("oval", "head_to_bot", 3), 15)
    runs = [Run("racing_line", load_track("oval"))] * 70
    assert [len(b) for b in batches(runs, 10)] == [MAX_OVERLAID_TRACKS] * 2 + [6]
    assert [len(b) for b in batches(runs[:5], MAX_COPIES // 2)] == [2, 2, 1]
    assert [len(b) for b in batches(runs[:3], 10 * MAX_COPIES)] == [1, 1, 1]
    assert sum(batches(runs, 10), []) == list(range(70))


def test_bad_race_settings() -> None:
    runs = [Run("racing_line", load_track("oval"))]
    with pytest.raises(ValueError, match="race_type must be one of"):
        race_runs(runs, "time_trial", 2, 1)
    with pytest.raises(ValueError, match="races and laps must be whole numbers >= 1"):
        race_runs(runs, "head_to_bot", 0, 1)
    assert np.isfinite(lap_runs(runs, 1)[0].mean_lap_time)
