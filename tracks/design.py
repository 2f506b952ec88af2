"""Regenerate the h2h-racing track catalogue: ``tracks/<name>.json`` and ``tracks/<name>.png``.

Run from anywhere with ``python tracks/design.py``; it writes next to this file. Every track is drawn from
hand-chosen control points (original shapes) through :func:`h2h_racing.track.generator.smooth_closed_curve`,
scaled to a chosen lap length, checked (no self-intersection of the centre line or the borders, minimum
radius of curvature >= 1.2 x the local half-width, DeepRacer-scale width and length, counter-clockwise),
and only then written. The script exits non-zero, writing nothing, if any track fails its checks.

Control points are listed in driving order (counter-clockwise), starting on the start line; the first
point is not repeated at the end.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from h2h_racing.track.generator import (
    RADIUS_TO_HALF_WIDTH,
    TrackMetrics,
    TrackSpec,
    border_polylines,
    closed_length,
    left_normals,
    measure_track,
    smooth_closed_curve,
)

FloatArray = npt.NDArray[np.float64]

TRACKS_DIR = Path(__file__).resolve().parent
SPACING = 0.05
"""Distance between centre-line vertices [m]."""
DECIMALS = 4
"""Coordinates and widths are rounded to 1e-4 m in the JSON files."""
WIDTH_RANGE = (0.76, 1.07)
"""Allowed total width [m] (DeepRacer: 0.762 m on re:Invent 2018, 1.067 m on most 2020+ tracks)."""
LENGTH_RANGE = (15.0, 60.0)
"""Allowed lap length [m]."""
MIN_WALL_GAP = 0.3
"""Smallest gap between the borders of two different parts of a track [m] (room for the walls)."""
PREVIEW_WIDTH = 480
"""Width of the preview PNGs [px]."""


@dataclass(frozen=True)
class Design:
    """One catalogue entry: control points, the lap length to scale them to, and the width profile."""

    name: str
    description: str
    control_points: list[tuple[float, float]]
    """Control points in driving order, arbitrary units (rescaled to ``length``)."""
    length: float
    """Lap length to scale the curve to [m]."""
    width: float | Callable[[FloatArray], FloatArray]
    """Total width [m], or a function of the lap fraction ``u = s / L`` in [0, 1) giving the total width."""


def _varying_width(u: FloatArray) -> FloatArray:
    """Total width that breathes twice per lap between 0.76 m and 1.07 m.

    ``w(u) = 0.915 + 0.155 cos(4 pi u)``: 1.07 m at the start and half-way (wide braking zones for
    overtaking), 0.76 m a quarter and three quarters of the way round (single-file sections).
    """
    return 0.915 + 0.155 * np.cos(4.0 * np.pi * u)


DESIGNS: list[Design] = [
    Design(
        name="oval",
        description="Simple oval: two straights joined by two wide, smooth bends; the first track to train on.",
        control_points=[
            (0.0, 0.0), (2.2, 0.0), (3.6, 0.25), (4.55, 1.0), (4.9, 2.0), (4.55, 3.0), (3.6, 3.75),
            (2.2, 4.0), (0.0, 4.0), (-2.2, 4.0), (-3.6, 3.75), (-4.55, 3.0), (-4.9, 2.0), (-4.55, 1.0),
            (-3.6, 0.25), (-2.2, 0.0),
        ],
        length=20.0,
        width=1.07,
    ),
    Design(
        name="speedway",
        description=(
            "Fast, wide circuit for head-to-head racing: two long straights, sweeping bends and a kink on "
            "the back straight, with room to go side by side."
        ),
        control_points=[
            (0.0, 0.0), (3.5, 0.0), (5.6, 0.3), (6.8, 1.4), (7.1, 2.8), (6.6, 4.2), (5.4, 5.0), (3.5, 5.2),
            (1.5, 4.7), (-0.5, 4.3), (-2.5, 4.6), (-4.5, 5.0), (-6.0, 4.5), (-6.9, 3.2), (-6.8, 1.6),
            (-5.8, 0.4), (-3.8, 0.0),
        ],
        length=33.0,
        width=1.07,
    ),
    Design(
        name="technical",
        description=(
            "Short, narrow technical circuit: a chicane on the start straight, two hairpins and an esse; "
            "rewards precise braking and turn-in over top speed."
        ),
        control_points=[
            (0.0, 0.0), (1.0, 0.0), (1.8, 0.0), (3.0, -0.4), (4.2, 0.0), (4.9, 0.0), (5.6, 0.3),
            (5.85, 0.95), (5.5, 1.55), (4.8, 1.7), (4.0, 1.62), (3.3, 1.65), (2.73, 1.88), (2.5, 2.45),
            (2.73, 3.02), (3.3, 3.25), (4.05, 3.35), (4.55, 3.9), (4.35, 4.6), (3.5, 4.85), (2.4, 4.6),
            (1.45, 3.95), (0.75, 3.6), (0.0, 3.75), (-0.65, 3.7), (-1.2, 3.25), (-1.3, 2.4), (-1.25, 1.4),
            (-1.0, 0.5), (-0.6, 0.08),
        ],
        length=20.0,
        width=0.76,
    ),
    Design(
        name="kidney",
        description=(
            "Medium kidney-shaped circuit with mixed corners: a fast sweeper, a tight inward bend and a "
            "long left-hander onto the start straight."
        ),
        control_points=[
            (0.0, 0.0), (2.5, -0.3), (4.5, 0.3), (5.8, 1.8), (5.7, 3.6), (4.5, 4.6), (3.0, 4.3),
            (2.0, 3.4), (0.8, 3.5), (-0.8, 4.4), (-2.4, 4.2), (-3.3, 2.8), (-3.0, 1.0), (-1.8, 0.2),
        ],
        length=25.0,
        width=1.07,
    ),
    Design(
        name="grand_loop",
        description=(
            "Long endurance circuit: a long main straight, fast sweepers, esses and a tight complex on the "
            "far side; tests consistency over a long lap."
        ),
        control_points=[
            (0.0, 0.0), (4.0, 0.0), (8.0, 0.0), (10.5, 0.4), (12.0, 1.5), (12.4, 3.2), (11.5, 4.5),
            (10.0, 4.8), (8.8, 5.6), (8.6, 7.0), (9.5, 8.3), (9.2, 9.6), (7.8, 10.0), (6.0, 9.6),
            (4.5, 8.6), (3.0, 8.8), (1.5, 9.8), (-0.3, 9.9), (-1.5, 8.8), (-1.4, 7.2), (-2.4, 6.0),
            (-3.8, 5.5), (-4.6, 4.2), (-4.4, 2.4), (-3.6, 1.0), (-2.0, 0.1),
        ],
        length=55.0,
        width=1.0,
    ),
    Design(
        name="varying",
        description=(
            "Circuit whose width breathes between 1.07 m and 0.76 m twice per lap: wide braking zones "
            "for passing, narrow single-file sections."
        ),
        control_points=[
            (0.0, 0.0), (3.0, 0.0), (5.5, 0.2), (6.8, 1.0), (6.9, 2.2), (5.8, 3.0), (4.2, 3.8),
            (2.8, 5.0), (1.6, 5.6), (0.4, 5.3), (-0.2, 4.2), (-0.9, 3.2), (-1.8, 2.4), (-1.9, 1.0),
            (-1.0, 0.1),
        ],
        length=24.0,
        width=_varying_width,
    ),
    Design(
        name="hairpin_valley",
        description=(
            "Medium-long circuit with a chicane on the main straight and a deep hairpin valley cut into "
            "the infield: hard braking, slow apex, drag race back out."
        ),
        control_points=[
            (0.0, 0.0), (0.8, 0.0), (2.2, 0.45), (3.6, 0.0), (5.0, 0.0), (8.0, 0.0), (9.8, 0.6),
            (10.5, 2.0), (10.0, 3.5), (8.8, 4.3), (7.5, 4.2), (6.3, 3.6), (5.7, 2.6), (5.45, 1.85),
            (4.8, 1.55), (4.2, 1.9), (4.05, 2.8), (4.4, 3.9), (4.3, 5.0), (3.3, 5.5), (1.8, 5.3),
            (0.4, 5.5), (-1.0, 5.0), (-1.8, 3.8), (-1.9, 2.2), (-1.4, 0.8), (-0.6, 0.1),
        ],
        length=40.0,
        width=1.0,
    ),
]


def build(design: Design) -> TrackSpec:
    """Build the track of a design: interpolate, scale to its lap length, sample widths, round."""
    points = np.asarray(design.control_points, dtype=np.float64)
    # The chord-length spline is scale-covariant, so scaling the control points scales the lap exactly.
    unit_length = closed_length(smooth_closed_curve(points, spacing=closed_length(points) / 2000))
    centre = smooth_closed_curve(points * (design.length / unit_length), spacing=SPACING)
    fraction = np.arange(len(centre)) / len(centre)
    if callable(design.width):
        total = np.asarray(design.width(fraction), dtype=np.float64)
    else:
        total = np.full(len(centre), float(design.width))
    half = np.round(0.5 * total, DECIMALS)
    return TrackSpec(
        name=design.name,
        description=design.description,
        centre=np.round(centre, DECIMALS),
        width_left=half,
        width_right=half.copy(),
    )


def check(spec: TrackSpec) -> tuple[TrackMetrics, list[str]]:
    """Measure a built track and list every catalogue rule it breaks (empty list: OK)."""
    metrics = measure_track(spec.centre, spec.width_left, spec.width_right)
    problems = []
    if metrics.centre_crossings:
        problems.append(f"centre line self-intersects ({metrics.centre_crossings} segment pairs)")
    if metrics.border_crossings:
        problems.append(f"borders intersect ({metrics.border_crossings} segment pairs)")
    if metrics.min_radius_ratio < RADIUS_TO_HALF_WIDTH:
        problems.append(
            f"min radius / half-width = {metrics.min_radius_ratio:.2f} < {RADIUS_TO_HALF_WIDTH} "
            f"(min radius {metrics.min_radius:.2f} m)"
        )
    if metrics.clearance < metrics.max_width + MIN_WALL_GAP:
        problems.append(
            f"two parts of the track come {metrics.clearance:.2f} m apart (centre to centre), "
            f"less than width + {MIN_WALL_GAP} m"
        )
    if not (WIDTH_RANGE[0] - 1e-9 <= metrics.min_width and metrics.max_width <= WIDTH_RANGE[1] + 1e-9):
        problems.append(f"width {metrics.min_width:.3f}-{metrics.max_width:.3f} m outside {WIDTH_RANGE}")
    if not LENGTH_RANGE[0] <= metrics.length <= LENGTH_RANGE[1]:
        problems.append(f"lap length {metrics.length:.2f} m outside {LENGTH_RANGE}")
    if not metrics.counter_clockwise:
        problems.append("driving order is clockwise, expected counter-clockwise")
    return metrics, problems


# ----------------------------------------------------------------------------------------------------------
# Preview images
# ----------------------------------------------------------------------------------------------------------

_FLOOR = (34, 30, 28)  # BGR
_SURFACE = (105, 105, 105)
_BORDER = (255, 255, 255)
_CENTRE = (0, 215, 255)  # yellow
_ARROW = (80, 200, 60)  # green
_SHIFT = 4  # cv2 fixed-point bits: coordinates carry 1/16 px precision


def render_preview(spec: TrackSpec, width_px: int = PREVIEW_WIDTH) -> npt.NDArray[np.uint8]:
    """Draw a top-down preview of a track (BGR image, ``width_px`` wide, y axis pointing up).

    Args:
        spec: The track to draw.
        width_px: Image width [px].

    Returns:
        Image, shape (H, width_px, 3) uint8, BGR.
    """
    left, right = border_polylines(spec.centre, spec.width_left, spec.width_right)
    every = np.concatenate([left, right])
    margin_px = 16
    lo, hi = every.min(axis=0), every.max(axis=0)
    scale = (width_px - 2 * margin_px) / (hi[0] - lo[0])
    height_px = int(np.ceil((hi[1] - lo[1]) * scale)) + 2 * margin_px + 22

    def to_px(points: FloatArray) -> npt.NDArray[np.int32]:
        # World (x right, y up) -> image (column right, row down), in 1/16 px fixed point.
        col = (points[:, 0] - lo[0]) * scale + margin_px
        row = (hi[1] - points[:, 1]) * scale + margin_px + 22
        return np.round(np.stack([col, row], axis=1) * (1 << _SHIFT)).astype(np.int32)

    image = np.full((height_px, width_px, 3), _FLOOR, dtype=np.uint8)
    lp, rp = to_px(left), to_px(right)
    nxt = np.roll(np.arange(len(lp)), -1)
    quads = np.stack([lp, lp[nxt], rp[nxt], rp], axis=1)
    cv2.fillPoly(image, list(quads), _SURFACE, lineType=cv2.LINE_AA, shift=_SHIFT)

    # Dashed centre line: 0.25 m dashes, 0.25 m gaps, by arc length.
    centre_px = to_px(spec.centre)
    seg = np.linalg.norm(np.roll(spec.centre, -1, axis=0) - spec.centre, axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
    for i in np.flatnonzero((s // 0.25) % 2 == 0):
        cv2.line(image, tuple(centre_px[i]), tuple(centre_px[nxt[i]]), _CENTRE, 1, cv2.LINE_AA, _SHIFT)

    for border in (lp, rp):
        cv2.polylines(image, [border], True, _BORDER, 2, cv2.LINE_AA, _SHIFT)

    # Chequered start line across the track at vertex 0: 8 cells across, 2 rows deep along the track.
    tangent = np.array([left_normals(spec.centre)[0, 1], -left_normals(spec.centre)[0, 0]])
    cells = 8
    depth = (left[0] - right[0]) / cells
    for k in range(cells):
        for row in range(2):
            corner = right[0] + k * depth + (row - 1) * np.linalg.norm(depth) * tangent
            quad = np.array([corner, corner + depth, corner + depth + np.linalg.norm(depth) * tangent,
                             corner + np.linalg.norm(depth) * tangent])
            colour = (255, 255, 255) if (k + row) % 2 == 0 else (0, 0, 0)
            cv2.fillPoly(image, [to_px(quad)], colour, cv2.LINE_AA, _SHIFT)

    # Direction arrow along the centre line, from 0.4 m to 1.4 m after the start line.
    i0 = int(np.searchsorted(s, 0.4))
    i1 = int(np.searchsorted(s, 1.4))
    cv2.arrowedLine(image, tuple(centre_px[i0]), tuple(centre_px[i1]), _ARROW, 3, cv2.LINE_AA, _SHIFT, 0.3)

    label = f"{spec.name}  {spec.length:.1f} m"
    cv2.putText(image, label, (margin_px, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (230, 230, 230), 1, cv2.LINE_AA)
    return image


# ----------------------------------------------------------------------------------------------------------
# Output
# ----------------------------------------------------------------------------------------------------------


def to_json(spec: TrackSpec) -> str:
    """Serialise a track as ``h2h-racing-track/1`` JSON, one key per line."""
    document = spec.to_dict(decimals=DECIMALS)
    lines = [f"  {json.dumps(key)}: {json.dumps(value)}" for key, value in document.items()]
    return "{\n" + ",\n".join(lines) + "\n}\n"


def main(argv: list[str] | None = None) -> int:
    """Build, check and write every track of the catalogue; return the process exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=TRACKS_DIR, help="output folder (default: tracks/)")
    parser.add_argument("--check-only", action="store_true", help="build and check, write nothing")
    args = parser.parse_args(argv)

    built = []
    failed = False
    header = f"{'name':<15} {'length m':>8} {'width m':>11} {'min R m':>7} {'R/half-w':>8}  status"
    print(header)
    print("-" * len(header))
    for design in DESIGNS:
        spec = build(design)
        metrics, problems = check(spec)
        width = (
            f"{metrics.min_width:.2f}"
            if metrics.max_width - metrics.min_width < 1e-6
            else f"{metrics.min_width:.2f}-{metrics.max_width:.2f}"
        )
        status = "ok" if not problems else "FAIL: " + "; ".join(problems)
        print(
            f"{spec.name:<15} {metrics.length:>8.2f} {width:>11} {metrics.min_radius:>7.2f} "
            f"{metrics.min_radius_ratio:>8.2f}  {status}"
        )
        failed |= bool(problems)
        built.append(spec)
    if failed:
        print("some tracks failed their checks; nothing written", file=sys.stderr)
        return 1
    if args.check_only:
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    for spec in built:
        (args.out / f"{spec.name}.json").write_text(to_json(spec), encoding="utf-8")
        cv2.imwrite(str(args.out / f"{spec.name}.png"), render_preview(spec))
    print(f"wrote {len(built)} tracks to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
