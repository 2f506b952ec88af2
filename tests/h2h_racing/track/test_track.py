"""Tests for :mod:`h2h_racing.track.shape`: geometry, projection, Frenet round trip, validation."""

from __future__ import annotations

import math
import pathlib
import pickle
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from h2h_racing.track.shape import BLEND_HALF_WIDTH, Track

R = 5.0  # circle radius [m]
M_CIRCLE = 400  # vertices of the test circle
HALF_W = 0.5  # half-width of the circle track [m]


def circle(radius: float = R, m: int = M_CIRCLE, half_width: float = HALF_W, ccw: bool = True) -> Track:
    """A regular m-gon inscribed in a circle, starting at (radius, 0)."""
    a = np.linspace(0.0, 2 * np.pi, m, endpoint=False)
    if not ccw:
        a = -a
    return Track(np.stack([radius * np.cos(a), radius * np.sin(a)], axis=1), half_width, half_width, name="circle")


def rectangle() -> Track:
    """A 10 m x 4 m rectangle, CCW, widths 0.4 left / 0.3 right, with extra vertices on the long sides."""
    pts = [(0, 0), (5, 0), (10, 0), (10, 4), (5, 4), (0, 4)]
    return Track(np.array(pts, float), 0.4, 0.3, name="rect")


class TestCircleGeometry:
    """Length, heading, curvature and normals of a finely sampled circle."""

    def test_length_is_polygon_perimeter(self) -> None:
        # Perimeter of a regular m-gon inscribed in radius R: m * 2R sin(pi/m) = 400 * 10 * sin(pi/400)
        # = 31.4156... (2 pi R = 31.4159, the polygon is 3.2e-4 m shorter).
        expected = M_CIRCLE * 2 * R * math.sin(math.pi / M_CIRCLE)
        assert circle().length == pytest.approx(expected, rel=1e-12)
        assert circle().length == pytest.approx(2 * math.pi * R, abs=1e-3)

    def test_vertex_s_and_widths(self) -> None:
        t = circle()
        seg = 2 * R * math.sin(math.pi / M_CIRCLE)
        np.testing.assert_allclose(t.vertex_s, np.arange(M_CIRCLE) * seg, atol=1e-12)
        assert t.min_width == pytest.approx(2 * HALF_W)
        assert t.is_ccw and not circle(ccw=False).is_ccw
        # Borders at radius R +- 0.5: bounds of the outer border = +-5.5 (vertex 0 lies on +x).
        xmin, ymin, xmax, ymax = t.bounds
        assert xmax == pytest.approx(R + HALF_W) and xmin == pytest.approx(-(R + HALF_W))
        assert ymax == pytest.approx(R + HALF_W, abs=1e-3)

    def test_heading_and_curvature(self) -> None:
        t = circle()
        # On the CCW circle at angle a = s / R the tangent points to a + pi/2. The heading is the segment
        # direction, which is off the circle tangent by at most half the turn per vertex, pi / 400 = 0.00785.
        s = np.array([0.5, 7.3, 20.1])
        a = s / R
        err = np.angle(np.exp(1j * (t.heading_at(s) - (a + np.pi / 2))))
        assert np.abs(err).max() <= math.pi / M_CIRCLE + 1e-4
        np.testing.assert_allclose(t.curvature_at(s), 1 / R, rtol=1e-3)
        np.testing.assert_allclose(circle(ccw=False).curvature_at(s), -1 / R, rtol=1e-3)

    def test_heading_is_continuous(self) -> None:
        t = circle()
        s = np.linspace(0, t.length, 20001)
        jump = np.diff(np.unwrap(t.heading_at(s)))
        # Turn per vertex 2 pi / 400 = 0.0157 rad; steps between samples must stay well below that.
        assert np.abs(jump).max() < 0.005

    def test_lanes_and_half_widths(self) -> None:
        t = rectangle()
        left, right = t.half_widths_at(np.array([1.0, 12.3]))
        np.testing.assert_allclose(left, 0.4)
        np.testing.assert_allclose(right, 0.3)
        # On the bottom side (driving +x), left lane at y = +0.2, right lane at y = -0.15.
        np.testing.assert_allclose(t.lane_point(2.0, 1), [2.0, 0.2], atol=1e-12)
        np.testing.assert_allclose(t.lane_point(np.array([2.0, 2.0]), np.array([1, -1])), [[2.0, 0.2], [2.0, -0.15]])
        np.testing.assert_allclose(t.left_lane[1], [5.0, 0.2])
        with pytest.raises(ValueError, match="lane"):
            t.lane_point(2.0, 0)


