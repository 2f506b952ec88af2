"""Tests for h2h_racing.track.generator and the shipped track catalogue (tracks/*.json)."""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from h2h_racing.track.generator import (
    TRACK_FORMAT,
    TrackSpec,
    border_polylines,
    closed_length,
    curvature,
    find_crossings,
    measure_track,
    min_radius_of_curvature,
    random_track,
    signed_area,
    smooth_closed_curve,
)

TRACKS_DIR = Path(__file__).resolve().parents[3] / "tracks"
CATALOGUE = ("oval", "technical", "speedway", "grand_loop", "kidney", "varying", "hairpin_valley")
REQUIRED_KEYS = {"format", "name", "description", "x", "y", "width_left", "width_right"}
NUM_RANDOM_SEEDS = 50

# An irregular closed shape (the speedway's control points) for spacing tests.
IRREGULAR = np.array(
    [
        (0.0, 0.0),
        (3.5, 0.0),
        (5.6, 0.3),
        (6.8, 1.4),
        (7.1, 2.8),
        (6.6, 4.2),
        (5.4, 5.0),
        (3.5, 5.2),
        (1.5, 4.7),
        (-0.5, 4.3),
        (-2.5, 4.6),
        (-4.5, 5.0),
        (-6.0, 4.5),
        (-6.9, 3.2),
        (-6.8, 1.6),
        (-5.8, 0.4),
        (-3.8, 0.0),
    ]
)


def circle(radius: float, num: int, clockwise: bool = False) -> np.ndarray:
    """Return ``num`` points on a circle of ``radius`` about the origin, starting at (radius, 0)."""
    angles = np.linspace(0.0, 2 * np.pi, num, endpoint=False)
    if clockwise:
        angles = -angles
    return radius * np.c_[np.cos(angles), np.sin(angles)]


