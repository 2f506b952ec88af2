"""Funnels whose narrow part is a run of tight corners ([procedural] funnel_corners,
h2h_racing.training.track_funnel_runs): the run's curvature worked by hand, the splice keeping
it and closing the loop, a generated run track's corners (count, signs, radii) and widths at a
fixed seed, bad settings refused, and the default leaving step 8's funnels as they were."""

from __future__ import annotations

import numpy as np
import pytest

from h2h_racing.track.generator import border_polylines, find_crossings
from h2h_racing.track.shape import Track
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.track_funnel_runs import (
    CORNER_GAP,
    CORNER_TURN,
    corner_run_curvature,
    corner_signs,
    funnel_run_track,
    splice_run,
)
from h2h_racing.training.track_funnels import funnel_track
from h2h_racing.training.tracks import ProceduralTracks

RANGES = {"entry": (1.2, 1.6), "width": (0.6, 0.75), "ramp": (1.5, 2.5), "radius": (0.45, 0.6)}


def test_run_curvature_by_hand() -> None:
    # Corner 1: 0.5 m radius turning 0.5 rad left: 0.25 m, 5 segments of +2 /m; a 0.2 m
    # straight (4 segments); corner 2: 0.4 m turning 0.5 rad right: 0.2 m, 4 segments of
    # -2.5 /m. 13 segments, box-filtered over 0.2 m (4 segments): 4 more, 17.
    kappa = corner_run_curvature(np.array([0.5, 0.4]), np.array([0.5, 0.5]),
                                 np.array([1.0, -1.0]), np.array([0.2]), spacing=0.05)
    assert len(kappa) == 17
    # The filter keeps each corner's turn and full curvature where it spans the corner alone
    # (4 segments fit in both; the 4-segment straight keeps the corners apart).
    assert kappa.max() == pytest.approx(2.0) and kappa.min() == pytest.approx(-2.5)
    left, right = kappa[kappa > 0], kappa[kappa < 0]
    assert left.sum() * 0.05 == pytest.approx(0.5) and right.sum() * 0.05 == pytest.approx(-0.5)
    assert np.flatnonzero(kappa > 0).max() < np.flatnonzero(kappa < 0).min()
    # A turn not a whole number of segments: 0.5 m turning 0.33 rad is 3.3 -> 3 segments of
    # 2 /m (the radius kept), each corner turning 0.3 rad.
    one = corner_run_curvature(np.array([0.5, 0.5]), np.array([0.33, 0.33]),
                               np.array([1.0, 1.0]), np.array([0.0]), spacing=0.05)
    assert one.sum() * 0.05 == pytest.approx(0.6)
    assert one.max() == pytest.approx(2.0)
    with pytest.raises(ValueError, match="a run of 2 corners needs 2 turns and signs and 1 gaps"):
        corner_run_curvature(np.array([0.5, 0.5]), np.array([0.5, 0.5]), np.array([1.0, 1.0]),
                             np.array([]))


def test_corner_signs() -> None:
    rng = np.random.default_rng(3)
    alternate = corner_signs(rng, 5, "alternate")
    assert set(np.abs(alternate)) == {1.0} and np.all(alternate[1:] == -alternate[:-1])
    same = corner_signs(rng, 4, "same")
    assert np.all(same == same[0]) and abs(same[0]) == 1.0
    mixed = corner_signs(np.random.default_rng(0), 200, "mixed")
    # Binomial(200, 0.5) at a fixed seed: both ways drawn, about as often.
    assert 70 <= (mixed > 0).sum() <= 130 and set(mixed) == {-1.0, 1.0}
    with pytest.raises(ValueError, match="turns must be one of"):
        corner_signs(rng, 3, "left")


def test_splice_keeps_the_run_and_closes_the_loop() -> None:
    # A circle of 5 m radius, 628 vertices ~0.05 m apart; a run of two corners spliced at 100.
    count = 628
    angle = 2 * np.pi * np.arange(count) / count
    circle = 5.0 * np.stack([np.cos(angle), np.sin(angle)], axis=1)
    run = corner_run_curvature(np.array([0.5, 0.5]), np.array([1.2, 1.2]),
                               np.array([1.0, -1.0]), np.array([0.3]), spacing=0.05)
    out = splice_run(circle, 100, run)
    assert len(out) == count
    assert np.allclose(out[0], circle[100])
    seg = np.diff(np.vstack([out, out[:1]]), axis=0)
    length = np.linalg.norm(seg, axis=1)
    heading = np.unwrap(np.arctan2(seg[:, 1], seg[:, 0]))
    # Vertex 0's outgoing heading is the circle's there; the run's vertices turn as asked.
    start = np.arctan2(*(circle[101] - circle[100])[::-1])
    assert np.angle(np.exp(1j * (heading[0] - start))) == pytest.approx(0.0, abs=1e-9)
    assert np.allclose(np.diff(heading[:len(run)]), run[:len(run) - 1] * length[:len(run) - 1])
    # Closed: the last vertex is one ordinary segment from the first, and the whole loop
    # still turns once round.
    assert length[-1] == pytest.approx(length[len(run) + 5], rel=0.05)
    total = heading[-1] - heading[0] + np.angle(np.exp(1j * (heading[0] - heading[-1])))
    assert total == pytest.approx(2 * np.pi, abs=1e-6)


