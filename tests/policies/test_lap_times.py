"""The minimum-time reference lap and the lap-time estimates of ``h2h-racing tracks``
(:mod:`h2h_racing.policies.lap_times`, ``racing_line.reference_lap_time``)."""

from __future__ import annotations

import math
import sys

import pytest

from h2h_racing.config.env import EnvConfig
from h2h_racing.policies import compute_race_line, reference_lap_time
from h2h_racing.policies.lap_times import TrackLaps, track_laps
from h2h_racing.track.io import list_tracks, load_track

GRAVITY = 9.81  # [m/s^2], racing_line.GRAVITY


class TestReferenceLap:
    """The racing line's path at the car's full grip: by hand on a circle, and below
    racing_line's own profile on every shipped track."""

    def test_circle_by_hand(self) -> None:
        # On a circle every point of the line has the same curvature 1 / r, so the profile is
        # flat: v = sqrt(mu g r) (mu = 1; below the 4 m/s top speed for r < 1.63 m) and the lap
        # is the path's length over v. racing_line's profile corners at 0.6 mu g: its lap is
        # 1 / sqrt(0.6) = 1.291 times as long.
        track = sys.modules["conftest"].circle_track(radius=1.2, half_width=0.4, vertices=240)
        config = EnvConfig()
        assert config.car.friction == 1.0 and config.max_speed == 4.0
        reference = reference_lap_time(track, config.car, config.max_speed)
        path = compute_race_line(track, config.car, config.max_speed).path_length
        radius = path / (2 * math.pi)
        assert math.sqrt(GRAVITY * radius) < 4.0
        assert reference == pytest.approx(path / math.sqrt(GRAVITY * radius), rel=1e-3)
        laps = track_laps(track, config)
        assert laps.reference == reference
        assert laps.racing_line / reference == pytest.approx(1 / math.sqrt(0.6), rel=1e-3)
        # (1.291 - 1) * 100 = 29.1 % slower.
        assert laps.margin == pytest.approx(100 * (1 / math.sqrt(0.6) - 1), rel=1e-3)

    @pytest.mark.parametrize("name", list_tracks())
    def test_below_racing_lines_profile_on_every_shipped_track(self, name: str) -> None:
        # Full grip, acceleration and braking on the same path: faster everywhere, so a shorter
        # lap; but not by more than the grip alone gives (laps at most 1 / sqrt(0.6) longer).
        laps = track_laps(load_track(name))
        assert laps.reference < laps.racing_line < laps.reference / math.sqrt(0.6)
        assert laps.width_min <= laps.width_max and laps.length > 0

    def test_row_shows_the_figures(self) -> None:
        laps = TrackLaps(name="oval", length=20.0, width_min=1.07, width_max=1.07,
                         reference=4.77, racing_line=5.15)
        # (5.15 / 4.77 - 1) * 100 = 7.97 %.
        assert laps.row().split() == ["oval", "20.00", "1.07-1.07", "4.77", "5.15", "8.0"]
        assert TrackLaps.header().split()[5:9] == ["reference", "s", "racing_line", "s"]
