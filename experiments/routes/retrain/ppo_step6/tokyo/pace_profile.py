"""Where a driver loses time to another along one track: per-metre time and speed of the
one-lap attempts of ``h2h-racing evaluate`` (20 starts spread round the lap, alone, training
rules), with the track's width and centre-line curvature there.

    python experiments/routes/retrain/ppo_step6/tokyo/pace_profile.py TRACK [A] [B] \
        [--episodes 20] [--bin 1.0]

A and B default to ``ppo_generalist`` and ``racing_line``. For each driver: every attempt's
lap time (by start point), then per ``--bin`` metres of the lap: the time spent there (mean
over the attempts that drove it, the first 2 m after each start left out: a standing start),
the mean speed, the speed command's mean and the share of steps with the speed action at its
top (``[-1, 1]`` action >= 0.99, the driver's top speed), the mean |offset| from the centre
line; and the time lost (A - B) per bin with its running sum.
"""

from __future__ import annotations

import argparse

import numpy as np

from h2h_racing.policies import make_driver
from h2h_racing.sim.core import RaceCore
from h2h_racing.track.io import load_track
from h2h_racing.training.evaluate import lap_config, lap_starts

STANDING = 2.0
"""Metres after each start left out of the per-bin figures (the car is accelerating from 0)."""


def trace(spec: str, track_path: str, episodes: int) -> dict[str, np.ndarray]:
    """Per-step arrays of every attempt: s, lap distance driven, speed, d, speed action."""
    track = load_track(track_path)
    cfg = lap_config(track_path)
    core = RaceCore(cfg, track, num_envs=episodes)
    core.reset(seed=0, start=lap_starts(track, episodes))
    driver = make_driver(spec, seed=0)
    driver.reset(core)
    start = core.distance[:, 0].copy()
    rows: dict[str, list] = {"s": [], "driven": [], "speed": [], "d": [], "action": [],
                             "command": [], "live": []}
    while not core.done.all():
        live = ~core.done[:, 0]
        action = np.asarray(driver.act(core, 0), dtype=np.float64)
        rows["s"].append(core.s[:, 0].copy())
        rows["driven"].append(core.distance[:, 0] - start)
        rows["speed"].append(core.speed[:, 0].copy())
        rows["d"].append(core.d[:, 0].copy())
        rows["action"].append(action[:, 1].copy())
        rows["live"].append(live.copy())
        steer, speed = cfg.commands(action[:, None, :])
        rows["command"].append(np.asarray(speed)[:, 0].copy())
        core.step(steer, speed)
    out = {k: np.array(v) for k, v in rows.items()}
    out["lap"] = np.array([t[0] if t else np.nan for t in (core.lap_times[e][0]
                                                          for e in range(episodes))])
    out["dt"] = np.full(1, core.dt)
    return out