def _replayed(seed: int, corners: tuple[int, int], turns: str) -> dict:
    # funnel_run_track's draws, in its order, before any loop.
    rng = np.random.default_rng(seed)
    wide, narrow = rng.uniform(*RANGES["entry"]), rng.uniform(*RANGES["width"])
    rng.uniform(*RANGES["ramp"])
    count = int(rng.integers(corners[0], corners[1] + 1))
    radii = rng.uniform(*RANGES["radius"], size=count)
    rng.uniform(*CORNER_TURN, size=count)
    rng.uniform(*CORNER_GAP, size=count - 1)
    signs = corner_signs(rng, count, turns)
    return {"wide": wide, "narrow": narrow, "count": count, "radii": radii, "signs": signs}


def _corners_in_narrow_part(track: Track, narrow: float) -> tuple[list[float], list[float]]:
    """Signs and radii of the corners tighter than 1 / 0.72 m (1.2 x the widest run radius)
    where the track is ``narrow`` wide: one entry per run of such 1 cm samples."""
    s = np.arange(0.0, track.length, 0.01)
    kappa = track.curvature_at(s)
    left, right = track.half_widths_at(s)
    inside = np.flatnonzero(left + right <= narrow + 1e-3)
    tight = inside[np.abs(kappa[inside]) > 1.0 / 0.72]
    groups = np.split(tight, np.flatnonzero(np.diff(tight) > 1) + 1)
    signs = [float(np.sign(kappa[g[0]])) for g in groups]
    radii = [float(1.0 / np.abs(kappa[g]).max()) for g in groups]
    return signs, radii


@pytest.mark.parametrize("seed, corners, turns", [(0, (3, 3), "alternate"),
                                                   (4, (2, 4), "mixed")])
def test_a_run_track_at_a_fixed_seed(seed: int, corners: tuple[int, int], turns: str) -> None:
    drawn = _replayed(seed, corners, turns)
    spec = funnel_run_track(np.random.default_rng(seed), length=(15.0, 45.0), **RANGES,
                            corners=corners, turns=turns)
    track = Track(spec.centre, spec.width_left, spec.width_right, name=spec.name)
    assert spec.name.startswith("funnel-") and 15.0 <= track.length <= 45.0
    s = np.arange(0.0, track.length, 0.01)
    left, right = track.half_widths_at(s)
    width = left + right
    # The run is the drawn narrow width, the rest the drawn wide width at most.
    assert width.min() == pytest.approx(drawn["narrow"], abs=1e-3)
    assert width.max() == pytest.approx(drawn["wide"], abs=1e-3)
    # Its corners: as many as drawn, turning as drawn, each of its drawn radius (to the
    # polyline's 3 %), all where the track is narrow.
    signs, radii = _corners_in_narrow_part(track, drawn["narrow"])
    assert len(signs) == drawn["count"]
    if turns == "alternate":
        assert all(a == -b for a, b in zip(signs[:-1], signs[1:]))
    assert signs == list(drawn["signs"]) or signs == list(drawn["signs"][::-1])
    expected = drawn["radii"] if signs == list(drawn["signs"]) else drawn["radii"][::-1]
    assert np.allclose(radii, expected, rtol=0.03)
    # Nowhere else a corner that tight; the track valid.
    kappa = np.abs(track.curvature_at(s))
    assert (kappa[width > drawn["narrow"] + 0.05] < 1.0 / 0.72).all()
    lb, rb = border_polylines(spec.centre, spec.width_left, spec.width_right)
    assert len(find_crossings(spec.centre)) == 0 and len(find_crossings(lb, rb)) == 0


def test_procedural_tracks_draw_runs_only_when_asked() -> None:
    proc = ProceduralTracks(funnel_share=1.0, funnel_corners=(3, 3), length=(15.0, 30.0),
                            funnel_radius=(0.45, 0.6))
    track = proc.draw(np.random.default_rng(1))
    assert "run of 3 corners" in track.description
    # The default (0, 0): step 8's one-bend funnel, the same track funnel_track draws.
    step8 = ProceduralTracks(funnel_share=1.0, length=(15.0, 30.0))
    assert step8.funnel_corners == (0, 0)
    rng = np.random.default_rng(1)
    rng.random()  # the share's draw
    direct = funnel_track(rng, length=(15.0, 30.0), entry=step8.funnel_entry,
                          width=step8.funnel_width, ramp=step8.funnel_ramp,
                          radius=step8.funnel_radius)
    assert step8.draw(np.random.default_rng(1)).name == direct.name


@pytest.mark.parametrize("fields, words", [
    ({"funnel_corners": (1, 3)}, "funnel_corners must be (0, 0) (one tight bend) or"),
    ({"funnel_corners": (4, 3)}, "2 <= fewest <= most <= 6 corners"),
    ({"funnel_corners": (2, 7)}, "got (2, 7)"),
    ({"funnel_corners": (2.0, 3)}, "ints with"),
    ({"funnel_turns": "left"}, "funnel_turns must be one of ['alternate', 'same', 'mixed'], "
                               "got 'left'"),
])
def test_bad_run_settings_are_refused(fields: dict, words: str) -> None:
    with pytest.raises(ValueError) as err:
        ProceduralTracks(**fields)
    assert words in str(err.value)


def test_run_settings_read_from_a_config_table() -> None:
    config = TrainConfig.from_dict({"procedural": {"funnel_share": 0.1, "funnel_corners": [3, 5],
                                                   "funnel_turns": "mixed"}})
    assert config.procedural.funnel_corners == (3, 5)
    assert config.procedural.funnel_turns == "mixed"
    with pytest.raises(ValueError, match="funnel_corners"):
        TrainConfig.from_dict({"procedural": {"funnel_corners": 3}})