class TestProject:
    """Projection onto the centre polyline, against hand-computed values and brute force."""

    def test_rectangle_points(self) -> None:
        t = rectangle()
        # (3, 0.25): bottom side, s = 3, d = +0.25 (inside = left of a CCW track).
        # (10.5, 1): right side beyond x = 10, s = 10 + 1 = 11, d = -0.5 (outside).
        # (-1, -1): outside the corner at the start vertex; nearest point (0, 0): s = 0, d = -sqrt(2).
        # (2, 3.5): top side driven towards -x, from (10, 4) at s = 14: s = 14 + 8 = 22, d = +0.5.
        s, d = t.project(np.array([[3, 0.25], [10.5, 1], [-1, -1], [2, 3.5]]))
        np.testing.assert_allclose(s, [3, 11, 0, 22], atol=1e-12)
        np.testing.assert_allclose(d, [0.25, -0.5, -math.sqrt(2), 0.5], atol=1e-12)
        assert t.length == pytest.approx(28.0)

    def test_shapes_and_wrap(self) -> None:
        t = rectangle()
        pts = np.zeros((3, 4, 2)) + [0.0, 1.0]  # left side, 1 m before the end of the lap
        s, d = t.project(pts)
        assert s.shape == (3, 4) and d.shape == (3, 4)
        np.testing.assert_allclose(s, 27.0)  # s = 28 - 1
        s, d = t.project([0.0, -0.1])
        assert s.shape == () and float(s) == 0.0 and 0.0 <= float(s) < t.length

    def test_matches_brute_force_on_random_points(self) -> None:
        t = circle(m=60)
        rng = np.random.default_rng(1)
        pts = rng.uniform(-9, 9, size=(4000, 2))  # includes points far beyond the grid margin
        s, d = t.project(pts)
        # Brute force: distance to every segment.
        a = t.centre
        b = np.roll(a, -1, axis=0)
        v = b - a
        w = pts[:, None, :] - a[None]
        u = np.clip(np.sum(w * v, -1) / np.sum(v * v, -1), 0, 1)
        dist = np.linalg.norm(w - u[..., None] * v, axis=-1)
        np.testing.assert_allclose(np.abs(d), dist.min(axis=1), atol=1e-12)
        assert np.all((s >= 0) & (s < t.length))

    def test_on_track(self) -> None:
        t = rectangle()
        on = t.on_track(np.array([[3, 0.39], [3, 0.41], [3, -0.29], [3, -0.31]]))
        np.testing.assert_array_equal(on, [True, False, True, False])

    def test_zero_length_segments(self) -> None:
        """Duplicate consecutive vertices (as in DeepRacer files) give finite answers everywhere."""
        pts = np.array([(0, 0), (5, 0), (5, 0), (10, 0), (10, 4), (0, 4), (0, 4)], float)
        t = Track(pts, 0.4, 0.4)
        assert t.length == pytest.approx(28.0)
        # (5, -0.2): right of the duplicate vertex at s = 5; (5, 0): on it; (-0.5, 4.5): outside the doubled corner.
        s, d = t.project(np.array([[5, -0.2], [5, 0.0], [-0.5, 4.5], [7, 0.1]]))
        assert np.all(np.isfinite(s)) and np.all(np.isfinite(d))
        np.testing.assert_allclose(s, [5, 5, 24, 7], atol=1e-12)
        np.testing.assert_allclose(d, [-0.2, 0, -math.hypot(0.5, 0.5), 0.1], atol=1e-12)
        q = t.point_at(np.linspace(0, 28, 57), 0.1)
        assert np.all(np.isfinite(q)) and np.all(np.isfinite(t.curvature_at([5.0, 24.0])))


