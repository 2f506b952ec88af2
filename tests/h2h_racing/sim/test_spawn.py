"""Randomised obstacle layouts (``spawn.obstacle_layout``, ``EnvConfig.obstacle_min_gap``).

On a lap of length L with n boxes, none within 3 m after the line or 1 m before the grid,
each box has a share ``(L - 4) / n`` of the lap; randomised, box k sits at
``3 + share (k + u)``, u uniform on [a, 1 - a], a = max(0.2, min_gap / (2 share)) capped at
0.5. Neighbours are then between ``2 a share`` and ``(2 - 2 a) share`` apart.
"""

from __future__ import annotations

import numpy as np
import pytest

import h2h_racing
from h2h_racing.sim import layouts as spawn
from h2h_racing.config.env import EnvConfig
from h2h_racing.track.io import load_track

DRAWS = 4000


def _gaps(track_name: str, min_gap: float, count: int = 6,
          seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    track = load_track(track_name)
    s, lane = spawn.obstacle_layout(track, np.random.default_rng(seed), DRAWS, count, None,
                                    True, 1, min_gap=min_gap)
    return np.diff(s, axis=1), lane


class TestMinGap:
    def test_short_lap_keeps_neighbours_min_gap_apart(self) -> None:
        # oval: L = 20 m, share = 16 / 6 = 2.667 m; a = 2 / 5.333 = 0.375, so neighbours are
        # 2.0 to 3.333 m apart (40 % of a share would be 1.067 m).
        gaps, lane = _gaps("oval", 2.0)
        assert gaps.min() >= 2.0 - 1e-9 and gaps.max() <= (2 - 0.75) * 16 / 6 + 1e-3
        assert gaps.min() < 2.05 and gaps.max() > 3.28  # the whole range is drawn
        assert set(np.unique(lane)) == {-1.0, 1.0}

    def test_long_lap_is_drawn_as_before(self) -> None:
        # grand_loop: L = 55 m, share = 8.5 m; a = max(0.2, 2 / 17) = 0.2: neighbours 3.4 to
        # 13.6 m apart, the same draws as without a minimum gap.
        gaps, _ = _gaps("grand_loop", 2.0)
        assert gaps.min() >= 3.4 - 1e-9 and gaps.max() <= 13.6 + 1e-9
        assert np.array_equal(gaps, _gaps("grand_loop", 0.0)[0])
        assert np.array_equal(_gaps("grand_loop", 2.0, seed=5)[1],
                              _gaps("grand_loop", 0.0, seed=5)[1])

    def test_lap_without_room_spaces_them_evenly(self) -> None:
        # oval with 8 boxes: share = (L - 4) / 8 = 2 m < min_gap 3 m: a = 0.5, every gap a
        # share (the file's lap is 19.9997 m).
        gaps, _ = _gaps("oval", 3.0, count=8)
        assert np.allclose(gaps, (load_track("oval").length - 4.0) / 8, rtol=0, atol=1e-9)

    def test_env_draws_with_its_config(self) -> None:
        env = h2h_racing.parallel_env(track="technical", num_cars=1,
                                      race_type="object_avoidance", randomize_obstacles=True)
        smallest = np.inf
        for seed in range(30):
            env.reset(seed=seed)
            s = np.sort(env.core.obstacle_s[0])
            smallest = min(smallest, np.diff(s).min())
        # technical: L = 20 m, share 2.61 m (the grid takes a car length): a = 0.383.
        assert 2.0 - 1e-9 <= smallest < 2.3

    @pytest.mark.parametrize("gap", [-0.5, float("nan"), float("inf"), True, "2"])
    def test_bad_gap_rejected(self, gap: object) -> None:
        with pytest.raises(ValueError, match="obstacle_min_gap"):
            EnvConfig(obstacle_min_gap=gap)  # type: ignore[arg-type]
