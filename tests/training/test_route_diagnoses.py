"""The measurements behind issue 36's diagnoses of `Bowtie_track` and `Tokyo_Training_track`
(`experiments/routes/retrain/obstacle_fine/bowtie/`, `experiments/routes/retrain/ppo_step6/
tokyo/`), on small hand-made tracks and poses with hand-worked values: the room beside a box
(`box_room.py`), how sharply a track narrows into a tight corner (`funnels.py`) and DeepRacer's
one-sided box crash test (`deepracer_crash_test.py`)."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
BOWTIE = ROOT / "experiments/routes/retrain/obstacle_fine/bowtie"
TOKYO = ROOT / "experiments/routes/retrain/ppo_step6/tokyo"


def load(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def circle(radius: float, width: float, vertices: int = 720):
    """An anticlockwise circle of constant width (its left is the inside)."""
    from h2h_racing.track.shape import Track

    a = np.linspace(0.0, 2 * np.pi, vertices, endpoint=False)
    centre = radius * np.stack([np.cos(a), np.sin(a)], axis=1)
    half = np.full(vertices, 0.5 * width)
    return Track(centre, half, half, name="circle")


def test_room_beside_a_box_on_a_circle():
    from h2h_racing.config.env import EnvConfig

    box_room = load(BOWTIE / "box_room.py", "box_room")
    cfg = EnvConfig(track="oval", num_cars=1, race_type="object_avoidance",
                    randomize_obstacles=True)
    radius, width = 1.5, 0.62
    room, widths, k = box_room.box_room(circle(radius, width), 50, np.random.default_rng(3),
                                        cfg)
    np.testing.assert_allclose(widths, width, atol=1e-9)
    np.testing.assert_allclose(k, 1 / radius, rtol=1e-3)
    # Lane centre 0.155 m from the centre line; the box is 0.4 m across and 0.5 m long.
    # Outside lane (right): the inside half-width 0.31 + 0.155 - 0.2 = 0.265 m beside it.
    # Inside lane (left): the same less its ends' bulge towards the outside: the outer side
    # at r = 1.5 - 0.155 + 0.2 = 1.545 m, its ends at sqrt(1.545^2 + 0.25^2) = 1.5651 m.
    outside, inside = 0.265, 0.265 - (math.hypot(1.545, 0.25) - 1.545)
    assert inside == pytest.approx(0.24490, abs=1e-4)
    values = np.unique(np.round(room, 4))
    np.testing.assert_allclose(values, [inside, outside], atol=2e-4)
    # 0.2449 < TIGHT_ROOM (0.24)? No: both sides of this circle leave room.
    assert not (room < box_room.TIGHT_ROOM).any()


def stadium(straight: float, radius: float, wide: float, narrow: float, taper: float):
    """A stadium driven anticlockwise: two straights of ``straight`` m and two half circles of
    ``radius``; ``wide`` m wide on the straights, narrowing linearly over the last ``taper`` m
    before each bend to ``narrow``, which it keeps round the bend and widens back after it.
    Only the outside (right) half-width changes: the inside one stays ``narrow / 2``, so the
    two straights' inner borders keep clear of each other."""
    from h2h_racing.track.shape import Track

    step = 0.01
    pts, widths = [], []
    arc = np.pi * radius
    for side in (0, 1):
        sign = 1 if side == 0 else -1
        for u in np.linspace(0.0, straight, round(straight / step), endpoint=False):
            x = sign * (u - straight / 2)
            y = -radius if side == 0 else radius
            pts.append((x, y))
            to_bend = straight - u
            from_bend = u
            w = wide
            if to_bend < taper:
                w = narrow + (wide - narrow) * to_bend / taper
            if from_bend < taper:
                w = min(w, narrow + (wide - narrow) * from_bend / taper)
            widths.append(w)
        for v in np.linspace(0.0, arc, round(arc / step), endpoint=False):
            t = v / radius - np.pi / 2 + side * np.pi
            cx = straight / 2 if side == 0 else -straight / 2
            pts.append((cx + radius * np.cos(t), radius * np.sin(t)))
            widths.append(narrow)
    inside = np.full(len(widths), 0.5 * narrow)
    return Track(np.array(pts), inside, np.array(widths) - inside, name="stadium")


