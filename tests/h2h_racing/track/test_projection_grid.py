"""Tests for :func:`h2h_racing.track.projection.grid_kernel`: the compiled build of the
projection grid gives, to the bit, the grid of the exhaustive numpy build it replaced (every
segment measured from every cell centre), on every shipped track and on real routes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from h2h_racing.track import projection as P
from h2h_racing.track.io import catalogue, load_track
from h2h_racing.track.shape import Track

ROUTES = Path(__file__).resolve().parents[3] / ".." / "shared" / "data" / "deepracer_tracks"
"""The DeepRacer routes beside the project (not part of it: the test skips without them)."""
REAL_ROUTES = ("Bowtie_track", "jyllandsringen_pro", "penbay_open", "Tokyo_Training_track",
               "reInvent2019_wide")
"""A few of them: a figure eight, the smallest window (3 segments), the most cells, a
hairpin, a short wide oval."""


def exhaustive_grid(track: Track) -> tuple[np.ndarray, np.ndarray]:
    """``Projector.build``'s ``start`` and ``cert`` as the numpy build before the compiled one
    computed them (copied from it): every cell centre measured against every segment."""
    g = track._geo
    c = track.centre
    m = len(c)
    seg = np.roll(c, -1, axis=0) - c
    seg_len = g["seg_len"]
    inv_l2 = np.divide(1.0, seg_len**2, out=np.zeros(m), where=seg_len > 0)
    zc = c[:, 0] + 1j * c[:, 1]
    dz = seg[:, 0] + 1j * seg[:, 1]
    xmin, ymin, xmax, ymax = track.bounds
    area = (xmax - xmin + 2 * P.GRID_MARGIN) * (ymax - ymin + 2 * P.GRID_MARGIN)
    cell = max(P.GRID_CELL, math.sqrt(area / P.GRID_MAX_CELLS))
    nx = int(math.ceil((xmax - xmin + 2 * P.GRID_MARGIN) / cell))
    ny = int(math.ceil((ymax - ymin + 2 * P.GRID_MARGIN) / cell))
    origin = np.array([xmin - P.GRID_MARGIN, ymin - P.GRID_MARGIN])
    arc = max(P.WINDOW_ARC, 4.0 * cell)
    cum = np.concatenate([[0.0], np.cumsum(np.tile(seg_len, 3))])
    i_mid = np.arange(m, 2 * m)
    ahead = np.searchsorted(cum, cum[i_mid + 1] + arc, side="left") - (i_mid + 1)
    behind = i_mid - np.searchsorted(cum, cum[i_mid] - arc, side="right") + 1
    k = int(min(max(ahead.max(), behind.max(), 1), m // 2))
    gx = origin[0] + (np.arange(nx) + 0.5) * cell
    gy = origin[1] + (np.arange(ny) + 0.5) * cell
    centres = (gx[:, None] + 1j * gy[None, :]).ravel()
    nearest = np.empty(len(centres), dtype=np.intp)
    outside = np.empty(len(centres))
    step = max(1, (1 << 17) // m)
    seg_ids = np.arange(m)
    factor = np.conj(dz) * inv_l2
    for a in range(0, len(centres), step):
        w = centres[a:a + step, None] - zc[None, :]
        t = np.clip((w * factor[None, :]).real, 0.0, 1.0)
        dist = np.abs(w - t * dz[None, :])
        near = dist.argmin(axis=1)
        nearest[a:a + step] = near
        offset = (seg_ids[None, :] - near[:, None]) % m
        dist[(offset <= k) | (offset >= m - k)] = np.inf
        outside[a:a + step] = dist.min(axis=1)
    cert = outside - (cell * math.sqrt(0.5) + 1e-9)
    edge = np.zeros((nx, ny), dtype=bool)
    edge[[0, -1], :] = True
    edge[:, [0, -1]] = True
    cert[edge.ravel()] = -1.0
    return nearest, cert


def assert_same_grid(track: Track) -> None:
    built = P.Projector.build(track)
    nearest, cert = exhaustive_grid(track)
    np.testing.assert_array_equal(built.start, nearest)
    # Bit for bit, infinities included (array_equal also fails on a NaN).
    assert built.cert.tobytes() == cert.tobytes()


@pytest.mark.parametrize("name", catalogue())
def test_grid_is_the_exhaustive_one_on_shipped_tracks(name: str) -> None:
    track = load_track(name)
    assert_same_grid(track)
    assert_same_grid(track.reversed())


@pytest.mark.parametrize("route", REAL_ROUTES)
def test_grid_is_the_exhaustive_one_on_real_routes(route: str) -> None:
    path = ROUTES / f"{route}.npy"
    if not path.is_file():
        pytest.skip(f"{path} not beside the project (README's Tests section)")
    track = load_track(str(path))
    assert_same_grid(track)
    assert_same_grid(track.reversed())


def test_window_of_every_segment_leaves_nothing_outside() -> None:
    """With 2k + 1 >= m segments every one is in the window: no cell has an outside segment
    (inf), and each cell's nearest is still the exhaustive one (a square of 4 segments)."""
    corners = np.array([0.0, 2.0, 2.0 + 2.0j, 2.0j])
    dz = np.roll(corners, -1) - corners
    full = np.stack([corners, dz, np.conj(dz) / np.abs(dz) ** 2, np.conj(dz) / 2.0,
                     np.zeros(4)], axis=1)
    gx = np.linspace(-1.05, 3.05, 21)
    gy = np.linspace(-0.95, 2.95, 20)
    nearest = np.empty(gx.size * gy.size, dtype=np.intp)
    outside = np.empty(gx.size * gy.size)
    P.grid_kernel(gx, gy, full, 2, *P.numpy_fuses(), nearest, outside)
    assert np.isinf(outside).all()
    z = (gx[:, None] + 1j * gy[None, :]).ravel()[:, None]
    w = z - corners[None, :]
    t = np.clip((w * full[None, :, 2]).real, 0.0, 1.0)
    np.testing.assert_array_equal(nearest, np.abs(w - t * dz[None, :]).argmin(axis=1))


def test_numpy_rounding_is_detected() -> None:
    """``numpy_fuses`` says how numpy rounds here: the kernel's two modes are the two
    roundings of the same arithmetic (checked against numpy itself by the tests above)."""
    product, size = P.numpy_fuses()
    a = np.array([complex(1.0 + 2.0**-30, 1.0)])
    assert ((a * a)[0].real == 2.0**-29 + 2.0**-60) == product
    assert isinstance(size, bool)
