"""How sharply a track narrows into a tight corner ("funnels"), on route files and on the
training tracks of a config's generator.

    python experiments/routes/retrain/ppo_step6/tokyo/funnels.py \
        [--config ppo_generalist/routes] [--tracks 300] [ROUTE.npy ...]

For every point s of the lap (5 cm apart) where a corner tighter than ``TIGHT_K`` (radius
under 0.67 m) lies within ``AHEAD`` metres, the funnel ratio is the track's width at s over
its narrowest width from s to that corner's end; a track's funnel is its largest ratio, and
``wide_entry`` the width at s there. ``ppo_generalist`` observes the half-widths only where the
car is (``h2h_racing.sensors.state``, features 15-16) and the centre line's curvature up to
5 m ahead, so a track that is wide where the car brakes and narrow in the corner is one it
cannot see coming. Prints each route's funnel and, for the training tracks, the share with a
funnel over 1.5 and over 1.8, and the largest.
"""

from __future__ import annotations

import argparse

import numpy as np

from h2h_racing.track.io import load_track
from h2h_racing.track.shape import Track

TIGHT_K = 1.5
"""Curvature of a tight corner [1/m]."""
AHEAD = 2.0
"""How far ahead of the braking point the tight corner may start [m]."""
STEP = 0.05


def funnel(track: Track) -> tuple[float, float, float]:
    """``(largest ratio, width at its entry, its arc position)``."""
    s = np.arange(0.0, track.length, STEP)
    left, right = track.half_widths_at(s)
    width = left + right
    tight = np.abs(track.curvature_at(s)) >= TIGHT_K
    n = len(s)
    reach = int(AHEAD / STEP)
    best = (1.0, float(width[0]), 0.0)
    for i in range(n):
        idx = (i + np.arange(reach + 1)) % n
        hit = np.nonzero(tight[idx])[0]
        if not len(hit):
            continue
        # To the end of that tight stretch (at most 1 m further).
        first = hit[0]
        end = first
        while end < len(idx) - 1 and tight[idx[end + 1]] and end - first < int(1.0 / STEP):
            end += 1
        ratio = width[i] / width[idx[: end + 1]].min()
        if ratio > best[0]:
            best = (float(ratio), float(width[i]), float(s[i]))
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("routes", nargs="*", help="route files (.npy)")
    parser.add_argument("--config", default="ppo_generalist/routes",
                        help="training config whose [procedural] tracks are drawn "
                             "(default: %(default)s)")
    parser.add_argument("--tracks", type=int, default=300,
                        help="training tracks drawn (default: %(default)s)")
    args = parser.parse_args()
    for path in args.routes:
        track = load_track(path)
        ratio, entry, at = funnel(track)
        print(f"{track.name:28s} funnel x{ratio:.2f} (from {entry:.2f} m wide at {at:.1f} m)")
    if args.tracks:
        from h2h_racing.config.shipped import resolve_config
        from h2h_racing.training.config import TrainConfig

        proc = TrainConfig.from_toml(resolve_config(args.config, "train")).procedural
        rng = np.random.default_rng(12345)
        ratios = np.array([funnel(proc.draw(rng))[0] for _ in range(args.tracks)])
        print(f"training tracks ({args.config}, {args.tracks}): funnel over x1.5 on "
              f"{100 * (ratios > 1.5).mean():.1f} %, over x1.8 on "
              f"{100 * (ratios > 1.8).mean():.1f} %; largest x{ratios.max():.2f}, median "
              f"x{np.median(ratios):.2f}")


if __name__ == "__main__":
    main()
