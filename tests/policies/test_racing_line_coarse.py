"""The racing line on a track drawn through coarse waypoints (30-80 cm apart, as DeepRacer's
route files and ``training.tracks.resample``): the same line as on the track drawn finely."""

from __future__ import annotations

import math

import numpy as np

from h2h_racing.config.env import EnvConfig
from h2h_racing.policies.racing_line import compute_race_line, smooth_frame, track_offsets
from h2h_racing.track.io import load_track
from h2h_racing.track.shape import Track
from h2h_racing.training.tracks import resample


def redrawn(track: Track, gap: tuple[float, float], seed: int) -> Track:
    """``track`` re-drawn through waypoints ``gap`` [m] apart (as ``waypoint_gap`` does)."""
    centre, widths = resample(np.random.default_rng(seed), track.centre,
                              (track.width_left, track.width_right), gap)
    return Track(centre, *widths, name=f"{track.name}_coarse")


class TestCoarseWaypoints:
    """Before the fix the optimiser used the track's own normals, which turn by the whole
    corner at each waypoint: on ``grand_loop`` re-drawn through 60-80 cm waypoints the line
    kept to the outside of every bend (offsets -0.38 to +0.03 m, 39 cm from the fine line)
    and planned a lap 16 % slower than on the fine track."""

    def test_grand_loop_redrawn_coarsely_gets_the_fine_line(self) -> None:
        config = EnvConfig()
        fine_track = load_track("grand_loop")
        coarse_track = redrawn(fine_track, (0.6, 0.8), seed=0)
        assert len(coarse_track.centre) < 100 < len(fine_track.centre)
        fine = compute_race_line(fine_track, config.car, config.max_speed)
        coarse = compute_race_line(coarse_track, config.car, config.max_speed)
        # Each point of the coarse line is within a few cm of the fine line (the re-drawn
        # track itself cuts each bend's chords by up to gap^2 / 8R, 4 cm at R = 1.5 m).
        gaps = np.linalg.norm(coarse.points[:, None, :] - fine.points[None, :, :], axis=2)
        assert float(gaps.min(axis=1).max()) < 0.08
        # It uses both sides of the track, as the fine line does (to 0.12 m of each border).
        assert coarse.d.min() < -0.3 and coarse.d.max() > 0.3
        assert abs(coarse.lap_time / fine.lap_time - 1.0) < 0.02

    def test_smooth_frame_turns_evenly_between_waypoints(self) -> None:
        # A regular 12-gon of circumradius 5 m, driven counter-clockwise. At a side's midpoint
        # the normal is that side's inward normal; at a vertex it is the bisector of the two
        # sides', pointing at the centre; halfway between, it has turned half of 30 degrees.
        count, radius = 12, 5.0
        angles = 2.0 * math.pi * np.arange(count) / count
        track = Track(radius * np.stack([np.cos(angles), np.sin(angles)], axis=1), 0.5, 0.5,
                      name="dodecagon")
        side = track.length / count
        s = np.array([0.0, 0.25 * side, 0.5 * side, 7.5 * side])
        centre, normal = smooth_frame(track, s)
        np.testing.assert_allclose(centre[0], [radius, 0.0], atol=1e-12)
        # Inward normal at angle phi points along -(cos phi, sin phi): phi = 0 at vertex 0,
        # 15 degrees at side 0's midpoint, 7.5 degrees a quarter of the way along it.
        for phi, n in zip((0.0, 7.5, 15.0, 7 * 30.0 + 15.0), normal):
            expected = -np.array([math.cos(math.radians(phi)), math.sin(math.radians(phi))])
            np.testing.assert_allclose(n, expected, atol=1e-9)

    def test_track_offsets_inverts_point_at_on_a_fine_track(self) -> None:
        track = load_track("kidney")
        s = np.linspace(0.0, track.length, 400, endpoint=False)
        d = 0.3 * np.sin(2.0 * math.pi * 3.0 * s / track.length)
        np.testing.assert_allclose(track_offsets(track, s, track.point_at(s, d)), d, atol=2e-3)
