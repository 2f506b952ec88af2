"""Issue 36's targets per seed, from the JSON files `run.sh` writes beside this file.

    python experiments/routes/retrain/summarise.py                      # today's racing_line
    python experiments/routes/retrain/summarise.py --stored-baseline    # as each run measured it
    python experiments/routes/retrain/summarise.py --pace-table ppo_s0  # its pace bar per route
    python experiments/routes/retrain/summarise.py --pace-table ppo_more/ppo5_s0  # a folder's run

Every subfolder's time-trial JSONs get a row too, except `*_shipped.json` (a run on the
shipped tracks, `--track all`, as `ppo_more/` keeps beside its routes) and `*_routelike.json`
(a run on the 30 route-like procedural tracks, `ppo_step6/routelike.py`).

racing_line's laps are its own run alone on the routes (`racing_line.json` beside this file,
`h2h-racing evaluate --policy racing_line --track ../shared/data/deepracer_tracks --episodes
20`), measured again whenever its line changes; the policies' own laps do not depend on it.
`--stored-baseline` uses the racing_line each run's JSON recorded instead (before
racing_line's fix for coarse waypoints, 6ad01ea, for every run here).

- ppo: >= 95 % laps and a mean lap within 5 % of the faster of the shipped ppo_generalist's
  (`experiments/routes/ppo_generalist.json`, 10 attempts) and racing_line's on every route;
- camera: >= 95 % laps and a mean lap within 10 % of ppo_generalist's on every route (the
  shipped ppo_generalist's, `experiments/routes/ppo_generalist.json`, or the retrained seed's
  named by PPO_SEED);
- obstacle: the evaluate command's own targets (>= 90 % of the races finished, <= 0.5 crashes
  and <= 1 reset per lap) on every route, in object avoidance and head to bot.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

HERE = Path(__file__).parent


def load(name: str) -> dict | None:
    path = HERE / f"{name}.json"
    return json.loads(path.read_text()) if path.exists() else None


def racing_line_laps(data: dict) -> dict[str, float | None]:
    """racing_line's mean lap per route for the run in ``data``: today's (RACING_LINE) unless
    --stored-baseline, else the one the run recorded beside its own laps."""
    if RACING_LINE is not None:
        return {r["route"]: r["mean_lap_s"] for r in RACING_LINE["routes"]}
    return {r["route"]: r["baseline_mean_lap_s"] for r in data["routes"]}


def pace_bar(route: dict, reference: dict | None, with_racing_line: bool,
             line_laps: dict[str, float | None]) -> tuple[float, str]:
    """The lap a route's mean lap is held to and whose it is: the reference policy's, or for
    ppo the faster of the shipped one's and racing_line's."""
    ref_lap = {r["route"]: r["mean_lap_s"] for r in (reference or {}).get("routes", [])}
    bar, whose = ref_lap.get(route["route"]) or 1e9, "policy before"
    line = line_laps.get(route["route"]) or 1e9
    if with_racing_line and line < bar:
        bar, whose = line, "racing_line"
    return bar, whose


def mean_vs_racing_line(data: dict, line_laps: dict[str, float | None]) -> float:
    """The mean of the per-route differences over the routes both lapped, as `evaluate`'s
    summary computes mean_vs_baseline_pct."""
    paces = [100 * (r["mean_lap_s"] / line_laps[r["route"]] - 1) for r in data["routes"]
             if r["mean_lap_s"] and line_laps.get(r["route"])]
    return sum(paces) / len(paces) if paces else float("nan")


def read_time_trial(name: str, folder: Path = HERE) -> dict | None:
    path = folder / f"{name}.json"
    data = json.loads(path.read_text()) if path.exists() else None
    return data if data is not None and data.get("race_type") == "time_trial" else None


def time_trial(name: str, reference: dict | None, within: float,
               folder: Path = HERE, with_racing_line: bool = False) -> str | None:
    data = read_time_trial(name, folder)
    if data is None:
        return None
    line_laps = racing_line_laps(data)
    laps_missed, pace_missed = [], []
    for route in data["routes"]:
        if route["laps"] < 0.95:
            laps_missed.append(f"{route['route']} {100 * route['laps']:.0f} %")
            continue
        bar, _ = pace_bar(route, reference, with_racing_line, line_laps)
        if route["mean_lap_s"] > (1 + within) * bar:
            pace_missed.append(f"{route['route']} {100 * (route['mean_lap_s'] / bar - 1):+.1f} %")
    total = len(data["routes"])
    return (f"| {name} | {total - len(laps_missed)} of {total} | {', '.join(laps_missed) or '-'} "
            f"| {total - len(laps_missed) - len(pace_missed)} of {total} | "
            f"{', '.join(pace_missed) or '-'} | {mean_vs_racing_line(data, line_laps):+.1f} % |")


def pace_table(name: str) -> None:
    """Per route where a ppo run misses its pace bar (5 % over the faster of the shipped
    ppo_generalist and racing_line), by how much, and whose lap sets the bar."""
    folder, _, stem = name.rpartition("/")
    data = read_time_trial(stem, HERE / folder)
    if data is None:
        raise SystemExit(f"--pace-table {name}: no time-trial JSON {HERE / folder / stem}.json; "
                         f"name a run as the table's first column does, e.g. ppo_s0")
    line_laps = racing_line_laps(data)
    ref_lap = {r["route"]: r["mean_lap_s"] for r in SHIPPED_PPO["routes"]}
    print(f"| route | {name} s | policy before s | racing_line s | over the bar | set by |")
    print("|---|---|---|---|---|---|")
    for route in sorted(data["routes"], key=lambda r: r["route"]):
        if route["laps"] < 0.95:
            print(f"| {route['route']} | {100 * route['laps']:.0f} % laps | | | | |")
            continue
        bar, whose = pace_bar(route, SHIPPED_PPO, True, line_laps)
        if route["mean_lap_s"] > 1.05 * bar:
            before = ref_lap.get(route["route"])
            line = line_laps.get(route["route"])
            print(f"| {route['route']} | {route['mean_lap_s']:.2f} | "
                  f"{f'{before:.2f}' if before else '-'} | {f'{line:.2f}' if line else '-'} | "
                  f"{100 * (route['mean_lap_s'] / bar - 1):+.1f} % | {whose} |")


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


def shipped_paces(path: Path) -> dict[str, float]:
    """Per shipped track, the mean lap against today's racing_line's (RACING_LINE_SHIPPED),
    from the route rows of an evaluate output on the shipped tracks (route, lap m, laps, %,
    mean s, ...)."""
    line_laps = {r["route"]: r["mean_lap_s"] for r in RACING_LINE_SHIPPED["routes"]}
    paces = {}
    for line in path.read_text().splitlines():
        cells = line.split()
        if len(cells) > 4 and cells[0] in line_laps and cells[3] == "%":
            try:
                paces[cells[0]] = 100 * (float(cells[4]) / line_laps[cells[0]] - 1)
            except ValueError:  # '-': no lap
                continue
    return paces


def alone_shipped(name: str) -> str:
    """The mean lap alone against racing_line's over the shipped tracks, from the time-trial
    evaluate output beside the JSON (`NAME_time_trial_shipped.txt`), or '-' without one:
    against today's racing_line (RACING_LINE_SHIPPED) unless --stored-baseline."""
    path = HERE / f"{name}_time_trial_shipped.txt"
    if not path.exists():
        return "-"
    if RACING_LINE_SHIPPED is not None:
        paces = shipped_paces(path)
        return f"{sum(paces.values()) / len(paces):+.1f} %" if paces else "-"
    for line in path.read_text().splitlines():
        if line.startswith("mean lap vs racing_line's:"):
            return line.split(":", 1)[1].split(" on average")[0].strip()
    return "-"


