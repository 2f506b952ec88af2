"""The training subcommands of ``h2h-racing``: ``evaluate`` and ``export`` here, ``train`` in
``h2h_racing.training.cli_train``.

They need the ``train`` extra only when they run; ``h2h_racing.cli.command`` adds them to its
parser.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import sys
from collections.abc import Callable
from pathlib import Path

from h2h_racing.cli.help import SEED_HELP, SPEC_HELP
from h2h_racing.training.cli_train import _train_config  # noqa: F401 (tests import it from here)
from h2h_racing.training.cli_train import add_train_command, warn_trained_alone
from h2h_racing.common.progress import Progress, add_progress_flag, progress_mode


def _cmd_export(args: argparse.Namespace) -> int:
    from h2h_racing.training.export import export_policy, parse_formats
    from h2h_racing.policies.trained import shipped_policies

    formats = parse_formats(args.format)
    if args.out is not None:
        out = Path(args.out)
    elif args.policy in shipped_policies():
        out = Path("exports") / args.policy
    else:
        out = Path(args.policy).parent
    result = export_policy(args.policy, out, formats=formats, samples=args.samples,
                           seed=args.seed)
    print(result.summary())
    print(f"inputs and outputs described in {out / 'policy.export.json'}")
    return 0


def _cmd_evaluate(args: argparse.Namespace) -> int:
    from h2h_racing.training.evaluate import Evaluation, evaluate

    items = [args.track] if isinstance(args.track, str) else list(args.track)
    if args.against and args.field:
        print("error: give --against (two-car races, one opponent at a time) or --field (all "
              "the opponents on the grid at once), not both", file=sys.stderr)
        return 2
    if (args.against or args.field) and args.race_type != "time_trial":
        print(f"error: --race-type {args.race_type} races the policy alone with boxes or bots; "
              "--against and --field race it against other cars (head to head): give one of "
              "them", file=sys.stderr)
        return 2
    if args.field or args.against:
        from h2h_racing.training.evaluate_routes import route_sources

        args.track = [source.source for source in route_sources(items).routes]
        return _evaluate_field(args) if args.field else _evaluate_head_to_head(args)
    parts = [part for item in items for part in item.split(",") if part.strip()]
    if (len(parts) != 1 or parts[0] == "all" or Path(parts[0]).is_dir()
            or args.race_type != "time_trial" or args.json is not None or args.jobs is not None):
        from h2h_racing.training.evaluate_routes_report import evaluate_routes_command

        return evaluate_routes_command(
            items, args.policy, race_type=args.race_type, episodes=args.episodes,
            races=args.races, laps=args.laps, seed=args.seed, baseline=args.baseline,
            jobs=args.jobs, json_path=args.json, progress=progress_mode(args))
    args.track = parts[0]
    print(f"{args.track}: {args.episodes} one-lap attempts from start points spread round the "
          "lap (training rules: an infraction ends the attempt)")
    drivers = [d for d in [args.policy, *args.baseline.split(",")] if d]
    width = max(28, *map(len, drivers))
    print(Evaluation.header(width))
    for driver in drivers:
        print(evaluate(driver, args.track, episodes=args.episodes, seed=args.seed).row(width))
    return 0


def _time_trials(seed: int) -> Callable[[str, str], float]:
    """``lap(driver, track)``: the driver's time-trial lap alone on the track
    (``time_trial_lap``: one batched core of 4 attempts), each pair measured once."""
    from h2h_racing.training.evaluate import time_trial_lap

    @functools.cache
    def lap(driver: str, track: str) -> float:
        return time_trial_lap(driver, track, seed=seed)

    return lap


def _evaluate_head_to_head(args: argparse.Namespace) -> int:
    from h2h_racing.training.evaluate import (combine, head_to_head, head_to_head_header,
                                            head_to_head_row)
    from h2h_racing.policies import make_driver

    if args.start == "both" and (args.races < 2 or args.races % 2):
        print(f"error: --races must be an even number >= 2 with --start both (every start in "
              f"both seat orders), got {args.races}", file=sys.stderr)
        return 2
    tracks = args.track
    policy = make_driver(args.policy, seed=args.seed)
    grid = {"both": "every start point in both seat orders", "behind": "the policy starts "
            "behind", "front": "the policy starts in front"}[args.start]
    gap = f", {args.gap:g} m grid gap" if args.gap is not None else ""
    gap += f", rolling start at {args.rolling:g} m/s" if args.rolling else ""
    print(f"{args.policy}: {args.races} two-car races of {args.laps} laps per track and opponent "
          f"(race rules: 5 s penalties), {grid}{gap}")
    opponents = args.against.split(",")
    warn_trained_alone([args.policy, *opponents], others=1)
    width = max(16, *map(len, opponents))
    print(head_to_head_header(width))
    results: dict[str, list] = {}
    jobs = [(opponent, track) for opponent in opponents for track in tracks]
    lap = _time_trials(args.seed)
    bar = Progress("evaluate", mode=progress_mode(args))
    for k, (opponent, track) in enumerate(jobs):
        def show(share: float, finished: int, k: int = k, opponent: str = opponent,
                 track: str = track) -> None:
            bar.update((k + share) / len(jobs), f"{finished}/{args.races} races vs {opponent} "
                                                f"on {track} ({k + 1}/{len(jobs)})")

        try:
            result = head_to_head(policy, make_driver(opponent, seed=args.seed + 1), track,
                                  races=args.races, laps=args.laps, seed=args.seed,
                                  start=args.start, gap=args.gap, rolling=args.rolling,
                                  progress=show)
            result = dataclasses.replace(result, time_trial_laps=(
                lap(args.policy, track), lap(opponent, track)))
        except ValueError as err:
            bar.close()
            print(f"error: {err}", file=sys.stderr)
            return 2
        results.setdefault(opponent, []).append(result)
        bar.clear()
        print(head_to_head_row(result, opponent, width), flush=True)
    bar.close()
    for opponent, rows in results.items():
        total = combine(rows)
        won = 100 * total.wins[0] / total.races
        print(f"{head_to_head_row(total, opponent, width)} ({won:.0f} % won)")
    print("won: the policy's wins (of all races, from the slot behind, from the front slot); "
          "lap s: each car's time-trial lap alone (the policy's / the opponent's; the mean of "
          "4 one-lap attempts from start points spread round the lap, an infraction ends one; "
          "summed over tracks in the total); margin %: how much faster the policy's lap is "
          "(negative: slower); per race: the policy's / the opponent's; a defence: the other "
          "car was under 1 m behind for 2 s, faster at some moment, and dropped back without "
          "passing")
    return 0


def _evaluate_field(args: argparse.Namespace) -> int:
    from h2h_racing.policies import make_driver
    from h2h_racing.training.evaluate_field import (combine_fields, field_header, field_race,
                                                  field_rows)

    if args.start != "both":
        print("error: --start applies to --against; --field rotates the policy over every "
              "grid slot", file=sys.stderr)
        return 2
    names = [name for name in args.field.split(",") if name]
    warn_trained_alone([args.policy, *names], others=len(names))
    tracks = args.track
    gap = f", {args.gap:g} m grid gap" if args.gap is not None else ""
    gap += f", rolling start at {args.rolling:g} m/s" if args.rolling else ""
    print(f"{args.policy} with {', '.join(names)}: {args.races} {len(names) + 1}-car races of "
          f"{args.laps} laps per track (race rules: 5 s penalties), every start point in "
          f"every rotation of the grid{gap}")
    print(field_header())
    results = []
    lap = _time_trials(args.seed)
    laps = {name: 0.0 for name in [args.policy, *names]}
    bar = Progress("evaluate", mode=progress_mode(args))
    for k, track in enumerate(tracks):
        def show(share: float, finished: int, k: int = k, track: str = track) -> None:
            bar.update((k + share) / len(tracks), f"{finished}/{args.races} races on {track} "
                                                  f"({k + 1}/{len(tracks)})")

        try:
            opponents = [make_driver(name, seed=args.seed + 1 + i)
                         for i, name in enumerate(names)]
            result = field_race(make_driver(args.policy, seed=args.seed), opponents, track,
                                races=args.races, laps=args.laps, seed=args.seed,
                                gap=args.gap, rolling=args.rolling, progress=show)
        except ValueError as err:
            bar.close()
            print(f"error: {err}", file=sys.stderr)
            return 2
        results.append(result)
        bar.clear()
        print("\n".join(field_rows(result)), flush=True)
        track_laps = {name: lap(name, track) for name in laps}
        print(_pace_line(track, args.policy, names, track_laps), flush=True)
        laps = {name: laps[name] + track_laps[name] for name in laps}
    bar.close()
    total = combine_fields(results)
    print("\n".join(field_rows(total, slots=True)))
    print(_pace_line("all", args.policy, names, laps))
    wins = ", ".join(f"{name} {won}" for name, won in zip(total.drivers, total.wins))
    print(f"races won: {wins}")
    print("slot: the policy's grid slot (1 is the front); mean place, won, per race and "
          "finished are the policy's; lap s: each car's time-trial lap alone (the mean of 4 "
          "one-lap attempts, summed over tracks in 'all'), with how much faster the policy's "
          "is (negative: slower)")
    return 0


def _pace_line(track: str, policy: str, opponents: list[str], laps: dict[str, float]) -> str:
    """``lap s on TRACK: POLICY 6.14; racing_line 6.14 (+0.0 %); ...``: each car's time-trial
    lap, and how much faster the policy's is than each opponent's (``evaluate --field``)."""
    from h2h_racing.training.evaluate import lap_text, margin_text, pace_margin

    others = [f"{name} {lap_text(laps[name])} "
              f"({margin_text(pace_margin(laps[policy], laps[name]))} %)"
              for name in dict.fromkeys(opponents)]
    where = "all tracks" if track == "all" else track
    return f"lap s on {where}: {policy} {lap_text(laps[policy])}; " + "; ".join(others)


def add_training_commands(sub: argparse._SubParsersAction) -> None:
    """Add ``train`` (``h2h_racing.training.cli_train``), ``evaluate`` and ``export`` to the
    ``h2h-racing`` subparsers."""
    add_train_command(sub)

    evaluate = sub.add_parser("evaluate", help="a policy's lap completion and lap times alone "
                                                  "(on one track or every route of a folder), "
                                                  "its races with boxes or bots (--race-type), "
                                                  "or its head-to-head record (--against)")
    evaluate.add_argument("--policy", required=True,
                          help="policy.pt, a shipped policy or a scripted driver name; "
                               + SPEC_HELP)
    evaluate.add_argument("--track", nargs="+", default="speedway", metavar="TRACK",
                          help="catalogue name or track file; or several (space- or "
                               "comma-separated), a folder (its .json, .npy and .csv files) or "
                               "'all' (the catalogue): then every route is evaluated, one row "
                               "each, with a summary (routes at >= 95 %% laps, the worst "
                               "routes, laps against the --baseline's and the reference lap); "
                               "a file that cannot be evaluated gets one line and the others "
                               "go on (exit status 1) (default: speedway)")
    evaluate.add_argument("--episodes", type=int, default=20,
                          help="one-lap attempts, from start points spread round the lap "
                               "(default: 20)")
    evaluate.add_argument("--seed", type=int, default=0, help=SEED_HELP + " (default: 0)")
    evaluate.add_argument("--baseline", default="racing_line",
                          help="comma-separated drivers evaluated on the same start points "
                               "(scripted ones with any settings); over several routes only "
                               "the first, whose mean lap each route's is compared with; '' "
                               "for none (default: racing_line)")
    evaluate.add_argument("--race-type", default="time_trial",
                          choices=("time_trial", "object_avoidance", "head_to_bot"),
                          help="time_trial: one-lap attempts alone (--episodes); "
                               "object_avoidance (DeepRacer's 6 boxes, re-drawn every race) or "
                               "head_to_bot (3 bots at 0.75 m/s): --races races of --laps laps "
                               "per track from the start line under race rules, with races "
                               "finished, crashes and resets per lap against the targets "
                               ">= 90 %% finished, <= 0.5 crashes and <= 1 reset per lap "
                               "(default: time_trial)")
    evaluate.add_argument("--jobs", type=int, default=None, metavar="N",
                          help="worker processes over several routes (each route runs in one); "
                               "1 runs them in this process (default: one per core, at most "
                               "one per route)")
    evaluate.add_argument("--json", default=None, metavar="PATH",
                          help="also write the figures (one object per route, the files not "
                               "evaluated and the summary) to this JSON file; its folder must "
                               "exist (default: none)")
    evaluate.add_argument("--against", default=None, metavar="DRIVERS",
                          help="comma-separated opponents (scripted ones with any settings: "
                               "racing_line:grip_factor=0.7): race the policy head to head "
                               "against each (2-car races; --track may be a comma list or "
                               "'all'), each row with both cars' time-trial laps alone and "
                               "the policy's pace margin")
    evaluate.add_argument("--races", type=int, default=20,
                          help="races per track and opponent with --against (even with --start "
                               "both: both seat orders of every start), per track with --field "
                               "or --race-type (default: 20)")
    evaluate.add_argument("--start", default="both", choices=["both", "behind", "front"],
                          help="the policy's grid slot with --against: both (alternating on "
                               "the same start points), behind (every win is a pass) or front "
                               "(default: both)")
    evaluate.add_argument("--gap", type=float, default=None, metavar="METRES",
                          help="distance the car behind starts behind the other [m of track] "
                               "with --against (between consecutive grid slots with --field); "
                               "see --rolling (default: the grid's 0.75)")
    evaluate.add_argument("--rolling", type=float, default=0.0, metavar="M/S",
                          help="start speed of every car with --against or --field [m/s]: a "
                               "rolling start, the cars already moving along the track, --gap "
                               "apart; at most the car's max speed; 0 is a standing start")
    evaluate.add_argument("--field", default=None, metavar="DRIVERS",
                          help="comma-separated opponents (scripted ones with any settings) "
                               "raced with the policy all at once (3-car races and more), every "
                               "start point in every rotation of the grid (--races a multiple "
                               "of the cars); results by the policy's grid slot, and each car's "
                               "time-trial lap")
    evaluate.add_argument("--laps", type=int, default=3,
                          help="laps per race with --against, --field or --race-type "
                               "(default: 3)")
    add_progress_flag(evaluate)
    evaluate.set_defaults(func=_cmd_evaluate)

    export = sub.add_parser("export", help="export a trained policy to ONNX and TorchScript, "
                                           "checked against the original")
    export.add_argument("policy", help="a shipped policy name or a policy.pt")
    export.add_argument("--format", default="onnx,torchscript",
                        help="comma-separated formats: onnx, torchscript")
    export.add_argument("--out", default=None, metavar="DIR",
                        help="output folder (default: the policy.pt's folder, or "
                             "exports/NAME for a shipped policy)")
    export.add_argument("--samples", type=int, default=64,
                        help="sample observations the exports are checked on")
    export.add_argument("--seed", type=int, default=0, help="seed of the sample races")
    export.set_defaults(func=_cmd_export)
