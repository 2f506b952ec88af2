"""Funnel tracks ([procedural] funnel_share, h2h_racing.training.track_funnels): the width
profile worked by hand, a generated funnel's width drop and bend radius at a fixed seed,
the share drawn, bad settings refused, and the defaults leaving the tracks as before."""

from __future__ import annotations

import numpy as np
import pytest

from h2h_racing.config.shipped import resolve_config
from h2h_racing.track.generator import border_polylines, find_crossings
from h2h_racing.track.shape import Track
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.track_funnels import OTHER_RAMP, funnel_track, funnel_widths
from h2h_racing.training.tracks import ProceduralTracks

RANGES = {"entry": (1.2, 1.6), "width": (0.6, 0.75), "ramp": (1.5, 2.5), "radius": (0.5, 0.9)}


def test_width_profile_by_hand() -> None:
    # 10 m lap, 100 vertices 0.1 m apart; narrow (0.6) on vertices 0-4, 2 m ramps to 1.4.
    w = funnel_widths(10.0, 100, 1.4, 0.6, (0, 4), 2.0)
    assert w[0] == w[4] == pytest.approx(0.6)
    assert w[14] == pytest.approx(1.0)  # 1 m after: half-way, smoothstep(0.5) = 0.5
    assert w[9] == pytest.approx(0.6 + 0.8 * (0.25 ** 2 * (3 - 0.5)))  # 0.5 m: x = 0.25
    assert w[24] == w[50] == pytest.approx(1.4)
    assert w[90] == pytest.approx(1.0)  # 1 m before vertex 0, round the loop
    # Another corner's limit (0.8 m at vertex 50) narrows the track there and fades over
    # OTHER_RAMP: 1.5 m away (x = 0.5) half-way from 0.8 to 1.4.
    limits = np.full(100, np.inf)
    limits[50] = 0.8
    w = funnel_widths(10.0, 100, 1.4, 0.6, (0, 4), 2.0, limits)
    assert w[50] == pytest.approx(0.8)
    half = int(round(0.5 * OTHER_RAMP / 0.1))
    assert w[50 + half] == pytest.approx(1.1)
    assert w[0] == pytest.approx(0.6)


def test_a_funnel_track_narrows_into_its_bend_at_a_fixed_seed() -> None:
    spec = funnel_track(np.random.default_rng(0), length=(15.0, 45.0), **RANGES)
    # Its four draws come first: replayed here.
    replay = np.random.default_rng(0)
    wide, narrow = replay.uniform(1.2, 1.6), replay.uniform(0.6, 0.75)
    radius, ramp = replay.uniform(0.5, 0.9), replay.uniform(1.5, 2.5)
    track = Track(spec.centre, spec.width_left, spec.width_right, name=spec.name)
    assert 15.0 <= track.length <= 45.0
    s = np.arange(0.0, track.length, 0.01)
    kappa = np.abs(track.curvature_at(s))
    left, right = track.half_widths_at(s)
    width = left + right
    apex = int(np.argmax(kappa))
    # The bend: its tightest corner has the drawn radius (to the polyline's 3 %), and the
    # track is the drawn narrow width through it and the drawn wide width away from it.
    assert 1.0 / kappa[apex] == pytest.approx(radius, rel=0.03)
    assert width[apex] == pytest.approx(narrow, abs=1e-3)
    assert width.min() == pytest.approx(narrow, abs=1e-3)
    assert width.max() == pytest.approx(wide, abs=1e-3)
    # Before the bend: the width falls to narrow from at least funnel_entry's low end (the
    # approach's own curvature may cap it under the drawn wide) within the ramp + 0.5 m.
    i = apex
    while width[i - 1] <= narrow + 1e-3:
        i -= 1
    start = s[i]
    approach = np.mod(start - ramp - np.linspace(0.0, 0.5, 51), track.length)
    entry = np.interp(approach, s, width).max()
    assert entry >= 1.2
    assert entry / narrow > 1.5  # a funnel by experiments/.../tokyo/funnels.py's measure
    # Valid: no crossing of the centre line or the borders (Track checked the folds).
    lb, rb = border_polylines(spec.centre, spec.width_left, spec.width_right)
    assert len(find_crossings(spec.centre)) == 0 and len(find_crossings(lb, rb)) == 0