def brute_force_crossings(*polylines: np.ndarray) -> set[tuple[int, int, int, int]]:
    """Independent, plain-Python O(n^2) check: every pair of closed-polyline segments that cross or touch.

    Segments ``(k, i)`` and ``(l, j)`` are skipped when they are the same or neighbours in one polyline.
    """

    def orient(a, b, c) -> float:
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])

    def on_segment(a, b, c) -> bool:  # c collinear with ab: is it inside ab's box?
        return min(a[0], b[0]) <= c[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= c[1] <= max(a[1], b[1])

    segments = []
    for k, poly in enumerate(polylines):
        pts = [tuple(p) for p in np.asarray(poly, dtype=float)]
        n = len(pts)
        segments += [(k, i, n, pts[i], pts[(i + 1) % n]) for i in range(n)]
    found = set()
    for a in range(len(segments)):
        k, i, n, p1, p2 = segments[a]
        for b in range(a + 1, len(segments)):
            other, j, _, q1, q2 = segments[b]
            if k == other and (abs(i - j) in (1, n - 1)):
                continue
            d1, d2, d3, d4 = orient(p1, p2, q1), orient(p1, p2, q2), orient(q1, q2, p1), orient(q1, q2, p2)
            proper = d1 * d2 < 0 and d3 * d4 < 0
            touching = (
                (d1 == 0 and on_segment(p1, p2, q1))
                or (d2 == 0 and on_segment(p1, p2, q2))
                or (d3 == 0 and on_segment(q1, q2, p1))
                or (d4 == 0 and on_segment(q1, q2, p2))
            )
            if proper or touching:
                found.add((k, i, other, j))
    return found


def load_design_module():
    """Import tracks/design.py by path (it is a script, not part of the test's import path)."""
    name = "tracks_design"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, TRACKS_DIR / "design.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up in sys.modules
    spec.loader.exec_module(module)
    return module


class TestSmoothClosedCurve:
    """The periodic spline passes through its control points and is sampled at uniform arc length."""

    def test_circle_radius_and_curvature(self):
        # 16 control points on a circle of R = 3 m. The interpolating spline through them hugs the circle:
        # lap = 2 pi R = 18.850 m, so M = round(18.850 / 0.05) = 377 vertices; every vertex at distance
        # R = 3 m from the centre and curvature 1 / R = 0.3333 1/m, up to the spline's approximation error
        # (measured: 2e-4 m in radius, 1.2 % in curvature), bounded here by 1e-3 m and 2 %.
        radius = 3.0
        curve = smooth_closed_curve(circle(radius, 16), spacing=0.05)
        assert curve.shape == (377, 2)
        np.testing.assert_allclose(np.hypot(curve[:, 0], curve[:, 1]), radius, atol=1e-3)
        np.testing.assert_allclose(curvature(curve), 1.0 / radius, rtol=0.02)
        assert closed_length(curve) == pytest.approx(2 * math.pi * radius, rel=1e-4)

    def test_spacing_is_uniform_on_an_irregular_shape(self):
        curve = smooth_closed_curve(IRREGULAR, spacing=0.05)
        gaps = np.linalg.norm(np.roll(curve, -1, axis=0) - curve, axis=1)  # includes the closing gap
        mean = gaps.mean()
        assert mean == pytest.approx(0.05, rel=0.02)
        np.testing.assert_allclose(gaps, mean, rtol=1e-3)

    def test_passes_through_control_points_and_starts_at_the_first(self):
        curve = smooth_closed_curve(IRREGULAR, spacing=0.02)
        np.testing.assert_array_equal(curve[0], IRREGULAR[0])
        assert not np.allclose(curve[-1], curve[0]), "first vertex must not be repeated"
        nearest = np.min(np.linalg.norm(IRREGULAR[:, None, :] - curve[None, :, :], axis=2), axis=1)
        assert np.all(nearest <= 0.01 + 1e-9)  # within half a spacing of some vertex

    def test_keeps_the_driving_direction(self):
        assert signed_area(smooth_closed_curve(circle(2.0, 8), 0.05)) > 0
        assert signed_area(smooth_closed_curve(circle(2.0, 8, clockwise=True), 0.05)) < 0
        assert np.all(curvature(smooth_closed_curve(circle(2.0, 8, clockwise=True), 0.05)) < 0)

    def test_is_scale_covariant(self):
        # Chord-length knots scale with the points, so scaling the input scales the curve.
        small = smooth_closed_curve(IRREGULAR, spacing=0.05)
        big = smooth_closed_curve(2.0 * IRREGULAR, spacing=0.1)
        np.testing.assert_allclose(big, 2.0 * small, atol=1e-6)

    @pytest.mark.parametrize(
        ("points", "spacing", "match"),
        [
            (np.zeros((2, 2)), 0.05, "shape"),
            (np.zeros((5, 3)), 0.05, "shape"),
            ([[0, 0], [1, 0], [1, 0], [0, 1]], 0.05, "distinct consecutive"),
            ([[0, 0], [1, 0], [0, 1], [0, 0]], 0.05, "do not repeat the first point"),
            ([[0, 0], [1, 0], [np.nan, 1]], 0.05, "finite"),
            (circle(1.0, 6), 0.0, "spacing"),
        ],
    )
    def test_rejects_bad_input(self, points, spacing, match):
        with pytest.raises(ValueError, match=match):
            smooth_closed_curve(points, spacing=spacing)


class TestGeometryHelpers:
    """Curvature, crossing detection and track measurement on hand-made shapes."""

    def test_curvature_sign_and_value(self):
        # Points on a circle: Menger curvature is exactly 1/R = 1/2, negative when driven clockwise.
        np.testing.assert_allclose(curvature(circle(2.0, 50)), 0.5)
        np.testing.assert_allclose(curvature(circle(2.0, 50, clockwise=True)), -0.5)
        assert min_radius_of_curvature(circle(2.0, 50)) == pytest.approx(2.0)

    def test_crossings_of_simple_shapes(self):
        assert find_crossings(circle(1.0, 40)).shape == (0, 4)
        assert find_crossings(circle(1.0, 40), circle(2.0, 40)).shape == (0, 4)
        # A figure eight crosses itself once, at the origin: x = sin(2t), y = sin(t).
        t = np.linspace(0, 2 * np.pi, 101, endpoint=False)
        eight = np.c_[np.sin(2 * t), np.sin(t)]
        assert len(find_crossings(eight)) >= 1
        # Two unit circles 1 m apart cross at two points, so at least two segment pairs.
        pairs = find_crossings(circle(1.0, 40), circle(1.0, 40) + np.array([1.0, 0.0]))
        assert len(pairs) >= 2
        assert set(pairs[:, 0].tolist()) == {0} and set(pairs[:, 2].tolist()) == {1}

    @pytest.mark.parametrize("seed", range(8))
    def test_crossings_match_brute_force_on_random_polygons(self, seed):
        rng = np.random.default_rng(seed)
        polygons = [rng.uniform(-1, 1, (rng.integers(3, 15), 2)) for _ in range(2)]
        fast = {tuple(row) for row in find_crossings(*polygons, chunk=5).tolist()}
        assert fast == brute_force_crossings(*polygons)

    def test_measure_track_on_a_ring(self):
        # A 2 m-radius ring, 1 m wide: length 2 pi 2 = 12.566 m; min radius / half-width = 2 / 0.5 = 4.
        # (24 control points keep the spline within ~1e-5 relative of the circle.)
        centre = smooth_closed_curve(circle(2.0, 24), spacing=0.05)
        metrics = measure_track(centre, 0.5, 0.5)
        assert metrics.length == pytest.approx(4 * math.pi, rel=1e-4)
        assert metrics.min_radius == pytest.approx(2.0, rel=0.02)
        assert metrics.min_radius_ratio == pytest.approx(4.0, rel=0.02)
        assert metrics.counter_clockwise and metrics.is_simple
        # 4.4 m wide: the inner border has radius 2 - 2.2 < 0, a small circle turned inside out. It does
        # not cross itself, so only the radius rule catches it: ratio 2 / 2.2 = 0.91 < 1.
        assert measure_track(centre, 2.2, 2.2).min_radius_ratio == pytest.approx(2 / 2.2, rel=0.02)

    def test_too_wide_for_a_corner_makes_the_inner_border_loop(self):
        # On a real shape only the tight corners fold: the inner border makes a swallow-tail loop there.
        centre = smooth_closed_curve(IRREGULAR, spacing=0.05)
        half_width = 1.5 * min_radius_of_curvature(centre)
        metrics = measure_track(centre, half_width, half_width)
        assert metrics.border_crossings > 0
        assert not metrics.is_simple

    def test_track_spec_validates_and_freezes(self):
        centre = circle(2.0, 10)
        spec = TrackSpec("ring", "a ring", centre, np.full(10, 0.5), np.full(10, 0.5))
        with pytest.raises(ValueError):
            spec.centre[0, 0] = 1.0
        with pytest.raises(ValueError, match="width_left"):
            TrackSpec("ring", "a ring", centre, np.full(9, 0.5), np.full(10, 0.5))
        with pytest.raises(ValueError, match="width_right"):
            TrackSpec("ring", "a ring", centre, np.full(10, 0.5), np.zeros(10))
        document = spec.to_dict()
        assert set(document) == REQUIRED_KEYS and document["format"] == TRACK_FORMAT


class TestRandomTrack:
    """Seeded random tracks are deterministic, inside their bounds and never self-intersecting."""

    def test_same_seed_same_track(self):
        a = random_track(np.random.default_rng(123))
        b = random_track(np.random.default_rng(123))
        assert a.name == b.name
        np.testing.assert_array_equal(a.centre, b.centre)
        np.testing.assert_array_equal(a.width_left, b.width_left)
        np.testing.assert_array_equal(a.width_right, b.width_right)

    def test_different_seed_different_track(self):
        a = random_track(np.random.default_rng(1))
        b = random_track(np.random.default_rng(2))
        assert a.name != b.name
        assert a.centre.shape != b.centre.shape or not np.allclose(a.centre, b.centre)

    def test_advances_the_generator_it_is_given(self):
        rng = np.random.default_rng(7)
        first, second = random_track(rng), random_track(rng)
        assert first.name != second.name

    def test_many_seeds_are_valid(self):
        length_range, width = (20.0, 45.0), 1.0
        min_radius = max(0.6, 1.2 * width / 2)  # = 0.6 m
        for seed in range(NUM_RANDOM_SEEDS):
            spec = random_track(np.random.default_rng(seed), length_range=length_range, width=width)
            # The lap is scaled to the drawn length; resampling moves it by far less than a millimetre.
            assert length_range[0] - 1e-3 <= spec.length <= length_range[1] + 1e-3, (seed, spec.length)
            assert min_radius_of_curvature(spec.centre) >= min_radius, seed
            assert signed_area(spec.centre) > 0, seed
            np.testing.assert_array_equal(spec.width_left + spec.width_right, width)
            # Independent check on every 8th vertex (0.4 m apart): plain O(n^2) segment tests.
            left, right = border_polylines(spec.centre, spec.width_left, spec.width_right)
            assert not brute_force_crossings(spec.centre[::8]), seed
            assert not brute_force_crossings(left[::8], right[::8]), seed

    def test_varying_width_spans_its_bounds_smoothly(self):
        for seed in range(5):
            spec = random_track(np.random.default_rng(seed), width=(0.76, 1.07))
            np.testing.assert_array_equal(spec.width_left, spec.width_right)
            # The profile is rescaled onto [0.76, 1.07] m: half-widths 0.38 and 0.535 m are reached.
            assert spec.width_left.min() == pytest.approx(0.38)
            assert spec.width_left.max() == pytest.approx(0.535)
            # Smooth: at most 3 harmonics of the lap over >= 400 vertices (20 m / 5 cm), so neighbours
            # differ by a small fraction of the 0.155 m half-width range (a step would be all of it).
            assert np.abs(np.diff(spec.width_left)).max() < 0.155 / 10
            left, right = border_polylines(spec.centre, spec.width_left, spec.width_right)
            assert not brute_force_crossings(left[::8], right[::8]), seed
            assert "0.76-1.07 m wide" in spec.description

    def test_bad_width_rejected(self):
        for width in ((1.0, 0.8), (0.0, 1.0), (0.8,), float("nan")):
            with pytest.raises(ValueError, match="narrowest, widest"):
                random_track(np.random.default_rng(0), width=width)

    def test_respects_custom_bounds(self):
        spec = random_track(np.random.default_rng(0), length_range=(15.0, 16.0), width=0.76, spacing=0.1)
        assert 15.0 - 1e-3 <= spec.length <= 16.0 + 1e-3
        assert np.all(spec.width_left == 0.38)
        gaps = np.linalg.norm(np.diff(spec.centre, axis=0), axis=1)
        np.testing.assert_allclose(gaps, spec.length / len(spec.centre), rtol=1e-3)
        assert measure_track(spec.centre, spec.width_left, spec.width_right).is_simple

    def test_gives_up_with_a_clear_error(self):
        # A 3 m lap is at most a circle of radius 3 / (2 pi) = 0.48 m < the 0.6 m minimum radius.
        with pytest.raises(RuntimeError, match="no valid track in 5 tries"):
            random_track(np.random.default_rng(0), length_range=(3.0, 3.0), max_tries=5)

    @pytest.mark.parametrize(
        ("kwargs", "error"),
        [
            ({"length_range": (30.0, 20.0)}, ValueError),
            ({"width": 0.0}, ValueError),
            ({"min_radius": 0.4, "width": 1.0}, ValueError),
            ({"spacing": -0.1}, ValueError),
            ({"max_tries": 0}, ValueError),
        ],
    )
    def test_rejects_bad_arguments(self, kwargs, error):
        with pytest.raises(error):
            random_track(np.random.default_rng(0), **kwargs)

    def test_requires_a_generator(self):
        with pytest.raises(TypeError, match="default_rng"):
            random_track(0)  # type: ignore[arg-type]

    def test_no_chicanes_draws_nothing(self):
        # Older calls give the same tracks: without chicanes nothing more is drawn.
        a = random_track(np.random.default_rng(3))
        b = random_track(np.random.default_rng(3), chicanes=(0, 0))
        np.testing.assert_array_equal(a.centre, b.centre)

    def test_chicane_is_one_swerve_out_and_back(self):
        from h2h_racing.track.generator import _add_chicanes

        # A 10 m circle, 1 cm vertices: one chicane moves a 2-4 m stretch sideways by
        # y = A sin(2 pi u)(1 - cos(2 pi u)) / 2, whose extremes are +-3 sqrt(3) / 8 A = +-0.6495 A
        # (at u = 1/3 and 2/3) with |A| in [0.1, 0.35]: out one way, then the other.
        angle = np.linspace(0, 2 * np.pi, 6284, endpoint=False)
        circle = 10.0 * np.c_[np.cos(angle), np.sin(angle)]
        for seed in range(5):
            moved = _add_chicanes(np.random.default_rng(seed), circle, count=1)
            shift = np.linalg.norm(moved, axis=1) - 10.0
            stretch = np.count_nonzero(np.abs(shift) > 1e-12) * 0.01  # [m]
            assert 1.9 <= stretch <= 4.0, (seed, stretch)
            assert shift.max() == pytest.approx(-shift.min(), rel=1e-3)
            assert 0.6495 * 0.1 - 1e-3 <= shift.max() <= 0.6495 * 0.35 + 1e-3, seed

    def test_tracks_with_chicanes_are_valid(self):
        plain_turns, chicane_turns = [], []
        for seed in range(NUM_RANDOM_SEEDS):
            spec = random_track(np.random.default_rng(seed), chicanes=(2, 3))
            assert min_radius_of_curvature(spec.centre) >= 0.6, seed
            left, right = border_polylines(spec.centre, spec.width_left, spec.width_right)
            assert not brute_force_crossings(spec.centre[::8]), seed
            assert not brute_force_crossings(left[::8], right[::8]), seed
            chicane_turns.append(-curvature(spec.centre).min())
            plain_turns.append(-curvature(random_track(np.random.default_rng(seed)).centre).min())
        # The loops run anticlockwise: chicanes are what turns them right, sharply.
        assert np.median(chicane_turns) > 2 * np.median(plain_turns)

    @pytest.mark.parametrize("kwargs", [{"chicanes": (2, 1)}, {"chicanes": (-1, 0)},
                                        {"chicanes": (0.5, 1)}, {"radius_range": (0.0, 1.0)},
                                        {"radius_range": (0.9, 0.5)}])
    def test_rejects_bad_shape_arguments(self, kwargs):
        with pytest.raises(ValueError, match="chicanes|radius_range"):
            random_track(np.random.default_rng(0), **kwargs)


class TestCatalogue:
    """The shipped tracks/*.json files are valid, DeepRacer-scale and in sync with tracks/design.py."""

    @pytest.mark.parametrize("name", CATALOGUE)
    def test_track_file_is_valid(self, name):
        document = json.loads((TRACKS_DIR / f"{name}.json").read_text(encoding="utf-8"))
        assert set(document) == REQUIRED_KEYS
        assert document["format"] == TRACK_FORMAT and document["name"] == name
        assert isinstance(document["description"], str) and document["description"]
        centre = np.c_[document["x"], document["y"]]
        width_left = np.asarray(document["width_left"])
        width_right = np.asarray(document["width_right"])
        assert len(width_left) == len(width_right) == len(centre)
        assert not np.allclose(centre[0], centre[-1]), "first vertex must not be repeated"
        # Rounded to 1e-4 m.
        np.testing.assert_allclose(centre, np.round(centre, 4), atol=1e-12)
        total = width_left + width_right
        assert total.min() >= 0.76 - 1e-3 and total.max() <= 1.07 + 1e-3
        gaps = np.linalg.norm(np.roll(centre, -1, axis=0) - centre, axis=1)
        assert gaps.min() >= 0.04 and gaps.max() <= 0.11
        metrics = measure_track(centre, width_left, width_right)
        assert 15.0 <= metrics.length <= 60.0
        assert metrics.counter_clockwise
        assert metrics.is_simple
        assert metrics.min_radius_ratio >= 1.2
        left, right = border_polylines(centre, width_left, width_right)
        assert not brute_force_crossings(centre[::6])
        assert not brute_force_crossings(left[::6], right[::6])
        assert (TRACKS_DIR / f"{name}.png").is_file()
        assert f"![{name}]({name}.png)" in (TRACKS_DIR / "README.md").read_text(encoding="utf-8")

    def test_files_match_design_script(self):
        design = load_design_module()
        assert {d.name for d in design.DESIGNS} >= set(CATALOGUE)
        for entry in design.DESIGNS:
            spec = design.build(entry)
            assert design.check(spec)[1] == [], entry.name
            shipped = (TRACKS_DIR / f"{entry.name}.json").read_text(encoding="utf-8")
            assert design.to_json(spec) == shipped, f"{entry.name}.json is stale: run python tracks/design.py"

    def test_speedway_is_flat_out_at_4_m_per_s(self):
        # Lateral acceleration v^2 / R at 4 m/s must stay under ~1 g = 9.81 m/s^2, i.e. R >= 16 / 9.81 = 1.63 m.
        document = json.loads((TRACKS_DIR / "speedway.json").read_text(encoding="utf-8"))
        assert min_radius_of_curvature(np.c_[document["x"], document["y"]]) >= 16.0 / 9.81
