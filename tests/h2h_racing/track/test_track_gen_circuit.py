"""Tests for h2h_racing.track.circuits: kart-style circuits of tight corners."""

from __future__ import annotations

import math

import numpy as np
import pytest

from h2h_racing.track.generator import (
    border_polylines,
    closed_length,
    curvature,
    find_crossings,
    min_radius_of_curvature,
    signed_area,
    smooth_closed_curve,
)
from h2h_racing.track.circuits import (_bspline, _has_hole, _outline, _rounded, _turns,
                                         random_circuit)

ARCS_SEED_4 = "circuit-c558ed2e"
"""``random_circuit(np.random.default_rng(4)).name`` before ``corners`` was added (b3164f8)."""


def blob(*cells: tuple[int, int]) -> np.ndarray:
    occupied = np.zeros((5, 4), dtype=bool)
    for x, y in cells:
        occupied[x, y] = True
    return occupied


def turn_points(occupied: np.ndarray) -> np.ndarray:
    """The grid points where the blob's outline turns, in its order."""
    path = _outline(occupied)
    return path[_turns(path)]


class TestOutline:
    def test_l_shape_turns_at_its_six_corners_anticlockwise(self) -> None:
        # Cells (0,0), (1,0), (0,1): the outline runs (0,0) (2,0) (2,1) (1,1) (1,2) (0,2),
        # anticlockwise; (1,1) is the one right-hand (reflex) corner.
        corners = turn_points(blob((0, 0), (1, 0), (0, 1)))
        start = int(np.flatnonzero((corners == (0, 0)).all(axis=1))[0])
        assert np.roll(corners, -start, axis=0).tolist() == [[0, 0], [2, 0], [2, 1], [1, 1],
                                                            [1, 2], [0, 2]]
        assert signed_area(corners.astype(float)) == pytest.approx(3.0)

    def test_every_grid_point_of_the_outline_in_order(self) -> None:
        # The same L: 8 unit edges around it, the turn points among them in the same order.
        path = _outline(blob((0, 0), (1, 0), (0, 1)))
        assert len(path) == 8
        steps = np.abs(np.roll(path, -1, axis=0) - path).sum(axis=1)
        assert (steps == 1).all()
        turns = turn_points(blob((0, 0), (1, 0), (0, 1)))
        assert [p for p in path.tolist() if p in turns.tolist()] == turns.tolist()

    def test_cells_meeting_at_a_corner_pinch_the_outline(self) -> None:
        # A staircase of 6 cells turns 12 times; without its step cells it pinches.
        assert turn_points(blob((0, 0), (1, 1), (1, 0), (2, 1), (2, 2), (3, 2))).shape == (12, 2)
        assert turn_points(blob((0, 0), (1, 1))).shape == (0, 2)

    def test_a_ring_of_cells_has_a_hole(self) -> None:
        ring = [(x, y) for x in range(3) for y in range(3) if (x, y) != (1, 1)]
        assert _has_hole(blob(*ring))
        assert not _has_hole(blob(*[cell for cell in ring if cell != (1, 2)]))


class TestRounded:
    def test_a_square_with_round_corners(self) -> None:
        # A 2 m square with 0.5 m corners: four 1 m straights and a full 0.5 m circle,
        # 4 + pi m around. The tightest radius is the corners', 4 % under at random_circuit's
        # 0.05 m spacing: the spline through the dense points overshoots where the curvature
        # jumps from 0 to 1 / r.
        square = np.array([(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)])
        centre = smooth_closed_curve(_rounded(square, np.full(4, 0.5)), spacing=0.05)
        assert closed_length(centre) == pytest.approx(4 + math.pi, rel=2e-3)
        assert min_radius_of_curvature(centre) == pytest.approx(0.5, rel=0.06)
        # The arcs' middles sit r (1 - 1 / sqrt 2) inside the square's corners.
        inset = 0.5 * (1 - 1 / math.sqrt(2))
        nearest = np.linalg.norm(centre - np.array([2.0, 2.0]), axis=1).min()
        assert nearest == pytest.approx(math.sqrt(2) * inset, abs=2e-3)

    def test_a_radius_longer_than_half_a_side_is_capped(self) -> None:
        # A 1 m x 3 m rectangle asked for 0.8 m corners gets 0.5 m (half the 1 m side): its
        # short ends become semicircles, 2 x 2 m straights + pi m.
        rectangle = np.array([(0.0, 0.0), (3.0, 0.0), (3.0, 1.0), (0.0, 1.0)])
        centre = smooth_closed_curve(_rounded(rectangle, np.full(4, 0.8)), spacing=0.02)
        assert closed_length(centre) == pytest.approx(4 + math.pi, rel=2e-3)


