"""Tests for :mod:`h2h_racing.sensors.lidar`: hand-computed ranges and bearings, a segment
intersection reference, noise determinism, sector mode, spaces and validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import h2h_racing
from h2h_racing.config.env import CarParams, EnvConfig
from h2h_racing.sim.core import RaceCore
from h2h_racing.sensors.lidar import LidarConfig, LidarSensor

TRACK = "oval"
EGO = (-2.0, 0.0)  # [m] ego car on the oval's bottom straight, heading +x
HALF_LENGTH, HALF_WIDTH = 0.5 * 0.3235, 0.5 * 0.1961  # [m] car box
BEAM_STEP = math.radians(300.0) / 63  # 4.762 deg between beams
FAR = LidarConfig(max_range=2.0)


def make_core(num_cars: int = 2, num_obstacles: int = 0, num_envs: int = 1) -> RaceCore:
    """A reset core with car 0 at EGO heading +x, the other cars hidden, obstacles far away."""
    config = EnvConfig(track=TRACK, num_cars=num_cars, num_obstacles=num_obstacles,
                       grid="fixed")
    core = RaceCore(config, h2h_racing.load_track(TRACK), num_envs=num_envs)
    core.reset(seed=0)
    core.position[:, 0] = EGO
    core.yaw[:, 0] = 0.0
    core.done[:, 1:] = True
    if num_obstacles:
        core.obstacle_position[:] = (50.0, 50.0)
    return core


def make_sensor(core: RaceCore, config: LidarConfig = FAR) -> LidarSensor:
    return LidarSensor(config, core.config.car,
                       (core.config.obstacle_length, core.config.obstacle_width))


def place(core: RaceCore, car: int, x: float, y: float, yaw: float = 0.0) -> None:
    core.position[0, car] = (x, y)
    core.yaw[0, car] = yaw
    core.done[0, car] = False


def reference_ranges(origin: np.ndarray, heading: float, angles: np.ndarray,
                     boxes: list[tuple[float, float, float, float, float]]) -> np.ndarray:
    """Nearest hit per beam by ray-segment intersection with the 4 edges of each box
    ``(x, y, yaw, length, width)`` (inf when none); a different algorithm from the slab."""
    out = np.full(len(angles), np.inf)
    for k, a in enumerate(angles):
        d = np.array([math.cos(heading + a), math.sin(heading + a)])
        for x, y, yaw, length, width in boxes:
            c, s = math.cos(yaw), math.sin(yaw)
            local = np.array([[0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5], [0.5, -0.5]]) * [length,
                                                                                     width]
            corners = np.array([x, y]) + local @ np.array([[c, s], [-s, c]])
            for q in range(4):
                p0, p1 = corners[q], corners[(q + 1) % 4]
                e = p1 - p0
                # Solve origin + t d = p0 + u e for (t, u).
                det = d[0] * -e[1] + d[1] * e[0]
                if abs(det) < 1e-12:
                    continue
                w = p0 - origin
                t = (w[0] * -e[1] + w[1] * e[0]) / det
                u = (d[0] * w[1] - d[1] * w[0]) / det
                if t >= 0 and 0 <= u <= 1:
                    out[k] = min(out[k], t)
    return out


class TestHandComputedHits:
    """Boxes at hand-computed distances and bearings."""

    def test_car_straight_ahead(self) -> None:
        # Beams 31 and 32 point at -+2.381 deg (63 gaps of 4.762 deg over 300 deg). Car 1 is
        # centred 1.0 m ahead, so its rear face is at x = 1.0 - 0.16175 = 0.83825 m; the beams
        # meet it at a lateral 0.83825 tan(2.381 deg) = 0.0349 < 0.098 m, range
        # 0.83825 / cos(2.381 deg) = 0.83897 m. Beams 30 and 33 (-+7.143 deg) pass at
        # 0.105 .. 0.146 m lateral over the car's length: they miss.
        core = make_core()
        place(core, 1, EGO[0] + 1.0, 0.0)
        scan = make_sensor(core).observe(core)[0, 0]
        assert scan[31] == pytest.approx(0.83897, abs=1e-4)
        assert scan[32] == pytest.approx(0.83897, abs=1e-4)
        others = np.delete(scan, [31, 32])
        assert (others == np.float32(2.0)).all()

    def test_obstacle_at_45_degrees(self) -> None:
        # Obstacle (0.5 m long, 0.4 m wide) centred 1.5 m away at a bearing of 45 deg, its
        # axis pointing at the sensor: its near face is 1.5 - 0.25 = 1.25 m away. The nearest
        # beam is (45 + 150) / 4.762 = 40.95 -> beam 41 (45.24 deg): range 1.25 /
        # cos(0.24 deg) = 1.2500 m. Beams 40 and 42 (4.5 and 5.0 deg off) also hit the face.
        core = make_core(num_obstacles=1)
        a = math.radians(45.0)
        core.obstacle_position[0, 0] = (EGO[0] + 1.5 * math.cos(a), EGO[1] + 1.5 * math.sin(a))
        core.obstacle_yaw[0, 0] = a
        scan = make_sensor(core).observe(core)[0, 0]
        assert int(np.argmin(scan)) in (40, 41, 42)
        assert scan.min() == pytest.approx(1.25, abs=0.01)
        assert np.flatnonzero(scan < 2.0).tolist() == [40, 41, 42]

    def test_nothing_behind(self) -> None:
        # Directly behind is 180 deg, outside the +-150 deg fan.
        core = make_core()
        place(core, 1, EGO[0] - 1.0, 0.0)
        assert (make_sensor(core).observe(core)[0, 0] == np.float32(2.0)).all()

    def test_car_2_sees_car_0_and_parked_cars_are_invisible(self) -> None:
        core = make_core()
        place(core, 1, EGO[0] + 1.0, 0.0, math.pi)  # facing the ego: sees it 0.83897 m ahead
        scan = make_sensor(core).observe(core)
        assert scan[0, 1, 31] == pytest.approx(0.83897, abs=1e-4)
        core.done[0, 0] = True
        assert (make_sensor(core).observe(core)[0, 1] == np.float32(2.0)).all()

    def test_overlap_reads_min_range(self) -> None:
        core = make_core()
        place(core, 1, EGO[0] + 0.05, 0.0)
        scan = make_sensor(core).observe(core)[0, 0]
        assert (scan == np.float32(0.15)).any()

    def test_mount_offset(self) -> None:
        # A scanner 0.1 m further forward reads the car straight ahead 0.1 / cos(2.381 deg)
        # = 0.10009 m nearer.
        core = make_core()
        place(core, 1, EGO[0] + 1.0, 0.0)
        scan = make_sensor(core, LidarConfig(max_range=2.0, mount_forward_m=0.1)).observe(core)
        assert scan[0, 0, 31] == pytest.approx(0.83897 - 0.10009, abs=1e-4)


class TestReference:
    """The slab kernel matches a ray-segment reference on random scenes."""

    core = make_core(num_obstacles=1)
    """One scene reused by every example (each example sets every pose it reads)."""

    @settings(max_examples=40, deadline=None)
    @given(st.floats(-1.5, 1.5), st.floats(-1.5, 1.5), st.floats(-math.pi, math.pi),
           st.floats(-1.5, 1.5), st.floats(-1.5, 1.5), st.floats(-math.pi, math.pi),
           st.floats(-math.pi, math.pi))
    def test_matches_reference(self, x1: float, y1: float, yaw1: float, xo: float, yo: float,
                               yawo: float, yaw0: float) -> None:
        core = self.core
        core.yaw[0, 0] = yaw0
        place(core, 1, EGO[0] + x1, y1, yaw1)
        core.obstacle_position[0, 0] = (EGO[0] + xo, yo)
        core.obstacle_yaw[0, 0] = yawo
        sensor = make_sensor(core, LidarConfig(max_range=12.0))
        got = sensor.ranges(core)[0, 0]
        car = CarParams()
        want = reference_ranges(np.array(EGO), yaw0, sensor.config.angles,
                                [(EGO[0] + x1, y1, yaw1, car.length, car.width),
                                 (EGO[0] + xo, yo, yawo, 0.5, 0.4)])
        inside = np.isfinite(want) | np.isfinite(got)
        # Rays that start inside a box read 0 in the kernel, the edge distance in the reference.
        started_inside = got == 0.0
        check = inside & ~started_inside
        np.testing.assert_allclose(got[check], want[check], atol=1e-9)
        assert (np.isfinite(got) == np.isfinite(want))[~started_inside].all()


class TestObservation:
    """Spaces, noise, determinism, sectors and batching."""

    def test_space_and_dtype(self) -> None:
        core = make_core(num_obstacles=2)
        place(core, 1, EGO[0] + 0.5, 0.1)
        for config in (LidarConfig(), LidarConfig(noise_std=0.05),
                       LidarConfig(mode="sector_lidar")):
            sensor = make_sensor(core, config)
            obs = sensor.observe(core, np.random.default_rng(0))
            space = sensor.space()
            assert obs.dtype == np.float32 and space.dtype == np.float32
            assert obs.shape == (1, 2, config.size) == (1, 2) + space.shape
            for i in range(2):
                assert space.contains(obs[0, i]), obs[0, i]

    def test_noise_is_seeded(self) -> None:
        core = make_core()
        place(core, 1, EGO[0] + 0.6, 0.0)
        sensor = make_sensor(core, LidarConfig(max_range=2.0, noise_std=0.01))
        a = sensor.observe(core, np.random.default_rng(7))
        b = sensor.observe(core, np.random.default_rng(7))
        c = sensor.observe(core, np.random.default_rng(8))
        np.testing.assert_array_equal(a, b)
        assert not np.array_equal(a, c)
        clean = make_sensor(core).observe(core)
        hit = clean < 2.0
        assert np.abs(a[hit] - clean[hit]).max() < 0.05
        np.testing.assert_array_equal(a[~hit], clean[~hit])  # misses stay at max_range
        with pytest.raises(ValueError, match="np.random.Generator"):
            sensor.observe(core)

    def test_driving_changes_the_scan_and_identical_states_give_identical_scans(self) -> None:
        # The fixed grid puts car 0 about 0.9 m ahead-right of car 1 (within 2 m); car 1
        # drives faster, so its scan changes from step to step.
        config = EnvConfig(track=TRACK, num_cars=2, grid="fixed")
        core = RaceCore(config, h2h_racing.load_track(TRACK), num_envs=1)
        core.reset(seed=0)
        sensor = make_sensor(core)
        before = sensor.observe(core)
        assert (before[0, 1] < 2.0).any(), "car 0 should be in view"
        np.testing.assert_array_equal(sensor.observe(core), before)
        for _ in range(8):
            core.step(np.zeros((1, 2)), np.array([[0.5, 3.0]]))
        after = sensor.observe(core)
        assert not np.array_equal(after[0, 1], before[0, 1])
        assert after[0, 1].min() < before[0, 1].min()  # closing in on car 0

    def test_sector_lidar(self) -> None:
        # Car 1's rear face 0.4 - 0.16175 = 0.238 m ahead: beams 31 and 32 -> sectors 3 and 4
        # (8 beams each) read 1, the rest 0. At 0.7 m ahead nothing is within 0.5 m.
        core = make_core()
        place(core, 1, EGO[0] + 0.4, 0.0)
        sensor = make_sensor(core, LidarConfig(mode="sector_lidar"))
        np.testing.assert_array_equal(sensor.observe(core)[0, 0],
                                      np.array([0, 0, 0, 1, 1, 0, 0, 0], dtype=np.float32))
        place(core, 1, EGO[0] + 0.7 + HALF_LENGTH, 0.0)
        assert (sensor.observe(core)[0, 0] == 0).all()

    def test_batch_equals_single_envs(self) -> None:
        core = make_core(num_obstacles=1, num_envs=3)
        core.done[:] = False
        core.position[:, 1] = [(EGO[0] + 0.8, 0.1), (EGO[0] + 1.5, -0.2), (EGO[0] - 0.5, 0.0)]
        core.obstacle_position[:, 0] = [(EGO[0] + 1.0, 0.5), (50.0, 50.0), (EGO[0], -0.6)]
        sensor = make_sensor(core)
        batch = sensor.observe(core)
        for e in range(3):
            single = make_core(num_obstacles=1)
            single.position[0] = core.position[e]
            single.yaw[0] = core.yaw[e]
            single.done[0] = False
            single.obstacle_position[0] = core.obstacle_position[e]
            single.obstacle_yaw[0] = core.obstacle_yaw[e]
            np.testing.assert_array_equal(batch[e], sensor.observe(single)[0])


class TestConfig:
    """Validation says what is wrong."""

    @pytest.mark.parametrize("kwargs, match", [
        ({"max_range": 13.0}, "max_range"), ({"min_range": 1.0, "max_range": 1.0}, "min_range"),
        ({"beams": 0}, "beams"), ({"sectors": 7}, "sectors"), ({"noise_std": -1.0}, "noise"),
        ({"mode": "sonar"}, "mode"), ({"fov_deg": 400.0}, "fov_deg"),
    ])
    def test_invalid_config(self, kwargs: dict, match: str) -> None:
        with pytest.raises(ValueError, match=match):
            LidarConfig(**kwargs)

    def test_angles(self) -> None:
        angles = LidarConfig().angles
        assert angles[0] == pytest.approx(-math.radians(150.0))
        assert angles[-1] == pytest.approx(math.radians(150.0))
        assert np.diff(angles) == pytest.approx(np.full(63, BEAM_STEP))
