"""Which seed of ppo_generalist's step 6 would ship, from the shipped tracks and the 30
route-like procedural tracks, never the real routes.

    python experiments/routes/retrain/ppo_step6/choose_seed.py           # step 6 (ppo6_sN)
    python experiments/routes/retrain/ppo_step6/choose_seed.py --step 5  # step 5, for the record

The rule, fixed and committed before any figure of step 6 was read (the routes only check the
choice):
1. the seeds that lap every shipped track at 100 % (20 of 20 attempts, `evaluate --track all
   --episodes 20`); if none does, those that lap the most shipped tracks at 100 %;
2. among them, the seeds that lap the most of the 30 route-like tracks (`routelike.py`: 20
   one-lap attempts each) at >= 95 %;
3. among them, the fastest: the lowest mean, over the 7 shipped and 30 route-like tracks
   together (37, each counted once, those the seed lapped at all), of its mean lap against
   today's racing_line's there, in % (`../racing_line_shipped.json`,
   `racing_line_routelike.json`: racing_line alone on the same start points).
A seed without its JSONs is left out and named.

Files: step 6 `ppo6_sN_shipped.json` and `ppo6_sN_routelike.json` beside this file; step 5
`../ppo_more/ppo5_sN_shipped.json` and `ppo5_sN_routelike.json` beside this file.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).parent
SEEDS = (0, 1, 2)
ROUTELIKE_TRACKS = 30
# A later step reuses this rule on its own seeds (../step8/choose_seed_ppo.py): it sets NAME,
# its files' prefix ("ppo8": ppo8_sN_shipped.json, ppo8_sN_routelike.json), and SEED_DIR, the
# folder holding them. None: steps 5 and 6 as --step says.
NAME: str | None = None
SEED_DIR: Path | None = None


def line_laps(path: Path) -> dict[str, float]:
    """racing_line's mean lap per track [s] of one evaluate JSON."""
    return {r["route"]: r["mean_lap_s"] for r in json.loads(path.read_text())["routes"]}


def figures(path: Path, line: dict[str, float], what: str) -> tuple[list[dict], list[float]]:
    """(the per-track rows, the seed's mean lap vs racing_line's per lapped track in %) of one
    evaluate JSON, checked to be a time trial on exactly ``line``'s tracks."""
    data = json.loads(path.read_text())
    tracks = sorted(r["route"] for r in data["routes"])
    episodes = data.get("settings", {}).get("episodes")
    if data.get("race_type") != "time_trial" or tracks != sorted(line) or episodes != 20:
        raise SystemExit(f"{path}: expected a time trial of 20 attempts on {what} "
                         f"({len(line)} tracks: {sorted(line)}), got race type "
                         f"{data.get('race_type')!r}, {episodes} attempts on {tracks}; "
                         "measure it as run.sh does")
    paces = [100 * (r["mean_lap_s"] / line[r["route"]] - 1) for r in data["routes"]
             if r["mean_lap_s"]]
    return data["routes"], paces


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--step", type=int, choices=(5, 6), default=6,
                        help="which step's seeds: 6 (ppo6_sN) or 5 (ppo5_sN, for the record)")
    args = parser.parse_args(argv)
    shipped_line = line_laps(HERE.parent / "racing_line_shipped.json")
    routelike_line = line_laps(HERE / "racing_line_routelike.json")
    if len(routelike_line) != ROUTELIKE_TRACKS:
        raise SystemExit(f"racing_line_routelike.json: expected {ROUTELIKE_TRACKS} tracks, got "
                         f"{len(routelike_line)}; measure it with routelike.py --policy "
                         "racing_line")
    if NAME is None:
        prefix = f"ppo{args.step}"
        shipped_dir = HERE if args.step == 6 else HERE.parent / "ppo_more"
        routelike_dir = HERE
    else:
        prefix, shipped_dir, routelike_dir = NAME, SEED_DIR, SEED_DIR
    scores: dict[int, tuple[int, int, float]] = {}
    for seed in SEEDS:
        name = f"{prefix}_s{seed}"
        shipped_path = shipped_dir / f"{name}_shipped.json"
        routelike_path = routelike_dir / f"{name}_routelike.json"
        missing = [p.name for p in (shipped_path, routelike_path) if not p.exists()]
        if missing:
            print(f"{name}: no {', '.join(missing)} (not measured); left out")
            continue
        shipped, shipped_paces = figures(shipped_path, shipped_line, "the shipped tracks")
        routelike, routelike_paces = figures(routelike_path, routelike_line,
                                             "the route-like tracks")
        full = sum(r["laps"] >= 1.0 for r in shipped)
        at_95 = sum(r["laps"] >= 0.95 for r in routelike)
        paces = shipped_paces + routelike_paces
        pace = sum(paces) / len(paces) if paces else float("inf")
        scores[seed] = (full, at_95, pace)
        below = ", ".join(f"{r['route']} {100 * r['laps']:.0f} %" for r in routelike
                          if r["laps"] < 0.95) or "none"
        print(f"{name}: {full} of {len(shipped_line)} shipped tracks at 100 %; {at_95} of "
              f"{len(routelike_line)} route-like tracks at >= 95 % (below: {below}); mean lap "
              f"{pace:+.1f} % against racing_line over {len(paces)} tracks (shipped "
              f"{sum(shipped_paces) / max(len(shipped_paces), 1):+.1f} %, route-like "
              f"{sum(routelike_paces) / max(len(routelike_paces), 1):+.1f} %)")
    if not scores:
        sys.exit("no seed measured yet")
    most_full = max(s[0] for s in scores.values())
    kept = [seed for seed, s in scores.items() if s[0] == most_full]
    most_95 = max(scores[seed][1] for seed in kept)
    kept = [seed for seed in kept if scores[seed][1] == most_95]
    chosen = min(kept, key=lambda seed: scores[seed][2])
    print(f"chosen: {prefix}_s{chosen}")


if __name__ == "__main__":
    main()