class TestRoundTrip:
    """project(point_at(s, d)) returns (s, d), exactly away from the vertex blend zones."""

    TRACK = circle(m=120)  # turn per vertex 3 degrees, segment 0.2617 m

    @settings(max_examples=300, deadline=None, derandomize=True)
    @given(st.floats(0.0, 31.0), st.floats(-0.9 * HALF_W, 0.9 * HALF_W))
    def test_round_trip(self, s: float, d: float) -> None:
        t = self.TRACK
        s_back, d_back = t.project(t.point_at(s, d))
        err_s = abs(float(s_back) - s)
        err_s = min(err_s, t.length - err_s)
        # Distance of s to the nearest vertex; the inexact zone is h + |d| tan(turn / 2) around a vertex.
        seg = t.length / 120
        to_vertex = abs(s - seg * round(s / seg))
        zone = BLEND_HALF_WIDTH + abs(d) * math.tan(math.pi / 120)
        if to_vertex > zone:
            assert err_s < 1e-9 and abs(float(d_back) - d) < 1e-9
        else:
            # Inside the zone the error is bounded by the zone size (turn 2 pi / 120 per vertex).
            assert err_s <= 2 * zone and abs(float(d_back) - d) <= zone * math.pi / 60 + 1e-12

    def test_round_trip_on_vertex(self) -> None:
        """At a vertex the normal is the bisector: exact outside the turn, off by |d| sin(turn/2) inside."""
        t = self.TRACK
        s = t.vertex_s[7]
        s_back, d_back = t.project(t.point_at(s, np.array([-0.4, 0.4])))
        # Outside (d = -0.4 on a CCW circle) the vertex is the nearest point. Inside, the point 0.4 m along the
        # bisector has its foot 0.4 sin(1.5 deg) = 0.01047 m from the vertex on either segment (a tie that
        # rounding breaks either way) at distance 0.4 cos(1.5 deg) = 0.39986 m.
        turn = 2 * math.pi / 120
        np.testing.assert_allclose(np.abs(s_back - s), [0.0, 0.4 * math.sin(turn / 2)], atol=1e-9)
        np.testing.assert_allclose(d_back, [-0.4, 0.4 * math.cos(turn / 2)], atol=1e-9)


class TestReversed:
    """Driving the other way round."""

    def test_reversed(self) -> None:
        t = rectangle()
        r = t.reversed()
        assert not r.is_ccw and r.length == pytest.approx(t.length)
        np.testing.assert_array_equal(r.centre[0], t.centre[0])  # same start line
        np.testing.assert_array_equal(r.centre[1], t.centre[-1])
        np.testing.assert_allclose(r.width_left, 0.3)
        np.testing.assert_allclose(r.width_right, 0.4)
        np.testing.assert_allclose(r.left_border, t.right_border[[0, 5, 4, 3, 2, 1]])
        np.testing.assert_array_equal(r.waypoints, t.waypoints[::-1])
        # A point 0.25 m inside the bottom side at x = 3: forward s = 3, d = +0.25; reversed s = 28 - 3, d = -0.25.
        s, d = r.project([3.0, 0.25])
        assert float(s) == pytest.approx(25.0) and float(d) == pytest.approx(-0.25)
        rr = r.reversed()
        np.testing.assert_array_equal(rr.centre, t.centre)