SHIPPED_PPO = json.loads((HERE.parent / "ppo_generalist.json").read_text())
RACING_LINE: dict | None = None  # today's racing_line alone on the routes; None: as recorded
RACING_LINE_SHIPPED: dict | None = None  # the same on the shipped tracks


def read_racing_line(option: str, path: Path, tracks: str) -> dict:
    if not path.exists():
        raise SystemExit(f"{option} {path}: no such file; write it with `h2h-racing evaluate "
                         f"--policy racing_line --track {tracks} --episodes 20 --json PATH`, "
                         f"or pass --stored-baseline")
    data = json.loads(path.read_text())
    if data.get("race_type") != "time_trial" or data.get("policy") != "racing_line":
        raise SystemExit(f"{option} {path}: expected racing_line's time trial (evaluate "
                         f"--policy racing_line), got policy {data.get('policy')!r}, race type "
                         f"{data.get('race_type')!r}")
    return data


def main() -> None:
    global RACING_LINE, RACING_LINE_SHIPPED
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--racing-line", type=Path, default=HERE / "racing_line.json",
                        help="racing_line alone on the routes, `evaluate --json` "
                             "(default: %(default)s)")
    parser.add_argument("--racing-line-shipped", type=Path,
                        default=HERE / "racing_line_shipped.json",
                        help="racing_line alone on the shipped tracks (`--track all`), for the "
                             "obstacle table's last column (default: %(default)s)")
    parser.add_argument("--stored-baseline", action="store_true",
                        help="hold the runs to the racing_line each JSON recorded instead "
                             "(default: off)")
    parser.add_argument("--pace-table", metavar="RUN",
                        help="print, per route, where RUN (e.g. ppo_s0) misses the ppo pace "
                             "bar instead of the tables (default: none)")
    parser.add_argument("--shipped", nargs="+", type=Path, metavar="TXT",
                        help="print, for each evaluate output on the shipped tracks (e.g. "
                             "ppo_s0_shipped.txt), its mean lap per track against today's "
                             "racing_line instead of the tables (default: none)")
    args = parser.parse_args()
    if not args.stored_baseline:
        RACING_LINE = read_racing_line("--racing-line", args.racing_line,
                                       "../shared/data/deepracer_tracks")
        RACING_LINE_SHIPPED = read_racing_line("--racing-line-shipped",
                                               args.racing_line_shipped, "all")
    if args.shipped:
        if RACING_LINE_SHIPPED is None:
            raise SystemExit("--shipped compares with today's racing_line: drop "
                             "--stored-baseline")
        for path in args.shipped:
            paces = shipped_paces(path)
            if not paces:
                raise SystemExit(f"--shipped {path}: no shipped track's row found; expected "
                                 f"the text `h2h-racing evaluate --track all` prints")
            print(f"{path}: {sum(paces.values()) / len(paces):+.1f} % on average; "
                  + ", ".join(f"{k} {v:+.1f} %" for k, v in paces.items()))
        return
    if args.pace_table:
        pace_table(args.pace_table)
        return
    print("| run | routes at >= 95 % laps | below | routes on target (laps and pace) | "
          "off pace | mean lap vs racing_line |")
    print("|---|---|---|---|---|---|")
    ppo_ref = SHIPPED_PPO
    if os.environ.get("PPO_SEED"):
        ppo_ref = load(f"ppo_s{os.environ['PPO_SEED']}")
    for seed in range(3):
        for row in (time_trial(f"ppo_s{seed}", SHIPPED_PPO, 0.05, with_racing_line=True),
                    time_trial(f"camera_s{seed}", ppo_ref, 0.10)):
            if row:
                print(row)
    for folder in sorted(p for p in HERE.iterdir() if p.is_dir()):
        for path in sorted(folder.glob("*.json")):
            if path.stem.startswith("obstacle"):  # its rows are the second table's
                continue
            # The shipped tracks (ppo_more/) or the route-like procedural ones (ppo_step6/,
            # racing_line's too), not the routes.
            if path.stem.endswith(("_shipped", "_routelike")):
                continue
            camera = path.stem.startswith("camera")
            row = time_trial(path.stem, ppo_ref if camera else SHIPPED_PPO,
                             0.10 if camera else 0.05, folder, with_racing_line=not camera)
            if row:
                print(row.replace(f"| {path.stem} |", f"| {folder.name}/{path.stem} |", 1))
    print()
    print("| run | object avoidance: routes on target | head to bot: routes on target | "
          "alone on the shipped tracks vs racing_line |")
    print("|---|---|---|---|")
    for seed in ("shipped/obstacle_generalist",
                 *(f"{folder}/obstacle_s{seed}" for folder in ("obstacle", "obstacle_fine")
                   for seed in range(3)),
                 *(f"step8/obstacle8_s{seed}" for seed in range(3)),
                 *(f"step9_obstacle/obstacle9_s{seed}" for seed in range(3)),
                 *(f"step10_obstacle/obstacle10_s{seed}" for seed in range(3))):
        row = obstacles(seed)
        if row:
            print(row)


if __name__ == "__main__":
    main()