def per_bin(tr: dict[str, np.ndarray], length: float, width: float) -> dict[str, np.ndarray]:
    """Per-bin means over the steps of the attempts that lapped (standing starts left out)."""
    bins = int(np.ceil(length / width))
    ok = np.isfinite(tr["lap"])[None, :] & tr["live"] & (tr["driven"] >= STANDING) & (
        tr["driven"] <= length)
    b = np.minimum((tr["s"] / width).astype(int), bins - 1)
    out = {}
    steps = np.bincount(b[ok], minlength=bins).astype(float)
    # Attempts that drove through each bin (after their standing start): each adds its steps.
    visits = np.zeros(bins)
    for e in range(tr["s"].shape[1]):
        if ok[:, e].any():
            visits += np.bincount(b[ok[:, e], e], minlength=bins) > 0
    out["time"] = steps * tr["dt"][0] / np.maximum(visits, 1)
    for key in ("speed", "command", "d"):
        value = np.abs(tr[key]) if key == "d" else tr[key]
        out[key] = np.bincount(b[ok], weights=value[ok], minlength=bins) / np.maximum(steps, 1)
    out["top"] = np.bincount(b[ok], weights=(tr["action"][ok] >= 0.99), minlength=bins) / (
        np.maximum(steps, 1))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("track", help="track name or file")
    parser.add_argument("a", nargs="?", default="ppo_generalist",
                        help="driver A (default: %(default)s)")
    parser.add_argument("b", nargs="?", default="racing_line",
                        help="driver B (default: %(default)s)")
    parser.add_argument("--episodes", type=int, default=20,
                        help="one-lap attempts (default: %(default)s)")
    parser.add_argument("--bin", type=float, default=1.0, help="bin length [m] (default: "
                        "%(default)s)")
    parser.add_argument("--trace", nargs=3, type=float, default=None,
                        metavar=("ATTEMPT", "FROM", "TO"),
                        help="also print every step of attempt ATTEMPT from FROM to TO m of "
                             "the lap, for both drivers (default: none)")
    args = parser.parse_args()
    track = load_track(args.track)
    starts = lap_starts(track, args.episodes)
    ta, tb = trace(args.a, args.track, args.episodes), trace(args.b, args.track, args.episodes)
    print(f"{track.name}: {track.length:.2f} m; one-lap attempts from standstill")
    print("start m  " + "  ".join(f"{s:5.1f}" for s in starts))
    for spec, tr in ((args.a, ta), (args.b, tb)):
        print(f"{spec[:7]:7s}  " + "  ".join(f"{t:5.2f}" for t in tr["lap"])
              + f"   mean {np.nanmean(tr['lap']):.2f} s")
    fa = per_bin(ta, track.length, args.bin)
    fb = per_bin(tb, track.length, args.bin)
    centres = (np.arange(len(fa["time"])) + 0.5) * args.bin
    left, right = track.half_widths_at(centres)
    fine = np.arange(0.0, track.length, 0.05)
    k_fine = np.abs(track.curvature_at(fine))
    print(f"{'bin m':>7} {'width':>5} {'max|k|':>6} | {'A s':>5} {'A m/s':>5} {'A cmd':>5} "
          f"{'A top':>5} {'A |d|':>5} | {'B s':>5} {'B m/s':>5} {'B |d|':>5} | "
          f"{'lost s':>6} {'sum s':>6}")
    total = 0.0
    for i, c in enumerate(centres):
        lost = fa["time"][i] - fb["time"][i]
        total += lost
        sel = (fine >= c - 0.5 * args.bin) & (fine < c + 0.5 * args.bin)
        print(f"{c - 0.5 * args.bin:4.0f}-{c + 0.5 * args.bin:<3.0f}"
              f"{left[i] + right[i]:5.2f} {k_fine[sel].max():6.2f} | "
              f"{fa['time'][i]:5.2f} {fa['speed'][i]:5.2f} {fa['command'][i]:5.2f} "
              f"{100 * fa['top'][i]:4.0f}% {fa['d'][i]:5.2f} | {fb['time'][i]:5.2f} "
              f"{fb['speed'][i]:5.2f} {fb['d'][i]:5.2f} | {lost:+6.2f} {total:+6.2f}")
    if args.trace is not None:
        e, lo, hi = int(args.trace[0]), args.trace[1], args.trace[2]
        for spec, tr in ((args.a, ta), (args.b, tb)):
            print(f"{spec}, attempt {e} (start {starts[e]:.1f} m), steps from {lo} to {hi} m:")
            sel = tr["live"][:, e] & (tr["s"][:, e] >= lo) & (tr["s"][:, e] < hi) & (
                tr["driven"][:, e] < track.length)
            for s, v, d, c in zip(tr["s"][sel, e], tr["speed"][sel, e], tr["d"][sel, e],
                                  tr["command"][sel, e]):
                hl, hr = track.half_widths_at(np.array([s]))
                k = track.curvature_at(np.array([s]))[0]
                print(f"  s {s:5.2f} m  speed {v:4.2f}  command {c:4.2f} m/s  d {d:+.2f} m  "
                      f"half-widths L {hl[0]:.2f} R {hr[0]:.2f} m  curvature {k:+.2f} /m")
    print(f"A's top speed reached: {ta['speed'][ta['live']].max():.2f} m/s, B's "
          f"{tb['speed'][tb['live']].max():.2f} m/s; A's speed command at most "
          f"{ta['command'][ta['live']].max():.2f} m/s")


if __name__ == "__main__":
    main()
