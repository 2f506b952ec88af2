"""Sensor configs: the camera (:class:`CameraConfig`) and the lidar (:class:`LidarConfig`)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


def _camera_fail(name: str, value: object, expected: str) -> None:
    raise ValueError(f"CameraConfig.{name} must be {expected}, got {value!r}; fix the value "
                     f"passed to CameraConfig")


MAX_FRAME_STACK = 32
"""Most camera frames one observation stacks (``CameraConfig.frame_stack``)."""
HFOV_RANGE_DEG = (1.0, 170.0)
"""Allowed horizontal fields of view (``CameraConfig.hfov_deg``) [deg]."""


@dataclass(frozen=True, kw_only=True)
class CameraConfig:
    """Where the camera sits, what it resolves and how frames are produced.

    The defaults reproduce DeepRacer's ``FRONT_FACING_CAMERA`` observation (160 x 120
    greyscale, stack 1); ``stereo=True`` gives ``STEREO_CAMERAS`` (two channels).
    """

    width: int = 160
    """Image width [px]."""
    height: int = 120
    """Image height [px]."""
    stereo: bool = False
    """Two cameras side by side (channel 0 left, 1 right) instead of one."""
    stereo_baseline_m: float = 0.06
    """Distance between the two optical centres with ``stereo`` [m]."""
    frame_stack: int = 1
    """Frames per observation, oldest first; a new episode repeats its first frame."""
    height_m: float = 0.13
    """Height of the optical centre above the ground [m]."""
    forward_m: float = 0.145
    """Distance of the optical centre ahead of the car's origin [m]."""
    pitch_deg: float = 15.0
    """Downward pitch of the optical axis [deg]."""
    hfov_deg: float = 64.7
    """Horizontal field of view [deg]; the vertical one follows from square pixels."""
    near_m: float = 0.02
    """Near clipping distance along the optical axis [m] (Gazebo's clip)."""
    texture_resolution_m: float = 0.01
    """Size of one ground-texture pixel [m/px]."""
    max_texture_px: int = 8192
    """Largest ground-texture side [px]; a larger track gets a coarser resolution."""
    interpolation: Literal["linear", "nearest"] = "linear"
    """Ground-texture sampling (bilinear is smoother, nearest is a little faster)."""
    car_height_m: float = 0.12
    """Height of the car boxes [m]."""
    obstacle_height_m: float = 0.2
    """Height of the obstacle boxes [m]."""

    def __post_init__(self) -> None:
        for name in ("width", "height", "frame_stack", "max_texture_px"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool):
                _camera_fail(name, value, "an int")
        if not 8 <= self.width <= 4096:
            _camera_fail("width", self.width, "in [8, 4096] px")
        if not 8 <= self.height <= 4096:
            _camera_fail("height", self.height, "in [8, 4096] px")
        if not 1 <= self.frame_stack <= MAX_FRAME_STACK:
            _camera_fail("frame_stack", self.frame_stack, f"in [1, {MAX_FRAME_STACK}]")
        if not 64 <= self.max_texture_px <= 32767:
            _camera_fail("max_texture_px", self.max_texture_px, "in [64, 32767] (OpenCV's limit)")
        if not isinstance(self.stereo, bool):
            _camera_fail("stereo", self.stereo, "a bool")
        for name in ("stereo_baseline_m", "height_m", "near_m", "texture_resolution_m",
                     "car_height_m", "obstacle_height_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                _camera_fail(name, value, "a finite number > 0")
        if not (isinstance(self.forward_m, (int, float)) and math.isfinite(self.forward_m)):
            _camera_fail("forward_m", self.forward_m, "a finite number")
        if not -80.0 <= self.pitch_deg <= 80.0:
            _camera_fail("pitch_deg", self.pitch_deg, "in [-80, 80] deg")
        if not HFOV_RANGE_DEG[0] <= self.hfov_deg <= HFOV_RANGE_DEG[1]:
            _camera_fail("hfov_deg", self.hfov_deg,
                         f"in [{HFOV_RANGE_DEG[0]:g}, {HFOV_RANGE_DEG[1]:g}] deg")
        if self.interpolation not in ("linear", "nearest"):
            _camera_fail("interpolation", self.interpolation, "'linear' or 'nearest'")

    @property
    def cameras(self) -> int:
        """Cameras per car: 2 with ``stereo``, else 1."""
        return 2 if self.stereo else 1

    @property
    def channels(self) -> int:
        """Channels of an observation: ``cameras * frame_stack``."""
        return self.cameras * self.frame_stack

    @property
    def focal_px(self) -> float:
        """Focal length in pixels, ``fx = fy = (W / 2) / tan(hfov / 2)``."""
        return 0.5 * self.width / math.tan(math.radians(0.5 * self.hfov_deg))

    @property
    def horizon_row(self) -> float:
        """Image row of the horizon, ``cy - fy tan(pitch)`` (may lie outside the image)."""
        return 0.5 * (self.height - 1) - self.focal_px * math.tan(math.radians(self.pitch_deg))

    def to_dict(self) -> dict[str, object]:
        """Return a plain, JSON-serialisable dict of this config."""
        return dataclasses.asdict(self)


LIDAR_MAX_RANGE = 12.0
"""Longest allowed ``LidarConfig.max_range`` [m] (DeepRacer's simulated hardware)."""


def _lidar_fail(name: str, value: object, expected: str) -> None:
    raise ValueError(f"LidarConfig.{name} must be {expected}, got {value!r}; fix the value "
                     f"passed to LidarConfig")


@dataclass(frozen=True, kw_only=True)
class LidarConfig:
    """Beams, ranges, noise and mode of the lidar (defaults: DeepRacer's ``LIDAR``)."""

    beams: int = 64
    """Number of beams B."""
    fov_deg: float = 300.0
    """Angle from the first to the last beam [deg] (+-150 deg)."""
    min_range: float = 0.15
    """Shortest reading [m]; nearer hits read this."""
    max_range: float = 1.0
    """Longest reading [m] (DeepRacer clips to 1.0 for the network; at most 12)."""
    noise_std: float = 0.0
    """Standard deviation of the Gaussian range noise [m] (DeepRacer's Gazebo: 0.01)."""
    mode: Literal["lidar", "sector_lidar"] = "lidar"
    """``"lidar"``: B ranges; ``"sector_lidar"``: ``sectors`` binary flags."""
    sectors: int = 8
    """Sectors of ``"sector_lidar"`` (must divide ``beams``)."""
    sector_clip: float = 0.5
    """A sector reads 1 when something is nearer than this [m]."""
    mount_forward_m: float = 0.0
    """Position of the scanner ahead of the car's origin [m]."""
    mount_left_m: float = 0.0
    """Position of the scanner left of the car's axis [m]."""

    def __post_init__(self) -> None:
        for name in ("beams", "sectors"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or not 1 <= value <= 4096:
                _lidar_fail(name, value, "an int in [1, 4096]")
        for name in ("fov_deg", "min_range", "max_range", "noise_std", "sector_clip",
                     "mount_forward_m", "mount_left_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                _lidar_fail(name, value, "a finite number")
        if not 0.0 < self.fov_deg <= 360.0:
            _lidar_fail("fov_deg", self.fov_deg, "in (0, 360] deg")
        if not 0.0 <= self.min_range < self.max_range <= LIDAR_MAX_RANGE:
            _lidar_fail("min_range/max_range", (self.min_range, self.max_range),
                  f"0 <= min_range < max_range <= {LIDAR_MAX_RANGE} m")
        if self.noise_std < 0.0:
            _lidar_fail("noise_std", self.noise_std, ">= 0 m")
        if self.mode not in ("lidar", "sector_lidar"):
            _lidar_fail("mode", self.mode, "'lidar' or 'sector_lidar'")
        if self.beams % self.sectors:
            _lidar_fail("sectors", self.sectors, f"a divisor of beams ({self.beams})")
        if not 0.0 < self.sector_clip <= LIDAR_MAX_RANGE:
            _lidar_fail("sector_clip", self.sector_clip, f"in (0, {LIDAR_MAX_RANGE}] m")

    @property
    def size(self) -> int:
        """Length of one observation: ``beams`` or ``sectors``."""
        return self.beams if self.mode == "lidar" else self.sectors

    @property
    def angles(self) -> FloatArray:
        """Bearing of each beam from the car's heading, (B,) [rad], CCW positive."""
        half = 0.5 * math.radians(self.fov_deg)
        if self.beams == 1:
            return np.zeros(1)
        return np.linspace(-half, half, self.beams)

    def to_dict(self) -> dict[str, object]:
        """Return a plain, JSON-serialisable dict of this config."""
        return dataclasses.asdict(self)