class TestBSpline:
    def test_a_square_becomes_a_round_loop_through_the_midpoints(self) -> None:
        # A 2 m square's quadratic B-spline: four parabolic arcs, each from one side's
        # midpoint to the next, passing (1/4)(M_i + M_i+1) + (1/2)P at t = 1/2, that is
        # (1.75, 1.75) for the corner (2, 2): the radius there is a / sqrt 2 = 1 / sqrt 2
        # (a = 1 m, half a side).
        square = np.array([(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)])
        dense = _bspline(square, samples=200)
        assert np.linalg.norm(dense - (1.0, 0.0), axis=1).min() < 1e-9
        assert np.linalg.norm(dense - (1.75, 1.75), axis=1).min() < 1e-9
        centre = smooth_closed_curve(dense, spacing=0.01)
        assert min_radius_of_curvature(centre) == pytest.approx(1 / math.sqrt(2), rel=0.02)

    def test_collinear_points_stay_straight(self) -> None:
        # A 3 x 1 rectangle walked in unit steps: the long sides' inner points are collinear,
        # so the curve runs along y = 0 between x = 1 and x = 2 exactly.
        path = np.array([(0, 0), (1, 0), (2, 0), (3, 0), (3, 1), (2, 1), (1, 1), (0, 1)], float)
        dense = _bspline(path, samples=8)
        bottom = dense[(dense[:, 0] >= 1.0) & (dense[:, 0] <= 2.0) & (dense[:, 1] < 0.5)]
        assert len(bottom) >= 8
        np.testing.assert_allclose(bottom[:, 1], 0.0, atol=1e-12)


class TestRandomCircuit:
    def test_circuits_are_valid_tight_and_anticlockwise(self) -> None:
        width = 0.8
        shares = []
        for seed in range(12):
            spec = random_circuit(np.random.default_rng(seed), width=width, chicanes=(0, 2))
            assert spec.name.startswith("circuit-")
            assert signed_area(spec.centre) > 0
            assert min_radius_of_curvature(spec.centre) >= 0.6 * width
            np.testing.assert_array_equal(spec.width_left, np.full(len(spec.centre), 0.4))
            left, right = border_polylines(spec.centre, spec.width_left, spec.width_right)
            assert not len(find_crossings(spec.centre))
            assert not len(find_crossings(left, right))
            shares.append(float((np.abs(curvature(spec.centre)) > 1.0).mean()))
        # Every corner is a right-angle arc of 0.5-0.7 m radius (0.8-1.1 m of lap under 1 m
        # radius), 4-14 of them a lap. The smooth tight tracks of training.tracks spend 5-20 %
        # of their lap under 1 m radius, technical 40 %.
        assert min(shares) > 0.15
        assert np.mean(shares) > 0.3

    def test_bspline_circuits_are_valid_round_and_tight(self) -> None:
        # Cells of 1.5-1.9 m: right angles of a / sqrt 2 = 0.53-0.67 m radius before the
        # jitter, and the rest straight or gentler: more than a fifth of the lap under 1 m.
        width = 0.76
        for seed in range(6):
            spec = random_circuit(np.random.default_rng(seed), width=width, cell=(1.5, 1.9),
                                  corners="bspline", jitter=0.08)
            assert "(bspline)" in spec.description
            assert signed_area(spec.centre) > 0
            assert min_radius_of_curvature(spec.centre) >= 0.6 * width
            left, right = border_polylines(spec.centre, spec.width_left, spec.width_right)
            assert not len(find_crossings(left, right))
            assert (np.abs(curvature(spec.centre)) > 1.0).mean() > 0.2
            # Smaller curvature steps than the arcs' (1 / r at each arc's end, 1.05-1.16 /m
            # between vertices 5 cm apart after the spline for seeds 0-5): 0.48-0.73 /m.
            assert np.abs(np.diff(curvature(spec.centre))).max() < 0.9

    def test_arcs_draws_are_those_of_before_the_bspline_option(self) -> None:
        # The default draws as it did before ``corners`` existed: a recorded circuit of
        # seed 4 (its name is the hash of its geometry).
        assert random_circuit(np.random.default_rng(4)).name == ARCS_SEED_4

    def test_same_seed_same_circuit(self) -> None:
        a = random_circuit(np.random.default_rng(4))
        b = random_circuit(np.random.default_rng(4))
        c = random_circuit(np.random.default_rng(5))
        assert a.name == b.name != c.name
        np.testing.assert_array_equal(a.centre, b.centre)

    @pytest.mark.parametrize(("kwargs", "message"), [
        ({"corner_radius": (0.3, 0.7)}, r"corner_radius = \(low, high\) with width / 2 = 0.38"),
        ({"cell": (0.9, 2.0)}, r"cell = \(low, high\) with width \+ 0.25 = 1.01"),
        ({"cells": (2, 6)}, r"cells = \(fewest, most\) with 4 <= fewest"),
        ({"width": -1.0}, r"width > 0"),
        ({"max_tries": 0}, r"max_tries >= 1"),
        ({"corners": "round"}, r"corners = 'arcs' or 'bspline', got 'round'"),
        ({"jitter": 0.5}, r"0 <= jitter < cell low / 4 = 0.325 m, got 0.5"),
    ])
    def test_bad_arguments_are_named(self, kwargs: dict, message: str) -> None:
        with pytest.raises(ValueError, match=message):
            random_circuit(np.random.default_rng(0), **kwargs)

    def test_no_circuit_found_says_what_was_rejected(self) -> None:
        # Cells barely wider than the track and 8 chicanes a lap: nothing passes in 2 tries.
        with pytest.raises(RuntimeError, match=r"no valid circuit in 2 tries \(rejected: "):
            random_circuit(np.random.default_rng(0), cell=(1.01, 1.01), chicanes=(8, 8),
                           max_tries=2)