def test_the_share_of_funnel_tracks() -> None:
    def funnels(share: float, draws: int) -> int:
        proc = ProceduralTracks(funnel_share=share, length=(15.0, 30.0))
        rng = np.random.default_rng(5)
        return sum(proc.draw(rng).name.startswith("funnel-") for _ in range(draws))

    assert funnels(0.0, 6) == 0
    assert funnels(1.0, 4) == 4
    # Binomial(24, 0.5): 5-19 with probability 0.998; the seed is fixed, so this is exact.
    assert 5 <= funnels(0.5, 24) <= 19


def test_waypoints_stay_close_on_funnel_tracks() -> None:
    # Re-drawn through waypoints up to 0.8 m apart a 0.5 m bend would round off to ~0.8 m.
    proc = ProceduralTracks(funnel_share=1.0, waypoint_gap=(0.05, 0.8), length=(15.0, 30.0))
    track = proc.draw(np.random.default_rng(2))
    gaps = np.linalg.norm(np.diff(track.centre, axis=0), axis=1)
    assert gaps.max() <= 0.1 + 1e-9


@pytest.mark.parametrize("fields, words", [
    ({"funnel_share": 1.5}, "funnel_share must be in [0, 1]"),
    ({"funnel_width": (0.75, 0.6)}, "funnel_width must be (low, high)"),
    ({"funnel_entry": (1.2, 3.0)}, "funnel_entry must be (low, high) with 0.6"),
    ({"funnel_ramp": (0.1, 2.0)}, "funnel_ramp must be (low, high) with 0.5"),
    ({"funnel_width": (0.6, 1.3)}, "must stay under funnel_entry's low end"),
    ({"funnel_radius": (0.4, 0.9)}, "at least 0.6 x funnel_width's high end (0.450 m"),
])
def test_bad_funnel_settings_are_refused(fields: dict, words: str) -> None:
    with pytest.raises(ValueError) as err:
        ProceduralTracks(**fields)
    assert words in str(err.value)


def test_unknown_and_mistyped_funnel_keys_are_refused() -> None:
    with pytest.raises(ValueError, match="funnel_shares"):
        TrainConfig.from_dict({"procedural": {"funnel_shares": 0.2}})
    with pytest.raises(ValueError, match="funnel_radius"):
        TrainConfig.from_dict({"procedural": {"funnel_radius": 0.6}})
    config = TrainConfig.from_dict({"procedural": {"funnel_share": 0.2,
                                                   "funnel_radius": [0.5, 0.7]}})
    assert config.procedural.funnel_radius == (0.5, 0.7)


# Drawn by the code before funnel_share existed (commit 1cf5c49), ppo_generalist/routes'
# [procedural] at seed 7: name, lap [m], vertices, narrowest width [m] of each of 6 tracks.
BEFORE = [("random-0c22bcc7-cw", 40.5435, 57, 1.0217), ("random-45a123df", 15.3292, 53, 0.8008),
          ("random-ac6e8459-cw", 38.5793, 182, 0.9242),
          ("random-3569b9c2-cw", 19.9573, 38, 1.2511),
          ("circuit-8a80308f-cw", 68.6084, 125, 0.9966),
          ("circuit-c7cd1435", 87.7722, 167, 1.0632)]


def test_the_defaults_draw_the_same_tracks_as_before() -> None:
    proc = TrainConfig.from_toml(resolve_config("ppo_generalist/routes", "train")).procedural
    assert proc.funnel_share == 0.0
    rng = np.random.default_rng(7)
    drawn = []
    for _ in range(6):
        track = proc.draw(rng)
        drawn.append((track.name, round(track.length, 4), len(track.centre),
                      round(float(track.width_left.min() + track.width_right.min()), 4)))
    assert drawn == BEFORE
