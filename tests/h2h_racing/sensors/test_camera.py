"""Tests for :mod:`h2h_racing.sensors.camera`: pinhole geometry by hand, occlusion, stacking,
stereo, batching, determinism, spaces and golden images."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import cv2
import numpy as np
import pytest

import h2h_racing
from h2h_racing.config.env import EnvConfig
from h2h_racing.sim.core import RaceCore
from h2h_racing.sensors.camera import (
    CAR_SHADES,
    SKY,
    CameraConfig,
    CameraSensor,
    save_camera_png,
)

HERE = Path(__file__).resolve().parent
_spec = importlib.util.spec_from_file_location("make_golden", HERE / "make_golden.py")
make_golden = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(make_golden)

TRACK = "oval"
EGO_X = -2.0  # [m] ego car on the oval's bottom straight (y = 0), heading +x
CAMERA_X = EGO_X + 0.145  # optical centre, forward_m ahead of the car's origin
HALF_LENGTH = 0.5 * 0.3235  # [m] car box
GOLDEN_MAX_DIFF = 2  # grey levels a golden pixel may differ by (OpenCV rounding)
GOLDEN_MAX_FRACTION = 0.002  # fraction of golden pixels allowed beyond GOLDEN_MAX_DIFF


def make_core(num_cars: int = 2, num_obstacles: int = 0, num_envs: int = 1) -> RaceCore:
    """A reset core on the oval with car 0 at (EGO_X, 0) heading +x and the others parked."""
    config = EnvConfig(track=TRACK, num_cars=num_cars, num_obstacles=num_obstacles,
                       grid="fixed")
    core = RaceCore(config, h2h_racing.load_track(TRACK), num_envs=num_envs)
    core.reset(seed=0)
    core.position[:, 0] = (EGO_X, 0.0)
    core.yaw[:, 0] = 0.0
    core.done[:, 1:] = True  # hidden until a test places them
    if num_obstacles:
        core.obstacle_position[:] = (50.0, 50.0)  # far off the track, outside the view
    return core


def make_sensor(core: RaceCore, config: CameraConfig | None = None) -> CameraSensor:
    return CameraSensor(config or CameraConfig(), core.track, core.config.car,
                        (core.config.obstacle_length, core.config.obstacle_width))


def place(core: RaceCore, car: int, x: float, y: float, yaw: float = 0.0) -> None:
    core.position[0, car] = (x, y)
    core.yaw[0, car] = yaw
    core.done[0, car] = False


def changed(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns where two (H, W) frames differ."""
    diff = a != b
    return np.flatnonzero(diff.any(axis=1)), np.flatnonzero(diff.any(axis=0))


