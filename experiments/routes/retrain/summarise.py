"""Issue 36's targets per seed, from the JSON files `run.sh` writes beside this file.

    python experiments/routes/retrain/summarise.py

- ppo: >= 95 % laps and a mean lap within 5 % of min(its best lap, racing_line's mean lap)
  on every route;
- camera: >= 95 % laps and a mean lap within 10 % of ppo_generalist's on every route (the
  shipped ppo_generalist's, `experiments/routes/ppo_generalist.json`, or the retrained seed's
  named by PPO_SEED);
- obstacle: the evaluate command's own targets (>= 90 % of the races finished, <= 0.5 crashes
  and <= 1 reset per lap) on every route, in object avoidance and head to bot.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

HERE = Path(__file__).parent


def load(name: str) -> dict | None:
    path = HERE / f"{name}.json"
    return json.loads(path.read_text()) if path.exists() else None


def time_trial(name: str, reference: dict | None, within: float) -> str | None:
    data = load(name)
    if data is None:
        return None
    laps_missed, pace_missed = [], []
    ref_lap = {r["route"]: r["mean_lap_s"] for r in (reference or {}).get("routes", [])}
    for route in data["routes"]:
        if route["laps"] < 0.95:
            laps_missed.append(f"{route['route']} {100 * route['laps']:.0f} %")
            continue
        if reference is None:  # ppo: against its own best and racing_line's mean
            bar = min(route["best_lap_s"], route["baseline_mean_lap_s"] or 1e9)
        else:
            bar = ref_lap.get(route["route"]) or 1e9
        if route["mean_lap_s"] > (1 + within) * bar:
            pace_missed.append(f"{route['route']} {100 * (route['mean_lap_s'] / bar - 1):+.1f} %")
    total = len(data["routes"])
    return (f"| {name} | {total - len(laps_missed)} of {total} | {', '.join(laps_missed) or '-'} "
            f"| {total - len(laps_missed) - len(pace_missed)} of {total} | "
            f"{', '.join(pace_missed) or '-'} | {data['summary']['mean_vs_baseline_pct']:+.1f} % |")


def obstacles(name: str) -> str | None:
    cells = []
    for race_type in ("object_avoidance", "head_to_bot"):
        data = load(f"{name}_{race_type}")
        if data is None:
            return None
        s = data["summary"]
        cells.append(f"{s['routes_meeting_targets']} of {s['routes']} "
                     f"({', '.join(s['routes_missing_targets']) or 'all'}); "
                     f"{s['crashes'] / s['laps']:.2f} crashes, {s['resets'] / s['laps']:.2f} "
                     f"resets a lap")
    return f"| {name} | {' | '.join(cells)} |"


def main() -> None:
    print("| run | routes at >= 95 % laps | below | routes on target (laps and pace) | "
          "off pace | mean lap vs racing_line |")
    print("|---|---|---|---|---|---|")
    ppo_ref = json.loads((HERE.parent / "ppo_generalist.json").read_text())
    if os.environ.get("PPO_SEED"):
        ppo_ref = load(f"ppo_s{os.environ['PPO_SEED']}")
    for seed in range(3):
        for row in (time_trial(f"ppo_s{seed}", None, 0.05),
                    time_trial(f"camera_s{seed}", ppo_ref, 0.10)):
            if row:
                print(row)
    print()
    print("| run | object avoidance: routes on target | head to bot: routes on target |")
    print("|---|---|---|")
    for seed in range(3):
        row = obstacles(f"obstacle_s{seed}")
        if row:
            print(row)


if __name__ == "__main__":
    main()
