"""Evaluation of a driver over lap attempts from evenly spread start points."""

from __future__ import annotations

import numpy as np

from h2h_racing.league.evaluate import Evaluation, evaluate


class TestEvaluate:
    """Scripted drivers give the figures their lap-time table predicts."""

    def test_racing_line_beats_pure_pursuit_from_every_start(self) -> None:
        fast = evaluate("racing_line", "oval", episodes=4)
        slow = evaluate("pure_pursuit", "oval", episodes=4)
        assert fast.episodes == 4 and fast.lap_completion == 1.0
        assert slow.lap_completion == 1.0
        # Racing line ~6 s vs pure pursuit ~8.7 s per lap of the 20 m oval (policies/README).
        assert fast.mean_lap_time < 0.85 * slow.mean_lap_time
        assert fast.best_lap_time <= fast.mean_lap_time

    def test_a_driver_that_leaves_the_track_completes_nothing(self) -> None:
        class FullLeft:
            name = "full_left"

            def reset(self, core: object) -> None:
                pass

            def act(self, core: object, car: int) -> np.ndarray:
                return np.tile(np.array([[1.0, 1.0]], np.float32), (core.num_envs, 1))

        result = evaluate(FullLeft(), "oval", episodes=3)
        assert result.lap_completion == 0.0 and result.off_tracks == 3
        assert result.mean_lap_time == float("inf")
        assert "full_left" in result.row() and "0.0 %" in result.row()
        assert Evaluation.header().split()[0] == "driver"
