"""Issue 36's targets per seed, from the JSON files `run.sh` writes beside this file.

    python experiments/routes/retrain/summarise.py

- ppo: >= 95 % laps and a mean lap within 5 % of the faster of the shipped ppo_generalist's
  (`experiments/routes/ppo_generalist.json`, 10 attempts) and racing_line's on every route;
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


def time_trial(name: str, reference: dict | None, within: float,
               folder: Path = HERE) -> str | None:
    path = folder / f"{name}.json"
    data = json.loads(path.read_text()) if path.exists() else None
    if data is None or data.get("race_type") != "time_trial":
        return None
    laps_missed, pace_missed = [], []
    ref_lap = {r["route"]: r["mean_lap_s"] for r in (reference or {}).get("routes", [])}
    for route in data["routes"]:
        if route["laps"] < 0.95:
            laps_missed.append(f"{route['route']} {100 * route['laps']:.0f} %")
            continue
        bar = ref_lap.get(route["route"]) or 1e9
        if reference is SHIPPED_PPO:  # ppo: the faster of the shipped one and racing_line
            bar = min(bar, route["baseline_mean_lap_s"] or 1e9)
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
    cells.append(alone_shipped(name))
    return f"| {name} | {' | '.join(cells)} |"


def alone_shipped(name: str) -> str:
    """The mean lap alone against racing_line's over the shipped tracks, from the time-trial
    evaluate output beside the JSON (`NAME_time_trial_shipped.txt`), or '-' without one."""
    path = HERE / f"{name}_time_trial_shipped.txt"
    if not path.exists():
        return "-"
    for line in path.read_text().splitlines():
        if line.startswith("mean lap vs racing_line's:"):
            return line.split(":", 1)[1].split(" on average")[0].strip()
    return "-"


SHIPPED_PPO = json.loads((HERE.parent / "ppo_generalist.json").read_text())


def main() -> None:
    print("| run | routes at >= 95 % laps | below | routes on target (laps and pace) | "
          "off pace | mean lap vs racing_line |")
    print("|---|---|---|---|---|---|")
    ppo_ref = SHIPPED_PPO
    if os.environ.get("PPO_SEED"):
        ppo_ref = load(f"ppo_s{os.environ['PPO_SEED']}")
    for seed in range(3):
        for row in (time_trial(f"ppo_s{seed}", SHIPPED_PPO, 0.05),
                    time_trial(f"camera_s{seed}", ppo_ref, 0.10)):
            if row:
                print(row)
    for folder in sorted(p for p in HERE.iterdir() if p.is_dir()):
        for path in sorted(folder.glob("*.json")):
            if path.stem.startswith("obstacle"):  # its rows are the second table's
                continue
            camera = path.stem.startswith("camera")
            row = time_trial(path.stem, ppo_ref if camera else SHIPPED_PPO,
                             0.10 if camera else 0.05, folder)
            if row:
                print(row.replace(f"| {path.stem} |", f"| {folder.name}/{path.stem} |", 1))
    print()
    print("| run | object avoidance: routes on target | head to bot: routes on target | "
          "alone on the shipped tracks vs racing_line |")
    print("|---|---|---|---|")
    for seed in ("shipped/obstacle_generalist",
                 *(f"{folder}/obstacle_s{seed}" for folder in ("obstacle", "obstacle_fine")
                   for seed in range(3))):
        row = obstacles(seed)
        if row:
            print(row)


if __name__ == "__main__":
    main()