class TestPinholeGeometry:
    """A box at a hand-computed distance and bearing lands in the expected pixels."""

    def test_car_straight_ahead(self) -> None:
        # fx = (160 / 2) / tan(64.7 deg / 2) = 80 / 0.63318 = 126.35 px; cx = 79.5, cy = 59.5.
        # Car 1 aligned with the ego, its rear face F = 1.0 m ahead of the optical centre,
        # half-width 0.09805 m. A point F ahead, height z, right offset X has
        #   Zc = F cos15 + (0.13 - z) sin15,  col = 79.5 + 126.35 X / Zc.
        # Top rear corners (z = 0.12): Zc = 0.96593 + 0.01 * 0.25882 = 0.96852,
        #   col = 79.5 -+ 126.35 * 0.09805 / 0.96852 = 79.5 -+ 12.79 -> [66.71, 92.29].
        # Bottom rear corners (z = 0): Zc = 0.99958 -> [67.11, 91.89]; the far corners are
        # narrower. Pixel centres inside [66.71, 92.29]: columns 67 .. 92.
        # Rows: row = 59.5 + 126.35 Yc / Zc with Yc = -F sin15 - (z - 0.13) cos15.
        # Bottom rear edge: Yc = -0.25882 + 0.12557 = -0.13325 -> row 59.5 - 16.84 = 42.66;
        # the top face's far edge (F = 1.3235 m): row 59.5 - 32.83 = 26.67. Rows 27 .. 42.
        core = make_core()
        sensor = make_sensor(core)
        empty = sensor.render(core)[:, :, 0]
        place(core, 1, CAMERA_X + 1.0 + HALF_LENGTH, 0.0)
        frame = sensor.render(core)[:, :, 0]
        rows, cols = changed(empty, frame)
        assert abs(cols.min() - 67) <= 1 and abs(cols.max() - 92) <= 1, (cols.min(), cols.max())
        assert abs(rows.min() - 27) <= 1 and abs(rows.max() - 42) <= 1, (rows.min(), rows.max())
        assert frame[35, 79] in {round(CAR_SHADES[1] * f) for f in (0.8, 1.0)}

    def test_car_ahead_left(self) -> None:
        # Car 1 aligned, rear face F = 1.5 m ahead, centred 0.4 m left: X in [-0.498, -0.302].
        # Leftmost: rear top-left corner, Zc = 1.5 * 0.96593 + 0.0026 = 1.45148,
        #   col = 79.5 - 126.35 * 0.49805 / 1.45148 = 36.14.
        # Rightmost: the far bottom-right corner (F = 1.8235 m; the right side face is seen),
        #   Zc = 1.8235 * 0.96593 + 0.03365 = 1.79501, col = 79.5 - 126.35 * 0.30195 / 1.79501
        #   = 58.25. Pixel centres: columns 37 .. 58.
        core = make_core()
        sensor = make_sensor(core)
        empty = sensor.render(core)[:, :, 0]
        place(core, 1, CAMERA_X + 1.5 + HALF_LENGTH, 0.4)
        frame = sensor.render(core)[:, :, 0]
        _, cols = changed(empty, frame)
        assert abs(cols.min() - 37) <= 1 and abs(cols.max() - 58) <= 1, (cols.min(), cols.max())

    def test_nothing_appears_behind(self) -> None:
        core = make_core(num_obstacles=1)
        sensor = make_sensor(core)
        empty = sensor.render(core)
        place(core, 1, EGO_X - 1.0, 0.0)
        core.obstacle_position[0, 0] = (EGO_X - 2.0, 0.3)
        np.testing.assert_array_equal(sensor.render(core), empty)

    def test_horizon_and_sky(self) -> None:
        # Horizon row = cy - fy tan15 = 59.5 - 126.35 * 0.26795 = 25.64: rows 0 .. 25 are sky.
        core = make_core()
        sensor = make_sensor(core)
        assert sensor.ground_row == 26
        frame = sensor.render(core)[:, :, 0]
        assert (frame[:26] == SKY).all()
        assert (frame[26:] != SKY).any(axis=1).all()

    def test_ground_map_inverts_the_pinhole(self) -> None:
        """Pixel -> texture -> world by the homography, then world -> pixel by the pinhole."""
        core = make_core()
        core.yaw[0, 0] = 0.7
        sensor = make_sensor(core)
        cfg = sensor.config
        cam_xy, maps = sensor.ground_maps(core.position, core.yaw)
        tex = sensor.texture
        res, (x0, y1) = tex.resolution, tex.origin
        psi, theta = 0.7, math.radians(cfg.pitch_deg)
        for u, v in [(0.0, 119.0), (79.5, 60.0), (159.0, 40.0), (20.0, 30.0)]:
            a, b, w = maps[0, 0, 0] @ np.array([u, v - sensor.ground_row, 1.0])
            x, y = x0 + res * a / w, y1 - res * b / w
            d = np.array([x - cam_xy[0, 0, 0, 0], y - cam_xy[0, 0, 0, 1], -cfg.height_m])
            f = np.array([math.cos(psi), math.sin(psi), 0.0])
            r = np.array([math.sin(psi), -math.cos(psi), 0.0])
            up = np.array([0.0, 0.0, 1.0])
            xc, yc = d @ r, d @ (-math.sin(theta) * f - math.cos(theta) * up)
            zc = d @ (math.cos(theta) * f - math.sin(theta) * up)
            assert zc > 0
            assert sensor.cx + sensor.focal * xc / zc == pytest.approx(u, abs=1e-6)
            assert sensor.cy + sensor.focal * yc / zc == pytest.approx(v, abs=1e-6)


