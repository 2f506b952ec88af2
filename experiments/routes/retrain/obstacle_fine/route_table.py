"""The per-route table of obstacle_generalist's card: each route's object-avoidance and
head-to-bot figures (20 three-lap races) of a seed of obstacle_fine and of the policy before.

    python experiments/routes/retrain/obstacle_fine/route_table.py [SEED]   # default 1
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).parent
BEFORE = HERE.parent / "shipped"


def cell(route: dict) -> str:
    mark = "" if not route["missed_targets"] else " **missed**"
    return (f"{route['finished']}/{route['races']}, {route['crashes_per_lap']:.2f}, "
            f"{route['resets_per_lap']:.2f}{mark}")


def main(seed: int) -> None:
    runs = {}
    for race_type in ("object_avoidance", "head_to_bot"):
        runs[race_type] = (
            json.loads((HERE / f"obstacle_s{seed}_{race_type}.json").read_text()),
            json.loads((BEFORE / f"obstacle_generalist_{race_type}.json").read_text()))
    print("| route | object avoidance: finished, crashes / lap, resets / lap | before step 7 "
          "| head to bot: finished, crashes / lap, resets / lap | before step 7 |")
    print("|---|---|---|---|---|")
    names = [r["route"] for r in runs["object_avoidance"][0]["routes"]]
    for name in names:
        cells = []
        for race_type in ("object_avoidance", "head_to_bot"):
            now, before = ({r["route"]: r for r in data["routes"]}[name]
                           for data in runs[race_type])
            cells += [cell(now), cell(before)]
        print(f"| `{name}` | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1)
