"""Whether the chosen seed of ppo_generalist's step 9 ships: step 8's ship rule, read only
after the seed is chosen (`choose_seed.txt`).

    python experiments/routes/retrain/step9/ship_rule.py      # ship_rule.txt

The rule (`../step8/README.md`, "The plan for step 8", unchanged): it ships if on the 40
routes it has MORE routes on target than the shipped step 6 (39 of 40), with every route at
>= 95 % laps and every shipped track at 100 %. On target: >= 95 % laps and a mean lap within
5 % of the faster of `experiments/routes/ppo_generalist.json`'s (steps 1-2's file, 10
attempts: the card's "policy before") and today's racing_line's (`../racing_line.json`) on the
route, as `../summarise.py` counts it (its `pace_bar` and `SHIPPED_PPO`, imported). Files:
`ppo9_sN.json` (the 40 routes) and `ppo9_sN_shipped.json` (the shipped tracks) of the chosen
seed.
"""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path

HERE = Path(__file__).parent
NAME = "ppo9"
STEP6_ON_TARGET = 39
"""Routes on target of the shipped step 6 (`../ppo_step6/choose_seed.txt`, step8/README.md)."""
ROUTES = 40

_spec = importlib.util.spec_from_file_location("summarise", HERE.parent / "summarise.py")
summarise = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(summarise)


def chosen_seed(path: Path) -> int:
    """The seed `choose_seed.py` chose, from its output saved in ``path``."""
    if not path.exists():
        raise SystemExit(f"{path}: no such file; run choose_seed.py > {path.name} first (the "
                         "seed is chosen before any route figure is read)")
    found = re.findall(rf"^chosen: {NAME}_s(\d+)$", path.read_text(), re.MULTILINE)
    if len(found) != 1:
        raise SystemExit(f"{path}: expected one line 'chosen: {NAME}_sN', found {len(found)}")
    return int(found[0])


def main() -> None:
    seed = chosen_seed(HERE / "choose_seed.txt")
    summarise.RACING_LINE = summarise.read_racing_line(
        "--racing-line", HERE.parent / "racing_line.json", "../shared/data/deepracer_tracks")
    routes = json.loads((HERE / f"{NAME}_s{seed}.json").read_text())
    shipped = json.loads((HERE / f"{NAME}_s{seed}_shipped.json").read_text())
    if len(routes["routes"]) != ROUTES:
        raise SystemExit(f"{NAME}_s{seed}.json: expected the {ROUTES} routes, got "
                         f"{len(routes['routes'])}")
    line_laps = summarise.racing_line_laps(routes)
    below, off_pace = [], []
    for route in routes["routes"]:
        if route["laps"] < 0.95:
            below.append(f"{route['route']} {100 * route['laps']:.0f} %")
            continue
        bar, whose = summarise.pace_bar(route, summarise.SHIPPED_PPO, True, line_laps)
        if route["mean_lap_s"] > 1.05 * bar:
            off_pace.append(f"{route['route']} {100 * (route['mean_lap_s'] / bar - 1):+.1f} % "
                            f"({whose})")
    on_target = ROUTES - len(below) - len(off_pace)
    not_full = [f"{r['route']} {100 * r['laps']:.0f} %" for r in shipped["routes"]
                if r["laps"] < 1.0]
    print(f"{NAME}_s{seed}: {on_target} of {ROUTES} routes on target (step 6: "
          f"{STEP6_ON_TARGET}); below 95 % laps: {', '.join(below) or 'none'}; off pace: "
          f"{', '.join(off_pace) or 'none'}; shipped tracks under 100 %: "
          f"{', '.join(not_full) or 'none'}; mean lap vs racing_line "
          f"{summarise.mean_vs_racing_line(routes, line_laps):+.1f} %")
    ships = on_target > STEP6_ON_TARGET and not below and not not_full
    print(f"ships: {'yes' if ships else 'no'}")


if __name__ == "__main__":
    main()