class TestImmutability:
    """Arrays are read-only, the dataclass is frozen and pickles."""

    def test_read_only(self) -> None:
        t = rectangle()
        for arr in (t.centre, t.width_left, t.width_right, t.left_border, t.right_border, t.waypoints, t.vertex_s):
            assert arr.dtype == np.float64 and not arr.flags.writeable
        with pytest.raises(AttributeError):
            t.name = "x"  # type: ignore[misc]
        np.testing.assert_array_equal(t.waypoints[-1], t.waypoints[0])
        assert t.waypoints.shape == (7, 2)

    def test_pickle(self) -> None:
        t = rectangle()
        t.project([1.0, 1.0])
        u = pickle.loads(pickle.dumps(t))
        np.testing.assert_array_equal(u.project([[3.0, 0.25]])[0], t.project([[3.0, 0.25]])[0])


class TestValidation:
    """Every geometric error is a ValueError naming source, problem and location."""

    SQUARE = np.array([(0, 0), (4, 0), (4, 4), (0, 4)], float)

    def test_too_few_vertices(self) -> None:
        with pytest.raises(ValueError, match=r"'tri' \(<memory>\).*at least 4 distinct vertices.*got 3"):
            Track(np.array([(0, 0), (4, 0), (4, 4), (4, 4)], float), 0.3, 0.3, name="tri")

    def test_non_finite(self) -> None:
        c = self.SQUARE.copy()
        c[2, 1] = np.nan
        with pytest.raises(ValueError, match=r"centre has a non-finite value.*row 2"):
            Track(c, 0.3, 0.3)

    def test_non_positive_width(self) -> None:
        with pytest.raises(ValueError, match=r"width_right must be > 0.*vertex 1 \(4\.0000, 0\.0000\)"):
            Track(self.SQUARE, 0.3, [0.3, 0.0, 0.3, 0.3])

    def test_too_narrow(self) -> None:
        # 0.15 + 0.2 = 0.35 m < 2 car widths = 0.40 m at vertex 3 (0, 4).
        with pytest.raises(ValueError, match=r"0\.3500 m wide at vertex 3 \(0\.0000, 4\.0000\).*0\.40 m"):
            Track(self.SQUARE, [0.3, 0.3, 0.3, 0.15], 0.2)

    def test_shape_mismatch(self) -> None:
        with pytest.raises(ValueError, match=r"width_left of shape \(4,\).*got shape \(3,\)"):
            Track(self.SQUARE, [0.3, 0.3, 0.3], 0.3)
        with pytest.raises(ValueError, match=r"centre of shape \(M, 2\)"):
            Track(np.zeros((4, 3)), 0.3, 0.3)
        with pytest.raises(ValueError, match=r"left_border of shape \(4, 2\)"):
            Track(self.SQUARE, 0.3, 0.3, left_border=np.zeros((5, 2)), right_border=np.zeros((5, 2)))

    def test_centre_self_intersection(self) -> None:
        # Bow tie: (0,0) -> (4,4) -> (4,0) -> (0,4) crosses itself at (2, 2).
        bow = np.array([(0, 0), (4, 4), (4, 0), (0, 4)], float)
        with pytest.raises(ValueError, match=r"centre line crosses itself near \(2\.0000, 2\.0000\).*vertex 0"):
            Track(bow, 0.3, 0.3, name="bow")

    def test_border_fold(self) -> None:
        # A circle of radius 0.5 m with 0.6 m half-width: the inner (left) border, at radius 0.5 - 0.6 = -0.1,
        # runs backwards.
        with pytest.raises(ValueError, match=r"'circle' \(<memory>\): the left border folds back at vertex 0 "
                           r"\(0\.5000, 0\.0000\).*radius of curvature"):
            circle(radius=0.5, m=40, half_width=0.6)

    def test_border_self_intersection(self) -> None:
        # Explicit borders of the 4 x 4 square; swapping two left-border rows makes it cross itself at (2, 2)
        # between the segment from vertex 0 (0.5, 0.5) -> (3.5, 3.5) and the one from vertex 2 (3.5, 0.5).
        left = np.array([(0.5, 0.5), (3.5, 3.5), (3.5, 0.5), (0.5, 3.5)])
        right = np.array([(-0.5, -0.5), (4.5, -0.5), (4.5, 4.5), (-0.5, 4.5)])
        with pytest.raises(ValueError, match=r"left border crosses itself near \(2\.0000, 2\.0000\).*vertex 0"):
            Track(self.SQUARE, 0.7, 0.7, left_border=left, right_border=right)

    def test_spike(self) -> None:
        spike = np.array([(0, 0), (4, 0), (4, 4), (4, 2), (0, 4)], float)
        with pytest.raises(ValueError, match=r"vertex"):
            Track(spike, 0.3, 0.3)


