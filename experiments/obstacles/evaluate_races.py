"""Object-avoidance and head-to-bot figures on the shipped tracks, against issue 22's targets.

    python experiments/obstacles/evaluate_races.py POLICY [POLICY ...] [--json FILE]

POLICY is a scripted driver (``racing_line``, ``pure_pursuit``; constructor options as
``racing_line:grip_factor=0.5,margin=0.2``), a shipped policy or a ``policy.pt``. For each
policy, on each catalogue track and each real DeepRacer route found in ``--routes`` (by
default ``../shared/data/deepracer_tracks/*.npy`` beside the clone, README's Tests section;
``--routes none`` skips them):

- ``object_avoidance``: 3-lap races, one car, DeepRacer's default 6 boxes at randomised places
  (seeds 1-3, or `--seeds`; race rules: a crash costs a penalty and a reset);
- ``head_to_bot``: 3-lap races against the default bots (3 cars at 0.75 m/s on alternating
  lanes, changing lanes every 3-5 s; the same seeds);
- ``time_trial``: one 3-lap time trial (seed 0): the best lap, and its ratio to the
  ``--reference`` policy's best lap on that track (``ppo_generalist``).

Per track and race type: races finished, laps completed, crashes and resets per lap completed,
and (head-to-bot) the net passes of bots on track: a bot ahead within ``PASS_WINDOW`` that is
behind at the next step counts +1, a bot behind that gets ahead again (it passed us while we
were frozen by a penalty, or a reset put us back behind it) counts -1. ``ok`` marks a row that
meets the issue's targets: at least 90 % finished, at most 0.5 crashes and 1 reset per lap,
some bots passed; a time-trial best lap within 15 % of the reference's.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from h2h_racing.match import run_race
from h2h_racing.policies import make_driver
from h2h_racing.track.io import list_tracks

SEEDS = (1, 2, 3)
ROUTES = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "deepracer_tracks"
RACE_TYPES = ("object_avoidance", "head_to_bot")
LAPS = 3
PASS_WINDOW = 2.0
"""Largest |arc gap| to a bot, before and after a step, at which its change of side counts
as a pass [m] (a step moves a car at most 0.4 m; the window keeps the lap's wrap-round out)."""
TARGETS = {"finished": 0.9, "crashes_per_lap": 0.5, "resets_per_lap": 1.0,
           "lap_time_ratio": 1.15}
"""Issue 22's targets for obstacle_generalist."""


def parse_driver(spec: str) -> tuple[str, dict[str, float]]:
    """``"name:key=value,key=value"`` -> (name, options); a path or a bare name has none."""
    if ":" not in spec or spec.endswith(".pt"):
        return spec, {}
    name, _, rest = spec.partition(":")
    options: dict[str, float] = {}
    for item in rest.split(","):
        key, eq, value = item.partition("=")
        if not eq:
            raise SystemExit(f"driver options must read key=value, got {item!r} in {spec!r}")
        options[key.strip()] = float(value)
    return name, options


class BotPassCounter:
    """Wraps a driver and counts the bots it passes on track (see the module docstring)."""

    def __init__(self, driver: Any) -> None:
        self.driver = driver
        self.name = getattr(driver, "name", type(driver).__name__)
        self.passes = self.passed_back = 0
        self._gap: np.ndarray | None = None

    def reset(self, core: Any) -> None:
        self.driver.reset(core)
        self.passes = self.passed_back = 0
        self._gap = None

    def act(self, core: Any, car: int) -> np.ndarray:
        if core.num_bots:
            length = core.track.length
            gap = core.bot_s[0] - core.s[0, car]
            gap = gap - length * np.floor(gap / length + 0.5)
            if self._gap is not None:
                near = (np.abs(gap) < PASS_WINDOW) & (np.abs(self._gap) < PASS_WINDOW)
                self.passes += int((near & (self._gap > 0) & (gap <= 0)).sum())
                self.passed_back += int((near & (self._gap <= 0) & (gap > 0)).sum())
            self._gap = gap
        return self.driver.act(core, car)


def race_rows(spec: str, track: str, race_type: str) -> dict[str, Any]:
    """The races of ``spec`` on ``track`` in ``race_type`` (seeds ``SEEDS``), summed."""
    name, options = parse_driver(spec)
    total = {"races": 0, "finished": 0, "laps": 0, "crashes": 0, "resets": 0, "passes": 0,
             "passed_back": 0, "total_time": []}
    for seed in SEEDS:
        counter = BotPassCounter(make_driver(name, seed=seed, **options))
        extra = {"randomize_obstacles": True} if race_type == "object_avoidance" else {}
        row = run_race(track, [counter], race_type=race_type, laps=LAPS, seed=seed,
                       **extra).rows[0]
        total["races"] += 1
        total["finished"] += int(row["finished"])
        for key in ("laps", "crashes", "resets"):
            total[key] += row[key]
        total["passes"] += counter.passes
        total["passed_back"] += counter.passed_back
        total["total_time"].append(row["total_time"] if row["finished"] else None)
    laps = total["laps"]
    total["crashes_per_lap"] = total["crashes"] / laps if laps else None
    total["resets_per_lap"] = total["resets"] / laps if laps else None
    total["net_passes"] = total["passes"] - total["passed_back"]
    total["ok"] = bool(
        total["finished"] >= TARGETS["finished"] * total["races"] and laps
        and total["crashes_per_lap"] <= TARGETS["crashes_per_lap"]
        and total["resets_per_lap"] <= TARGETS["resets_per_lap"]
        and (race_type != "head_to_bot" or total["net_passes"] > 0))
    return total


def best_lap(spec: str, track: str) -> float:
    """Best lap of a 3-lap time trial (seed 0) [s]; inf without a lap."""
    name, options = parse_driver(spec)
    row = run_race(track, [make_driver(name, seed=0, **options)], race_type="time_trial",
                   laps=LAPS, seed=0).rows[0]
    return float(row["best_lap"])


def _label(track: str) -> str:
    return Path(track).stem if track.endswith(".npy") else track


def _per_lap(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def evaluate(spec: str, tracks: list[str], reference: str | None,
             reference_laps: dict[str, float]) -> dict[str, Any]:
    """Every figure of ``spec`` on ``tracks``, printed as a table as it comes."""
    print(f"== {spec}", flush=True)
    print(f"{'track':15s} {'race type':17s} {'fin':>5} {'laps':>4} {'crash/lap':>9} "
          f"{'reset/lap':>9} {'bot passes':>10} {'ok':>3}", flush=True)
    out: dict[str, Any] = {}
    for track in tracks:
        out[track] = {}
        for race_type in RACE_TYPES:
            r = race_rows(spec, track, race_type)
            out[track][race_type] = r
            passes = (f"{r['net_passes']} ({r['passes']}-{r['passed_back']})"
                      if race_type == "head_to_bot" else "")
            print(f"{_label(track):15s} {race_type:17s} {r['finished']}/{r['races']:<3} "
                  f"{r['laps']:>4} "
                  f"{_per_lap(r['crashes_per_lap']):>9} {_per_lap(r['resets_per_lap']):>9} "
                  f"{passes:>10} {'yes' if r['ok'] else 'no':>3}", flush=True)
        lap = best_lap(spec, track)
        ref = reference_laps.get(track)
        ratio = lap / ref if ref and math.isfinite(lap) and math.isfinite(ref) else None
        out[track]["time_trial"] = {"best_lap": lap, "reference": reference,
                                    "reference_best_lap": ref, "ratio": ratio,
                                    "ok": ratio is not None
                                    and ratio <= TARGETS["lap_time_ratio"]}
        shown = "-" if ratio is None else f"{ratio:.3f}"
        print(f"{_label(track):15s} {'time_trial':17s} best lap {lap:.2f} s, {reference} "
              f"{ref if ref is None else round(ref, 2)} s, ratio {shown} "
              f"{'yes' if out[track]['time_trial']['ok'] else 'no'}", flush=True)
    for race_type in RACE_TYPES:
        rows = [out[t][race_type] for t in tracks]
        print(f"total {race_type}: {sum(r['finished'] for r in rows)}/"
              f"{sum(r['races'] for r in rows)} finished, {sum(r['laps'] for r in rows)} laps, "
              f"{sum(r['crashes'] for r in rows)} crashes, {sum(r['resets'] for r in rows)} "
              f"resets, {sum(r['net_passes'] for r in rows)} net bot passes; targets met on "
              f"{sum(r['ok'] for r in rows)}/{len(rows)} tracks", flush=True)
    met = sum(out[t]["time_trial"]["ok"] for t in tracks)
    print(f"total time_trial: within 15 % of {reference} on {met}/{len(tracks)} tracks",
          flush=True)
    return out


def main(argv: list[str] | None = None) -> int:
    global SEEDS
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("policies", nargs="+", help="drivers, shipped policies or policy.pt")
    parser.add_argument("--tracks", nargs="+", default=None, help="default: the catalogue")
    parser.add_argument("--routes", default=str(ROUTES),
                        help="folder of DeepRacer route files (.npy) raced too, or 'none'")
    parser.add_argument("--reference", default="ppo_generalist",
                        help="policy whose time-trial best lap the ratios divide by")
    parser.add_argument("--json", type=Path, default=None, help="write every figure here")
    parser.add_argument("--seeds", nargs="+", type=int, default=list(SEEDS),
                        help="race seeds of the object-avoidance and head-to-bot races "
                             "(default: %(default)s)")
    args = parser.parse_args(argv)
    SEEDS = tuple(args.seeds)
    tracks = args.tracks or list_tracks()
    if args.routes != "none" and Path(args.routes).is_dir():
        tracks += [str(path) for path in sorted(Path(args.routes).glob("*.npy"))]
    reference_laps = {t: best_lap(args.reference, t) for t in tracks} if args.reference else {}
    figures = {spec: evaluate(spec, tracks, args.reference, reference_laps)
               for spec in args.policies}
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"seeds": SEEDS, "laps": LAPS, "targets": TARGETS,
                                         "reference_best_laps": reference_laps,
                                         "figures": figures}, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