def test_funnel_of_a_track_narrowing_into_tight_bends():
    funnels = load(TOKYO / "funnels.py", "funnels")
    # Bends of 0.5 m radius (2 /m, tighter than TIGHT_K), 0.6 m wide, entered from 1.2 m
    # straights narrowing over their last metre: the width 2 m before a bend (within AHEAD)
    # is 1.2 m, the bend's 0.6 m: x2.0.
    ratio, entry, _ = funnels.funnel(stadium(5.0, 0.5, 1.2, 0.6, 1.0))
    assert ratio == pytest.approx(2.0, rel=0.02)
    assert entry == pytest.approx(1.2, abs=0.01)
    # Constant width: x1.
    ratio, _, _ = funnels.funnel(stadium(5.0, 0.5, 0.6, 0.6, 1.0))
    assert ratio == pytest.approx(1.0, abs=1e-6)
    # Bends of 1 m radius (1 /m) are not tight: no funnel, however the width changes.
    ratio, _, _ = funnels.funnel(stadium(5.0, 1.0, 1.2, 0.6, 1.0))
    assert ratio == pytest.approx(1.0, abs=1e-6)


def pose_core(car_xy, car_yaw, box_xy, box_yaw):
    """The fields of a one-car, one-box core that ``car_corner_in_box`` reads."""
    car = SimpleNamespace(length=0.3235, width=0.1961)
    config = SimpleNamespace(car=car, obstacle_length=0.5, obstacle_width=0.4)
    return SimpleNamespace(config=config, position=np.array([[car_xy]], dtype=float),
                           yaw=np.array([[car_yaw]], dtype=float),
                           obstacle_position=np.array([[box_xy]], dtype=float),
                           obstacle_yaw=np.array([[box_yaw]], dtype=float))


def test_deepracer_crash_test_is_one_sided():
    crash = load(BOWTIE / "deepracer_crash_test.py", "deepracer_crash_test")
    # A box at the origin along x (x in +-0.25, y in +-0.2). A car along x with its centre
    # 0.29 m to the side: its near side at y = 0.29 - 0.098 = 0.192 < 0.2, its corners at
    # x = +-0.162 inside the box's length: a corner in the box, a crash for DeepRacer.
    assert crash.car_corner_in_box(pose_core((0.0, 0.29), 0.0, (0.0, 0.0), 0.0))[0, 0, 0]
    # 0.31 m to the side: its near side at 0.212, clear.
    assert not crash.car_corner_in_box(pose_core((0.0, 0.31), 0.0, (0.0, 0.0), 0.0))[0, 0, 0]
    # The car at -45 degrees with the middle of its right side 4 mm past the box's corner
    # (0.25, 0.2): the box's corner is inside the car (its frame: x 0, y -0.094 within
    # +-0.098), which the env's contact test counts. The car's centre is the corner plus
    # 0.094 m along its left normal (0.7071, 0.7071): (0.3165, 0.2665); its right-hand
    # corners, +-0.16175 along (0.7071, -0.7071) and 0.09805 along the right normal, are at
    # (0.3616, 0.0828) (x > 0.25) and (0.1328, 0.3116) (y > 0.2): outside the box. No corner
    # of the car in the box: no crash for DeepRacer.
    r = 0.094 / math.sqrt(2)
    centre = (0.25 + r, 0.2 + r)
    assert centre == pytest.approx((0.3165, 0.2665), abs=1e-4)
    assert not crash.car_corner_in_box(pose_core(centre, -math.pi / 4, (0.0, 0.0),
                                                 0.0))[0, 0, 0]
    # 12 cm further in (centre (0.2316, 0.1816)), its right-hand corners at (0.2767, -0.0021)
    # (x > 0.25) and (0.0479, 0.2267) (y > 0.2) are still outside: the test looks at the
    # car's corners only, so even this deep overlap is no crash, as in DeepRacer.
    deep = (0.25 + r - 0.12 / math.sqrt(2), 0.2 + r - 0.12 / math.sqrt(2))
    assert not crash.car_corner_in_box(pose_core(deep, -math.pi / 4, (0.0, 0.0),
                                                 0.0))[0, 0, 0]
    c, s = math.cos(math.pi / 6), math.sin(math.pi / 6)
    # The same box turned with the car (both at 30 degrees) and the car 0.29 m to its side in
    # that frame: a corner in the box again (the test works in the box's own frame).
    turned = (-0.29 * s, 0.29 * c)
    assert crash.car_corner_in_box(pose_core(turned, math.pi / 6, (0.0, 0.0),
                                             math.pi / 6))[0, 0, 0]