def _run_python(code: str, timeout: float = 60.0) -> subprocess.CompletedProcess[str]:
    """Run ``code`` in a fresh interpreter; a check that went quadratic runs past ``timeout``."""
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=timeout, check=False)


class TestLargeTracks:
    """The simple-polygon check is O(n log n): tens of thousands of vertices load in about a second
    (the pairwise check took 137 s for 20,000 and over 300 s for 50,000), and the vertex count and the
    file size are bounded."""

    # An ellipse of N vertices 5 cm apart, and the same number on a figure of eight.
    SETUP = """
        import numpy as np
        from h2h_racing.track.shape import Track
        n = {n}
        t = np.linspace(0, 2 * np.pi, n, endpoint=False)
        r = n * 0.05 / (2 * np.pi)
        ellipse = np.stack([r * np.cos(t), 0.6 * r * np.sin(t)], axis=1)
        eight = np.stack([r * np.sin(t), r * np.sin(2 * t) / 2], axis=1)
    """

    def test_large_valid_track(self) -> None:
        code = self.SETUP.format(n=50_000) + """
        track = Track(ellipse, 0.5, 0.5, name="big")
        print(len(track.centre))
        """
        result = _run_python(code)
        assert result.returncode == 0, result.stderr
        assert result.stdout.strip() == "50000"

    def test_large_self_intersecting_track(self) -> None:
        # x = r sin t, y = r sin 2t / 2 crosses itself at the origin (vertices 0 and n / 2), where the
        # segments around vertex 0 meet those around vertex n / 2.
        code = self.SETUP.format(n=50_000) + """
        try:
            Track(eight, 0.5, 0.5, name="eight")
        except ValueError as exc:
            print(exc)
        """
        result = _run_python(code)
        assert result.returncode == 0, result.stderr
        assert re.search(r"'eight'.*centre line crosses itself near \(-?0\.0000, -?0\.0000\): the segment from "
                         r"vertex (0|2499\d|2500\d|4999\d) .* meets the segment from vertex (2499\d|2500\d|4999\d) ",
                         result.stdout), result.stdout

    def test_vertex_count_is_bounded(self) -> None:
        # In a subprocess: without the bound the check would run for many minutes.
        code = """
        import numpy as np
        from h2h_racing.track.shape import MAX_TRACK_VERTICES, Track
        n = MAX_TRACK_VERTICES + 1
        t = np.linspace(0, 2 * np.pi, n, endpoint=False)
        try:
            Track(np.stack([1e3 * np.cos(t), 1e3 * np.sin(t)], axis=1), 0.5, 0.5, name="huge")
        except ValueError as exc:
            print(exc)
        """
        result = _run_python(code)
        assert result.returncode == 0, result.stderr
        assert "'huge' (<memory>): the centre line has 100001 vertices; at most 100000 are allowed" in result.stdout

    def test_file_size_is_bounded(self, tmp_path: pathlib.Path) -> None:
        from h2h_racing.track.io import MAX_TRACK_FILE_BYTES, load_track

        path = tmp_path / "huge.csv"
        with path.open("wb") as f:
            f.truncate(MAX_TRACK_FILE_BYTES + 1)  # sparse: no disk written
        with pytest.raises(ValueError, match=rf"huge\.csv: the file is {MAX_TRACK_FILE_BYTES + 1} bytes.*"
                           rf"at most {MAX_TRACK_FILE_BYTES}"):
            load_track(path)