class TestOcclusionAndShades:
    """Nearer boxes hide farther ones; every car has its own shade."""

    def test_near_car_hides_far_obstacle(self) -> None:
        core = make_core(num_obstacles=1)
        sensor = make_sensor(core)
        empty = sensor.render(core)[:, :, 0]
        place(core, 1, CAMERA_X + 0.8 + HALF_LENGTH, 0.0)
        near_only = sensor.render(core)[:, :, 0]
        near_mask = near_only != empty
        core.obstacle_position[0, 0] = (CAMERA_X + 2.5, 0.15)
        both = sensor.render(core)[:, :, 0]
        np.testing.assert_array_equal(both[near_mask], near_only[near_mask])
        assert (both[~near_mask] != near_only[~near_mask]).any(), "the obstacle peeks out"

    def test_cars_have_distinct_shades(self) -> None:
        assert len(set(CAR_SHADES)) == len(CAR_SHADES)
        core = make_core(num_cars=3)
        sensor = make_sensor(core)
        place(core, 1, CAMERA_X + 1.0 + HALF_LENGTH, 0.0)
        with_1 = sensor.render(core)
        core.done[0, 1] = True
        place(core, 2, CAMERA_X + 1.0 + HALF_LENGTH, 0.0)
        with_2 = sensor.render(core)
        assert (with_1 != with_2).mean() > 0.01

    @pytest.mark.parametrize("x, y, yaw", [
        (EGO_X + 0.1, 0.15, 0.0),  # beside the camera: its box straddles the near plane
        (EGO_X + 0.2, 0.0, 0.5),  # overlapping the camera
        (EGO_X + 0.4, -0.3, 1.2),
        (EGO_X + 0.3, 0.12, -2.0),
    ])
    def test_boxes_crossing_the_near_plane(self, x: float, y: float, yaw: float) -> None:
        """Boxes partly behind or around the camera are clipped, not smeared."""
        core = make_core()
        sensor = make_sensor(core)
        empty = sensor.render(core)
        place(core, 1, x, y, yaw)
        frame = sensor.render(core)
        np.testing.assert_array_equal(sensor.render(core), frame)
        shades = {round(CAR_SHADES[1] * f) for f in (0.8, 0.62, 1.0)}
        assert set(np.unique(frame[frame != empty]).tolist()) <= shades

    def test_parked_car_is_not_drawn(self) -> None:
        core = make_core()
        sensor = make_sensor(core)
        empty = sensor.render(core)
        place(core, 1, CAMERA_X + 1.0 + HALF_LENGTH, 0.0)
        core.done[0, 1] = True
        np.testing.assert_array_equal(sensor.render(core), empty)


