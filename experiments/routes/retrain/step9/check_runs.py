"""Share of a config's training tracks that have a run of tight corners in a narrow section,
entered from a wide track (as ``Tokyo_Training_track`` at 9-16 m), and the same measure on
route files.

    python experiments/routes/retrain/step9/check_runs.py [--config CONFIG] [--tracks 300] \
        [ROUTE.npy ...]

A track's sections are its stretches at most ``NARROW`` wide (every 5 cm, round the lap); a
section's corners are its stretches of curvature at least ``TIGHT_K`` (radius under 0.67 m,
``../ppo_step6/tokyo/funnels.py``'s tight corner), a new one where the curvature changes sign
or falls under ``TIGHT_K`` for at least ``GAP``. A run is a section with at least 2 corners;
it is funnelled if the track is at least ``RATIO`` x the section's narrowest width somewhere in
the ``AHEAD`` metres before it. Prints, for each route, its longest-run section; for the
config's tracks (drawn as training draws them, one generator, seed 12345 as ``funnels.py``),
the share with a run, with a funnelled run, and how many of them are the generator's run
funnels (``funnel_corners``: "into a run of" in their description). Plain
``h2h_racing`` only; it reads the config and the routes, and trains or tunes nothing.
"""

from __future__ import annotations

import argparse

import numpy as np

from h2h_racing.track.shape import Track

NARROW = 0.9
"""Widest section counted as narrow [m]: Tokyo's run is 0.65-0.9 m wide."""
TIGHT_K = 1.5
"""Curvature of a tight corner [1/m]."""
GAP = 0.2
"""Shortest dip under ``TIGHT_K`` that separates two corners turning the same way [m]."""
RATIO = 1.5
"""Width before the section over its narrowest width, for a funnelled run."""
AHEAD = 2.0
"""How far before the section the wide track must be [m]."""
STEP = 0.05


def runs(track: Track) -> list[tuple[float, float, int, float]]:
    """``(start [m], length [m], corners, entry ratio)`` of each narrow section with 2 or more
    tight corners."""
    s = np.arange(0.0, track.length, STEP)
    left, right = track.half_widths_at(s)
    width = left + right
    kappa = track.curvature_at(s)
    narrow = width <= NARROW
    n = len(s)
    if narrow.all() or not narrow.any():
        starts = [0] if narrow.all() else []
    else:
        starts = [i for i in range(n) if narrow[i] and not narrow[i - 1]]
    found = []
    for first in starts:
        idx = [first]
        while narrow[(idx[-1] + 1) % n] and len(idx) < n:
            idx.append((idx[-1] + 1) % n)
        k = kappa[idx]
        corners, last_sign, dip = 0, 0.0, GAP
        for value in k:
            if abs(value) >= TIGHT_K:
                sign = np.sign(value)
                if sign != last_sign or dip >= GAP:
                    corners += 1
                last_sign, dip = sign, 0.0
            else:
                dip += STEP
        if corners >= 2:
            before = (first - np.arange(1, int(AHEAD / STEP) + 1)) % n
            ratio = float(width[before].max() / width[idx].min())
            found.append((float(s[first]), len(idx) * STEP, corners, ratio))
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("routes", nargs="*", help="route files (.npy)")
    parser.add_argument("--config", default="ppo_generalist/routes",
                        help="training config whose [procedural] tracks are drawn "
                             "(default: %(default)s)")
    parser.add_argument("--tracks", type=int, default=300,
                        help="training tracks drawn; 0 draws none (default: %(default)s)")
    args = parser.parse_args()
    from h2h_racing.track.io import load_track

    for path in args.routes:
        track = load_track(path)
        found = runs(track)
        if found:
            at, length, corners, ratio = max(found, key=lambda r: r[2])
            print(f"{track.name:28s} {len(found)} run(s); most corners: {corners} in "
                  f"{length:.1f} m from {at:.1f} m, entered x{ratio:.2f}")
        else:
            print(f"{track.name:28s} no run")
    if args.tracks:
        from h2h_racing.config.shipped import resolve_config
        from h2h_racing.training.config import TrainConfig

        proc = TrainConfig.from_toml(resolve_config(args.config, "train")).procedural
        rng = np.random.default_rng(12345)
        with_run = funnelled = generated = generated_funnelled = 0
        for _ in range(args.tracks):
            track = proc.draw(rng)
            found = runs(track)
            made = "into a run of" in track.description
            generated += made
            with_run += bool(found)
            hit = any(ratio >= RATIO for *_, ratio in found)
            funnelled += hit
            generated_funnelled += made and hit
        print(f"training tracks ({args.config}, {args.tracks}, funnel_share "
              f"{proc.funnel_share}, funnel_corners {proc.funnel_corners}): a run of >= 2 "
              f"tight corners in a section <= {NARROW} m wide on "
              f"{100 * with_run / args.tracks:.1f} %, entered from x{RATIO} wider within "
              f"{AHEAD} m on {100 * funnelled / args.tracks:.1f} %; run funnels drawn: "
              f"{generated} ({generated_funnelled} of them measured funnelled)")


if __name__ == "__main__":
    main()
