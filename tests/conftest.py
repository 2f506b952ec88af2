"""Shared fixtures for the h2h-racing tests (kept small: tracks, env factory, rng, geometry)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

# pytest's default "prepend" import mode puts this directory on sys.path before importing this
# file; tests/h2h_racing/ (no __init__.py) would then shadow the h2h_racing package as a
# namespace package when pytest is run as `pytest` (not `python -m pytest`). Take it off again
# before anything imports h2h_racing. Test files import helpers via sys.modules["conftest"].
_HERE = str(Path(__file__).resolve().parent)
sys.path[:] = [p for p in sys.path if str(Path(p or ".").resolve()) != _HERE]
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import h2h_racing
from h2h_racing.track.shape import Track

CIRCLE_RADIUS = 3.0  # [m] default radius of the test circle
CIRCLE_HALF_WIDTH = 0.5  # [m] half-width of the test circle
CIRCLE_VERTICES = 400


def circle_track(radius: float = CIRCLE_RADIUS, half_width: float = CIRCLE_HALF_WIDTH,
                 vertices: int = CIRCLE_VERTICES, ccw: bool = True) -> Track:
    """A regular polygon inscribed in a circle, starting at (radius, 0), CCW by default.

    Its length is the polygon perimeter ``m * 2 R sin(pi / m)`` (2 pi R minus ~1e-4 m).
    """
    a = np.linspace(0.0, 2.0 * math.pi, vertices, endpoint=False)
    if not ccw:
        a = -a
    centre = np.stack([radius * np.cos(a), radius * np.sin(a)], axis=1)
    return Track(centre, half_width, half_width, name=f"circle_r{radius:g}")


def stadium_track(radius: float, straight: float, half_width: float,
                  name: str = "stadium") -> Track:
    """Two straights of ``straight`` metres joined by left-hand semicircles of ``radius``
    (CCW), ``half_width`` to each side, vertices 5 cm apart on the straights and 1 cm on the
    bends; the first straight runs along y = -radius from x = 0."""
    xs = np.arange(0.0, straight, 0.05)
    arc = np.arange(0.0, math.pi, 0.01 / radius)
    centre = np.concatenate([
        np.stack([xs, np.full_like(xs, -radius)], axis=1),
        np.stack([straight + radius * np.sin(arc), -radius * np.cos(arc)], axis=1),
        np.stack([straight - xs, np.full_like(xs, radius)], axis=1),
        np.stack([-radius * np.sin(arc), radius * np.cos(arc)], axis=1)])
    return Track(centre, half_width, half_width, name=name)


def box_corners(position: np.ndarray, yaw: np.ndarray, length: float, width: float) -> np.ndarray:
    """Corners (..., 4, 2) of oriented boxes centred at ``position`` (..., 2) with heading ``yaw``."""
    hl, hw = 0.5 * length, 0.5 * width
    local = np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]])
    c, s = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
    x = position[..., None, 0] + c * local[:, 0] - s * local[:, 1]
    y = position[..., None, 1] + s * local[:, 0] + c * local[:, 1]
    return np.stack([x, y], axis=-1)


def box_penetration(corners_a: np.ndarray, corners_b: np.ndarray) -> np.ndarray:
    """Penetration depth [m] of pairs of convex quads (..., 4, 2) by the separating-axis test.

    Returns the smallest overlap of the projections over the 4 edge normals (2 per box), or 0
    when some axis separates the boxes. Vectorised over the leading axes.
    """
    depth = np.full(corners_a.shape[:-2], np.inf)
    for quad in (corners_a, corners_b):
        for k in (0, 1):
            edge = quad[..., k + 1, :] - quad[..., k, :]
            axis = np.stack([-edge[..., 1], edge[..., 0]], axis=-1)
            axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
            pa = np.einsum("...ij,...j->...i", corners_a, axis)
            pb = np.einsum("...ij,...j->...i", corners_b, axis)
            overlap = np.minimum(pa.max(-1), pb.max(-1)) - np.maximum(pa.min(-1), pb.min(-1))
            depth = np.minimum(depth, overlap)
    return np.maximum(depth, 0.0)


def ellipse_route_rows(rows: int = 71, a: float = 3.0, b: float = 1.8,
                       half_width: float = 0.38) -> np.ndarray:
    """DeepRacer route rows (rows, 6) of a CCW ellipse, closing row repeated (a narrow,
    re:Invent 2018-sized loop: 71 rows, 0.76 m wide, smallest radius b^2 / a = 1.08 m)."""
    t = np.linspace(0.0, 2.0 * math.pi, rows - 1, endpoint=False)
    centre = np.stack([a * np.cos(t), b * np.sin(t)], axis=1)
    tangent = np.stack([-a * np.sin(t), b * np.cos(t)], axis=1)
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    out = np.concatenate([centre, centre + half_width * normal, centre - half_width * normal], 1)
    return np.vstack([out, out[:1]])


def with_route_slips(rows: np.ndarray, back_row: int, duplicate_row: int) -> np.ndarray:
    """Copy of route ``rows`` with the drawing slips of the 2019-era re:Invent 2018 file: row
    ``back_row`` moved to 2 mm behind row ``back_row - 1`` (a step backwards along the route),
    and row ``duplicate_row`` a near-duplicate of its predecessor (0.3 mm away)."""
    out = rows.copy()
    step = rows[back_row, :2] - rows[back_row - 1, :2]
    out[back_row] = rows[back_row - 1] - np.tile(0.002 * step / np.linalg.norm(step), 3)
    out[duplicate_row] = rows[duplicate_row - 1] + np.tile([0.0003, 0.0], 3)
    return out


def reinvent_2018_71_rows(source: Path) -> np.ndarray:
    """The 2019-era re:Invent 2018 route rebuilt for tests from today's 119-row file
    ``source`` (shared/data, never copied into the project): resampled to 71 rows (70 evenly
    spaced along the centre line + the closing row), with the old file's slips added."""
    raw = np.load(source)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(raw[:, :2], axis=0).T))])
    at = np.linspace(0.0, arc[-1], 71)
    rows = np.stack([np.interp(at, arc, raw[:, k]) for k in range(6)], axis=1)
    rows[-1] = rows[0]
    return with_route_slips(rows, back_row=24, duplicate_row=51)


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator (tests never use unseeded randomness)."""
    return np.random.default_rng(12345)


@pytest.fixture
def tiny_track() -> Track:
    """A 3 m radius circle, 1 m wide (L = 18.849 m)."""
    return circle_track()


@pytest.fixture
def make_env() -> Callable[..., Any]:
    """Factory: ``make_env(**overrides)`` builds a ParallelEnv on the oval with 2 cars."""
    def factory(**overrides: Any) -> Any:
        kwargs: dict[str, Any] = {"track": "oval", "num_cars": 2}
        kwargs.update(overrides)
        return h2h_racing.parallel_env(**kwargs)
    return factory


def pytest_collectstart(collector: pytest.Collector) -> None:
    """Piped or logged, pytest says nothing while it collects (10-45 s on 2 cores: every test
    module is imported, torch and numba among them; on a terminal it counts the tests as it
    goes). So off a terminal, a line for each top-level folder of tests it starts on; ``-qq``
    keeps quiet."""
    config = collector.config
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    terminal = reporter is not None and (reporter.isatty() if callable(reporter.isatty)
                                         else reporter.isatty)
    if reporter is None or terminal or config.get_verbosity() < -1:
        return
    path = getattr(collector, "path", None)
    tests = Path(__file__).resolve().parent
    if isinstance(collector, pytest.Directory) and path is not None and path.parent == tests:
        reporter.write_line(f"collecting {path.relative_to(tests.parent)}/ ...", flush=True)