class TestObservation:
    """Spaces, dtypes, batching, determinism, frame stacking and stereo."""

    def test_space_and_dtype(self) -> None:
        core = make_core()
        for config in (CameraConfig(), CameraConfig(stereo=True, frame_stack=3, width=64,
                                                    height=48)):
            sensor = make_sensor(core, config)
            space = sensor.space()
            obs = sensor.observe(core)
            assert space.dtype == np.uint8 and space.shape == (config.height, config.width,
                                                               config.channels)
            assert obs.dtype == np.uint8 and obs.flags.c_contiguous
            assert obs.shape == (1, 2) + space.shape
            for i in range(2):
                assert space.contains(obs[0, i])

    def test_out_argument_is_filled_and_checked(self) -> None:
        core = make_core()
        sensor = make_sensor(core)
        out = np.zeros((1, 2, 120, 160, 1), dtype=np.uint8)
        assert sensor.observe(core, out) is out
        np.testing.assert_array_equal(out, sensor.observe(core))
        with pytest.raises(ValueError, match="C-contiguous uint8"):
            sensor.observe(core, np.zeros((1, 2, 120, 160, 2), dtype=np.uint8))

    def test_driving_changes_the_image_and_identical_states_give_identical_images(self) -> None:
        config = EnvConfig(track=TRACK, num_cars=2, grid="fixed")
        core = RaceCore(config, h2h_racing.load_track(TRACK), num_envs=1)
        core.reset(seed=0)
        sensor = make_sensor(core)
        before = sensor.observe(core)
        np.testing.assert_array_equal(make_sensor(core).observe(core), before)
        position = core.position.copy()
        for _ in range(6):
            core.step(np.zeros((1, 2)), np.full((1, 2), 3.0))
        assert (np.linalg.norm(core.position - position, axis=-1) > 0.2).all()
        after = sensor.observe(core)
        for i in range(2):
            assert (before[0, i] != after[0, i]).mean() > 0.01, f"car {i} image did not change"

    def test_batch_equals_single_envs(self) -> None:
        core = make_core(num_envs=3)
        core.done[:] = False
        core.position[:, 1] = [(EGO_X + 1.2, 0.1), (EGO_X + 2.0, -0.2), (EGO_X - 1.0, 0.0)]
        core.yaw[:, 0] = [0.0, 0.1, -0.1]
        sensor = make_sensor(core)
        batch = sensor.observe(core)
        for e in range(3):
            for i in range(2):
                np.testing.assert_array_equal(batch[e, i], sensor.render(core, e, i))

    def test_frame_stack(self) -> None:
        core = make_core()
        place(core, 1, EGO_X + 1.5, 0.2)
        sensor = make_sensor(core, CameraConfig(frame_stack=3))
        first = sensor.observe(core)
        for t in range(3):
            np.testing.assert_array_equal(first[..., t], first[..., 0])
        core.step(np.zeros((1, 2)), np.full((1, 2), 2.0))
        second = sensor.observe(core)
        np.testing.assert_array_equal(second[..., 0], first[..., 2])
        np.testing.assert_array_equal(second[..., 1], first[..., 2])
        assert (second[..., 2] != first[..., 2]).any()
        np.testing.assert_array_equal(sensor.observe(core), second)  # same step: idempotent
        core.step(np.zeros((1, 2)), np.full((1, 2), 2.0))
        third = sensor.observe(core)
        np.testing.assert_array_equal(third[..., 0], second[..., 1])
        np.testing.assert_array_equal(third[..., 1], second[..., 2])
        core.reset_envs(np.ones(1, dtype=bool))  # new episode: the history is refilled
        fresh = sensor.observe(core)
        for t in range(3):
            np.testing.assert_array_equal(fresh[..., t], fresh[..., 2])

    def test_stereo_disparity(self) -> None:
        # Disparity of a point at depth Zc: fx * baseline / Zc = 126.35 * 0.06 / 0.97 = 7.8 px;
        # the left camera sees the car further right than the right camera does.
        core = make_core()
        sensor = make_sensor(core, CameraConfig(stereo=True))
        empty = sensor.render(core)
        place(core, 1, CAMERA_X + 1.0 + HALF_LENGTH, 0.0)
        frame = sensor.render(core)
        _, left_cols = changed(empty[:, :, 0], frame[:, :, 0])
        _, right_cols = changed(empty[:, :, 1], frame[:, :, 1])
        shift = 0.5 * (left_cols.min() + left_cols.max() - right_cols.min() - right_cols.max())
        assert shift == pytest.approx(126.35 * 0.06 / 0.97, abs=1.0)


class TestConfigAndTools:
    """Validation messages and the PNG helper."""

    @pytest.mark.parametrize("kwargs, match", [
        ({"width": 4}, "width"), ({"frame_stack": 0}, "frame_stack"),
        ({"hfov_deg": 180.0}, "hfov_deg"), ({"height_m": -0.1}, "height_m"),
        ({"interpolation": "cubic"}, "interpolation"), ({"stereo": 1}, "stereo"),
    ])
    def test_invalid_config(self, kwargs: dict, match: str) -> None:
        with pytest.raises(ValueError, match=match):
            CameraConfig(**kwargs)

    def test_save_camera_png(self, tmp_path: Path) -> None:
        core = make_core()
        path = save_camera_png(core, 0, tmp_path / "car0.png", scale=2)
        image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        assert image.shape == (240, 320) and image.dtype == np.uint8
        with pytest.raises(ValueError, match="car must be"):
            save_camera_png(core, 5, tmp_path / "x.png")


class TestGolden:
    """Fixed scenes match the stored frames (regenerate with make_golden.py, on purpose)."""

    @pytest.mark.parametrize("file_name", sorted(make_golden.GOLDEN))
    def test_golden(self, file_name: str) -> None:
        scene_name, config = make_golden.GOLDEN[file_name]
        expected = cv2.imread(str(make_golden.GOLDEN_DIR / file_name), cv2.IMREAD_UNCHANGED)
        assert expected is not None, f"missing {file_name}; run make_golden.py"
        got = make_golden.render_golden(scene_name, config)
        assert got.shape == expected.shape
        diff = np.abs(got.astype(np.int16) - expected.astype(np.int16))
        assert (diff > GOLDEN_MAX_DIFF).mean() <= GOLDEN_MAX_FRACTION, (
            f"{file_name}: {(diff > GOLDEN_MAX_DIFF).sum()} pixels differ by more than "
            f"{GOLDEN_MAX_DIFF}; if the change is intended, run make_golden.py and look at it")
