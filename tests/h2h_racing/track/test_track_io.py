"""Tests for :mod:`h2h_racing.track.io`: catalogue, JSON round trip, DeepRacer npy and centre-line CSV."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from h2h_racing.track.shape import Track
from h2h_racing.track.io import (
    TRACK_FORMAT,
    catalogue,
    list_tracks,
    load_track,
    route_geometry_rows,
    save_track,
)

SHARED = Path(__file__).resolve().parents[3] / ".." / "shared" / "data"
DEEPRACER = SHARED / "deepracer_tracks"
CATALUNYA = SHARED / "centerline_csv" / "Catalunya.csv"


def needs(path: Path) -> pytest.MarkDecorator:
    # The files are public but not ours to ship; README.md's "Tests" says where to get them.
    return pytest.mark.skipif(
        not path.exists(), reason=f"real track data not available at {path.resolve()}: "
        "DeepRacer routes from aws-deepracer-community/deepracer-simapp (bundle/routes/*.npy), "
        "Catalunya.csv from TUMFTM/racetrack-database (tracks/); see README.md, Tests")


def square_rows(n_side: int = 4, side: float = 4.0) -> np.ndarray:
    """DeepRacer rows for a CCW square with 0.4 m half-width, closing row repeated."""
    t = np.linspace(0, side, n_side, endpoint=False)
    z = np.zeros_like(t)
    centre = np.concatenate([np.stack([t, z], 1), np.stack([z + side, t], 1),
                             np.stack([side - t, z + side], 1), np.stack([z, side - t], 1)])
    # Inner (left of CCW travel) border: 0.4 m along each side's inward normal, and along the diagonal
    # (0.4 m in x and in y) at the four corners.
    normal = np.repeat(np.array([(0, 1), (-1, 0), (0, -1), (1, 0)], float), n_side, axis=0)
    corner = np.repeat(np.array([(1, 1), (-1, 1), (-1, -1), (1, -1)], float), n_side, axis=0)
    is_corner = (np.arange(4 * n_side) % n_side == 0)[:, None]
    inner = centre + 0.4 * np.where(is_corner, corner, normal)
    outer = 2 * centre - inner
    rows = np.concatenate([centre, inner, outer], axis=1)
    return np.vstack([rows, rows[:1]])


class TestJson:
    """Catalogue JSON format: round trip and rejection of malformed files."""

    def test_round_trip(self, tmp_path: Path) -> None:
        c = np.array([(0, 0), (4, 0), (4, 3), (0, 3)], float)
        t = Track(c, [0.3, 0.35, 0.3, 0.3], 0.25, name="box", description="a box")
        path = save_track(t, tmp_path / "box.json")
        u = load_track(path)
        np.testing.assert_array_equal(u.centre, c)
        np.testing.assert_array_equal(u.width_left, t.width_left)
        assert u.name == "box" and u.description == "a box" and u.source == str(path)
        assert u.length == pytest.approx(14.0)  # 4 + 3 + 4 + 3
        np.testing.assert_array_equal(u.waypoints, np.vstack([c, c[:1]]))
        r = load_track(path, reverse=True)
        assert not r.is_ccw

    def test_rejects_unknown_keys_and_format(self, tmp_path: Path) -> None:
        doc = {"format": TRACK_FORMAT, "name": "b", "description": "", "x": [0, 4, 4, 0], "y": [0, 0, 3, 3],
               "width_left": [0.3] * 4, "width_right": [0.3] * 4}
        bad = tmp_path / "bad.json"
        bad.write_text(json.dumps({**doc, "colour": "red"}))
        with pytest.raises(ValueError, match=r"bad\.json.*unknown keys \['colour'\]"):
            load_track(bad)
        bad.write_text(json.dumps({**doc, "format": "other/2"}))
        with pytest.raises(ValueError, match=r"bad\.json: expected format 'h2h-racing-track/1', got 'other/2'"):
            load_track(bad)
        bad.write_text(json.dumps({**doc, "width_left": [0.3, 0.3]}))
        with pytest.raises(ValueError, match=r"bad\.json.*width_left of shape \(4,\)"):
            load_track(bad)


class TestLoadTrackDispatch:
    """Names, paths and errors of load_track."""

    def test_unknown_name_lists_catalogue(self) -> None:
        with pytest.raises(ValueError, match=r"Unknown track 'no_such_track'.*\.json, \.npy, \.csv"):
            load_track("no_such_track")

    def test_missing_file(self, tmp_path: Path) -> None:
        with pytest.raises(FileNotFoundError, match="nothing.npy"):
            load_track(tmp_path / "nothing.npy")

    def test_catalogue_tracks_load(self) -> None:
        names = list_tracks()
        assert names == sorted(catalogue())
        for name in names:
            t = load_track(name)
            assert t.name and t.length > 0 and t.min_width >= 0.4


class TestNpy:
    """DeepRacer route files, written by the test and real ones."""

    def test_written_square(self, tmp_path: Path) -> None:
        rows = square_rows()
        path = tmp_path / "sq.npy"
        np.save(path, rows)
        t = load_track(path)
        assert t.name == "sq" and t.is_ccw
        assert t.length == pytest.approx(16.0)  # 4 sides of 4 m
        assert t.waypoints.shape == (17, 2)  # 16 vertices + the closing row, kept as given
        np.testing.assert_allclose(t.width_left[1], 0.4)  # inner = left on a CCW loop
        np.testing.assert_array_equal(t.left_border, rows[:-1, 2:4])
        # Reversed (CW): inner is now on the right.
        r = load_track(path, reverse=True)
        np.testing.assert_array_equal(r.right_border[0], rows[0, 2:4])
        np.testing.assert_array_equal(r.waypoints, rows[::-1, :2])

    def test_cw_file_puts_inner_on_the_right(self, tmp_path: Path) -> None:
        rows = square_rows()[::-1].copy()  # same loop driven clockwise, inner still columns 2:4
        np.save(tmp_path / "cw.npy", rows)
        t = load_track(tmp_path / "cw.npy")
        assert not t.is_ccw
        np.testing.assert_array_equal(t.right_border, rows[:-1, 2:4])

    def test_wrong_shape(self, tmp_path: Path) -> None:
        np.save(tmp_path / "bad.npy", np.zeros((10, 4)))
        with pytest.raises(ValueError, match=r"bad\.npy: expected .*\(N, 6\).*got shape \(10, 4\)"):
            load_track(tmp_path / "bad.npy")

    @needs(DEEPRACER / "reinvent_base.npy")
    def test_reinvent_base(self) -> None:
        t = load_track(DEEPRACER / "reinvent_base.npy")
        assert t.length == pytest.approx(17.71, abs=0.01)  # SOURCES.md
        assert t.waypoints.shape == (119, 2) and t.is_ccw
        assert 0.75 < t.min_width and t.width.max() < 0.77  # 0.756-0.762 m
        s, d = t.project(t.waypoints)
        np.testing.assert_allclose(d, 0, atol=1e-12)

    @needs(DEEPRACER / "Oval_track.npy")
    def test_oval_zero_length_row(self) -> None:
        t = load_track(DEEPRACER / "Oval_track.npy")
        raw = np.load(DEEPRACER / "Oval_track.npy")
        np.testing.assert_array_equal(raw[66, :2], raw[67, :2])  # the duplicated row
        assert t.waypoints.shape == (102, 2) and t.length == pytest.approx(19.55, abs=0.01)
        pts = np.concatenate([raw[60:72, 0:2], raw[60:72, 2:4], raw[60:72, 4:6]])
        s, d = t.project(pts)
        assert np.all(np.isfinite(s)) and np.all(np.isfinite(d))
        assert np.all(np.isfinite(t.point_at(t.vertex_s[60:72], 0.2)))
        assert np.all(np.isfinite(t.curvature_at(t.vertex_s)))

    @needs(DEEPRACER / "reInvent2019_track.npy")
    def test_smile_speedway(self) -> None:
        t = load_track(DEEPRACER / "reInvent2019_track.npy")
        assert t.length == pytest.approx(23.12, abs=0.01) and t.waypoints.shape == (155, 2)
        assert t.on_track(t.left_lane).all() and t.on_track(t.right_lane).all()


ellipse_route_rows = sys.modules["conftest"].ellipse_route_rows
with_route_slips = sys.modules["conftest"].with_route_slips
reinvent_2018_71_rows = sys.modules["conftest"].reinvent_2018_71_rows


class TestRouteSlips:
    """Route files with the drawing slips DeepRacer raced on (the 2019-era re:Invent 2018 file:
    71 rows, a 2 mm step backwards, near-duplicate rows) load; real crossings are refused."""

    def test_slips_are_left_out_of_the_geometry_but_every_row_is_a_waypoint(
            self, tmp_path: Path) -> None:
        rows = with_route_slips(ellipse_route_rows(), back_row=20, duplicate_row=45)
        path = tmp_path / "reinvent_2019_era.npy"
        np.save(path, rows)
        # The same rows as one Track, slips included, are the old refusal.
        with pytest.raises(ValueError, match="centre line crosses itself"):
            Track(rows[:-1, :2], 0.38, 0.38, left_border=rows[:-1, 2:4],
                  right_border=rows[:-1, 4:6])
        t = load_track(path)
        # Every row, exactly as in the file, closing row included.
        np.testing.assert_array_equal(t.waypoints, rows[:, :2])
        assert t.waypoints.shape == (71, 2)
        # Geometry: 70 distinct rows less the backtracked one and the near-duplicate.
        kept = [i for i in range(70) if i not in (20, 45)]
        np.testing.assert_array_equal(t.centre, rows[kept, :2])
        np.testing.assert_array_equal(t.left_border, rows[kept, 2:4])  # CCW: inner = left
        assert t.width.min() == pytest.approx(0.76)
        reverse = load_track(path, reverse=True)
        np.testing.assert_array_equal(reverse.waypoints, rows[::-1, :2])

    def test_params_waypoint_indices_are_file_rows(self, tmp_path: Path) -> None:
        from h2h_racing.config.env import CarParams
        from h2h_racing.deepracer.params import ParamsBuilder

        rows = with_route_slips(ellipse_route_rows(), back_row=20, duplicate_row=45)
        np.save(tmp_path / "slips.npy", rows)
        t = load_track(tmp_path / "slips.npy")
        builder = ParamsBuilder(t, CarParams(), 1)
        # Half-way between file rows k and k + 1 (after both slips, where geometry vertex
        # indices are 2 lower than row indices, and before them), on the centre line.
        for k in (10, 60, 68):
            mid = 0.5 * (rows[k, :2] + rows[k + 1, :2])
            heading = np.arctan2(*(rows[k + 1, 1::-1] - rows[k, 1::-1]))
            back = mid - 0.14 * np.array([np.cos(heading), np.sin(heading)])
            (p,) = builder.build(position=back[None], yaw=np.array([heading]),
                                 speed_command=np.ones(1), steering_deg=np.zeros(1),
                                 start_distance=np.zeros(1), steps=1.0, sim_time=0.0)
            assert p["closest_waypoints"] == [k, k + 1]
            assert p["waypoints"] == [tuple(r) for r in rows[:, :2].tolist()]

    def test_route_geometry_rows_by_hand(self) -> None:
        c = np.array([[0, 0], [1, 0], [0.998, 0], [1.0005, 0.0003], [2, 0], [2, 1], [0, 1],
                      [0, 0.005], [0, 0]])
        # Row 2 is 2 mm back, row 3 0.6 mm from row 1, row 7 5 mm from row 0, row 8 = row 0.
        np.testing.assert_array_equal(route_geometry_rows(c), [0, 1, 4, 5, 6])
        # At 1 mm, row 2 (2 mm from row 1) stays, and row 3 is 2.5 mm from it; row 7 stays.
        np.testing.assert_array_equal(route_geometry_rows(c, tolerance=0.001), np.arange(8))

    def test_real_crossings_and_large_backtracks_are_refused(self, tmp_path: Path) -> None:
        # A figure of eight crosses itself at the origin.
        t = np.linspace(0, 2 * np.pi, 60, endpoint=False)
        centre = np.stack([3 * np.sin(t), 1.5 * np.sin(2 * t)], axis=1)
        rows = np.concatenate([centre, centre + [0, 0.3], centre - [0, 0.3]], axis=1)
        np.save(tmp_path / "eight.npy", np.vstack([rows, rows[:1]]))
        with pytest.raises(ValueError, match=r"eight\.npy.*crosses itself"):
            load_track(tmp_path / "eight.npy")
        # A step 5 cm backwards is no drawing slip: still refused.
        rows = ellipse_route_rows()
        step = rows[20, :2] - rows[19, :2]
        rows[20] = rows[19] - np.tile(0.05 * step / np.linalg.norm(step), 3)
        np.save(tmp_path / "back.npy", rows)
        with pytest.raises(ValueError, match=r"back\.npy.*(crosses itself|reverses direction)"):
            load_track(tmp_path / "back.npy")

    @needs(DEEPRACER / "reinvent_base.npy")
    def test_reinvent_2018_at_71_rows_with_its_slips(self, tmp_path: Path) -> None:
        path = tmp_path / "reinvent_2018_71.npy"
        np.save(path, reinvent_2018_71_rows(DEEPRACER / "reinvent_base.npy"))
        t = load_track(path)
        assert t.waypoints.shape == (71, 2) and len(t.centre) == 68
        assert t.length == pytest.approx(17.7, abs=0.1)


class TestCsv:
    """Centre-line CSV (TUMFTM / f1tenth layout)."""

    def test_written_file_with_scale(self, tmp_path: Path) -> None:
        path = tmp_path / "box.csv"
        path.write_text("# x_m,y_m,w_tr_right_m,w_tr_left_m\n0,0,3,4\n100,0,3,4\n100,50,3,4\n0,50,3,4\n")
        t = load_track(path)
        assert t.length == pytest.approx(300.0)  # 100 + 50 + 100 + 50
        np.testing.assert_allclose(t.width_right, 3.0)
        np.testing.assert_allclose(t.width_left, 4.0)
        u = load_track(path, scale=(0.1, 0.1))
        # Lengths x 0.1 -> 30 m; widths x 0.1 -> 0.3 m right, 0.4 m left.
        assert u.length == pytest.approx(30.0)
        np.testing.assert_allclose(u.width_right, 0.3)
        v = load_track(path, scale=(0.1, 0.08))
        np.testing.assert_allclose(v.width_left, 0.32)  # 4 m x 0.08
        with pytest.raises(ValueError, match="scale"):
            load_track(path, scale=(0.1, -1.0))

    @needs(CATALUNYA)
    def test_catalunya_full_scale(self) -> None:
        t = load_track(CATALUNYA)
        assert t.length == pytest.approx(4650, abs=5)  # 4.65 km lap (SOURCES.md)
        assert len(t.centre) == 931 and t.waypoints.shape == (932, 2)

    @needs(CATALUNYA)
    def test_catalunya_at_deepracer_scale_is_rejected(self) -> None:
        """Shrunk uniformly to a 60 m, 0.9 m wide lap, the real hairpin is tighter than the half-width.

        DeepRacer's own 60 m Spain_track is a re-drawing, not a scaled copy: at 60 / 4650 = 0.0129 the
        hairpin's radius falls below the 0.45 m half-width and the left border crosses itself.
        """
        length = load_track(CATALUNYA).length
        with pytest.raises(ValueError, match=r"Catalunya\.csv.*left border (folds back|crosses itself).*vertex"):
            load_track(CATALUNYA, scale=(60.0 / length, 0.9 / 11.7))
        # A uniform scale keeps the shape valid but makes it 8.56 m x 0.0129 = 0.11 m wide at its narrowest.
        with pytest.raises(ValueError, match=r"Catalunya\.csv.*m wide at vertex \d+ .*0\.40 m"):
            load_track(CATALUNYA, scale=60.0 / length)
        # At 1/20 scale (232 m lap, 0.43-0.89 m wide) it is a valid track.
        t = load_track(CATALUNYA, scale=0.05)
        assert t.length == pytest.approx(length * 0.05) and not t.is_ccw


class TestRandomTracks:
    """``load_track("random:<seed>")`` builds a procedurally generated track."""

    def test_same_seed_same_track_and_different_seed_different_track(self) -> None:
        a, b, c = load_track("random:3"), load_track("random:3"), load_track("random:4")
        assert np.array_equal(a.centre, b.centre)
        assert a.name == "random:3"
        assert a.centre.shape != c.centre.shape or not np.array_equal(a.centre, c.centre)
        # random_track's default lap length range is 20-45 m.
        assert 20.0 <= a.length <= 45.0

    def test_bad_seed_is_a_clear_error(self) -> None:
        with pytest.raises(ValueError, match="random:<integer seed>"):
            load_track("random:abc")


class TestNamedTrackCache:
    """Catalogue and random tracks are loaded once per process and shared (they are immutable)."""

    def test_same_object_for_the_same_name(self) -> None:
        assert load_track("oval") is load_track("oval")
        assert load_track("random:5") is load_track("random:5")

    def test_reversed_and_scaled_are_new_tracks(self) -> None:
        base = load_track("oval")
        assert load_track("oval", reverse=True) is not base
        assert load_track("oval", scale=2.0).length == pytest.approx(2.0 * base.length)
