"""The ``h2h-racing`` command line.

    h2h-racing race [--track speedway] [--drivers racing_line,pure_pursuit] [...]
                    [--race-type head_to_bot [--bots 3] [--bot-speed 0.75]]
                    [--save race.rrd] [--spawn] [--serve [--serve-seconds N]]
    h2h-racing camera [--track speedway] [--car 1] [--steps 20] [--out camera.png]
    h2h-racing train --out runs/NAME [--config TRAIN.toml|NAME] [--track T]
                     [--obs state|camera|camera_only|camera_lidar]
                     [--opponents none|D] [--rules training|race] [--reward TERM=W,...]
                     [--init P] [--max-std S] [--teacher P] [--eval-every 50]
                     [--race-type object_avoidance [--boxes 6] | head_to_bot [--bots 3]]
    h2h-racing evaluate --policy runs/NAME/policy.pt [--track T] [--episodes 20]
    h2h-racing evaluate --policy P --track FOLDER|FILE FILE ...|all [--episodes 20]
                        [--race-type object_avoidance|head_to_bot [--races 20] [--laps 3]]
                        [--jobs N] [--json FILE]
    h2h-racing evaluate --policy P [--track T1,T2|FOLDER|all]
                        [--against DRIVERS | --field DRIVERS] [--races 20] [--laps 3]
                        [--start both|behind|front] [--gap M] [--rolling M/S]
    h2h-racing export POLICY [--format onnx,torchscript] [--out DIR]
    h2h-racing tracks [list] [--track T1,FILE,FOLDER]
    h2h-racing tracks show NAME [--out NAME.png]
    h2h-racing tracks import FILE [--name NAME] [--scale S | --scale L,W] [--reverse] [--out F]
    h2h-racing tournament --players A,B,C [--tracks T1,T2] [--races 2] [--backend local|ray]
    h2h-racing league train --config recommended|smoke|FILE.toml
    h2h-racing league table | plot --league FILE
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from h2h_racing.cli.help import DESCRIPTION, DRIVERS_HELP, EPILOG, SEED_HELP, ArgumentParser
from h2h_racing.training.cli_train import warn_trained_alone
from h2h_racing.training.cli import add_training_commands
from h2h_racing.config.rules import RACE_TYPES
from h2h_racing.common.progress import add_progress_flag, progress_mode


def _scale(text: str) -> float | tuple[float, float]:
    parts = [float(p) for p in text.split(",")]
    if len(parts) == 1:
        return parts[0]
    if len(parts) == 2:
        return (parts[0], parts[1])
    raise argparse.ArgumentTypeError(f"--scale takes S or L,W (length and width factors), "
                                     f"got {text!r}")


TRACKS_NOTE = ("reference s: the minimum-time reference lap, an estimate: a point mass on the "
               "racing line's path at the car's full grip, acceleration and braking (a real car "
               "lags it); racing_line s: the lap of that driver's own speed profile on the same "
               "path (60 % of the grip in corners), also an estimate (it drives 9-20 % slower "
               "from a standing start); margin %: how much slower racing_line's profile is")


def _track_sources(text: str | None) -> list[str]:
    """The tracks ``--track`` names: the catalogue (None), else each comma-separated item, a
    folder standing for its .json, .npy and .csv files."""
    from h2h_racing.track.io import list_tracks

    if text is None:
        return list_tracks()
    found: list[str] = []
    for item in (part.strip() for part in text.split(",") if part.strip()):
        folder = Path(item)
        if folder.is_dir():
            files = sorted(str(p) for p in folder.iterdir()
                           if p.suffix.lower() in (".json", ".npy", ".csv"))
            if not files:
                raise ValueError(f"--track {item!r}: the folder holds no .json, .npy or .csv "
                                 f"track file")
            found += files
        else:
            found.append(item)
    return found


def _cmd_tracks_list(args: argparse.Namespace) -> int:
    from h2h_racing.policies.lap_times import TrackLaps, track_laps
    from h2h_racing.track.io import load_track

    tracks = [load_track(name) for name in _track_sources(args.track)]
    width = max(16, *(len(t.name) for t in tracks))
    print(f"{TrackLaps.header(width)}  description")
    for track in tracks:
        print(f"{track_laps(track).row(width)}  {track.description}".rstrip(), flush=True)
    print(TRACKS_NOTE)
    return 0


def _cmd_tracks_show(args: argparse.Namespace) -> int:
    import cv2

    from h2h_racing.viz.render import SpectatorRenderer
    from h2h_racing.track.io import load_track

    track = load_track(args.name)
    out = Path(args.out or f"{track.name or Path(args.name).stem}.png")
    img = SpectatorRenderer(track, width=args.width).background
    cv2.imwrite(str(out), cv2.cvtColor(img, cv2.COLOR_RGB2BGR))
    print(f"{track.name}: lap {track.length:.2f} m, width {track.width.min():.2f}-"
          f"{track.width.max():.2f} m -> {out}")
    return 0


def _cmd_tracks_import(args: argparse.Namespace) -> int:
    import dataclasses

    from h2h_racing.track.io import load_track, save_track

    name = args.name or Path(args.file).stem
    track = dataclasses.replace(load_track(args.file, scale=args.scale, reverse=args.reverse),
                                name=name)
    out = Path(args.out or f"{name}.json")
    save_track(track, out)
    print(f"imported {args.file}: lap {track.length:.2f} m, width {track.width.min():.2f}-"
          f"{track.width.max():.2f} m, {len(track.centre)} points -> {out}")
    return 0


def _cmd_race(args: argparse.Namespace) -> int:
    from h2h_racing.match import FALLBACK_CODEC, run_race
    from h2h_racing.track.io import list_tracks

    drivers = [d.strip() for d in args.drivers.split(",") if d.strip()]
    tracks = list_tracks() if args.track == "all" else [args.track]
    warn_trained_alone(drivers, others=len(drivers) - 1)
    for flag, value in (("--video", args.video), ("--save", args.save),
                        ("--spawn", args.spawn), ("--serve", args.serve),
                        ("--simtrace", args.simtrace)):
        if value and len(tracks) > 1:
            raise ValueError(f"{flag} records one race: give a single --track, not 'all'")
    if args.serve_seconds is not None and not args.serve:
        raise ValueError("--serve-seconds needs --serve")
    if args.serve_seconds is not None and args.serve_seconds < 0:
        raise ValueError(f"--serve-seconds must be >= 0, got {args.serve_seconds}")
    progress = progress_mode(args) == "auto"
    overrides = {}
    if args.model_metadata:
        from h2h_racing.deepracer.metadata import load_action_space

        overrides = load_action_space(args.model_metadata)
    if args.bots is not None:
        overrides["num_bots"] = args.bots
    if args.bot_speed is not None:
        overrides["bot_speed"] = args.bot_speed
    for i, track in enumerate(tracks):
        result = run_race(track=track, drivers=drivers, race_type=args.race_type,
                          laps=args.laps, seed=args.seed, video=args.video, save=args.save,
                          spawn=args.spawn, serve=args.serve, web_port=args.web_port,
                          grpc_port=args.grpc_port, progress=progress,
                          simtrace=args.simtrace, reward_function=args.reward_function,
                          reward_time_limit=args.reward_time_limit,
                          **overrides)
        print(("\n" if i else "") + result.table, flush=True)
        if result.bots:
            print(f"{result.bots} bot cars at {result.bot_speed:g} m/s; a bot ran into a car "
                  f"ahead {result.bot_pauses} time(s) (every bot then paused)", flush=True)
        if result.rewards is not None:
            totals = ", ".join(f"car_{k} ({d}) {r:.2f}" for k, (d, r)
                               in enumerate(zip(result.drivers, result.rewards)))
            print(f"total DeepRacer reward ({args.reward_function}): {totals}", flush=True)
        if result.simtrace:
            print(f"simtrace -> {', '.join(result.simtrace)} (load one with deepracer-utils: "
                  f"DeepRacerLog(FOLDER).load_evaluation_trace())", flush=True)
        if result.video:
            note = ("" if result.video_codec != FALLBACK_CODEC else
                    ": OpenCV here has no H.264 encoder, and browsers do not play this one; "
                    "name the file .webm for VP8, or convert it with ffmpeg -i "
                    f"{result.video} -c:v libx264 race_h264.mp4")
            print(f"video -> {Path(result.video).resolve()} ({result.video_codec}{note})",
                  flush=True)
        if args.save:
            print(f"recording -> {args.save} (open it with: rerun {args.save})", flush=True)
        if result.viewer is not None:
            until = ("Ctrl-C to stop" if args.serve_seconds is None
                     else f"for {args.serve_seconds:g} s")
            print(f"web viewer: {result.viewer.viewer_url} ({until})", flush=True)
            result.viewer.serve_until(args.serve_seconds)
    return 0


def _cmd_camera(args: argparse.Namespace) -> int:
    import h2h_racing
    from h2h_racing.policies import make_driver
    from h2h_racing.sensors.camera import save_camera_png

    names = [d.strip() for d in args.drivers.split(",") if d.strip()]
    drivers = [make_driver(d, seed=args.seed + car) for car, d in enumerate(names)]
    if not 0 <= args.car < len(drivers):
        raise ValueError(f"--car must be in [0, {len(drivers) - 1}] (one car per driver), "
                         f"got {args.car}")
    env = h2h_racing.parallel_env(track=args.track, num_cars=len(drivers), grid="fixed")
    env.reset(seed=args.seed)
    for driver in drivers:
        driver.reset(env.core)
    for _ in range(args.steps):
        if not env.agents:
            break
        env.step({agent: drivers[i].act(env.core, i)[0]
                  for i, agent in enumerate(env.possible_agents) if agent in env.agents})
    out = save_camera_png(env.core, args.car, args.out, scale=args.scale)
    print(f"car_{args.car}'s camera after {args.steps} steps on {env.track.name} -> {out}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of the ``h2h-racing`` command."""
    parser = ArgumentParser(prog="h2h-racing", description=DESCRIPTION, epilog=EPILOG)
    sub = parser.add_subparsers(dest="command", required=True)

    race = sub.add_parser("race", help="race drivers (scripted or trained) and print the results "
                                          "table")
    race.add_argument("--track", default="speedway",
                      help="catalogue name, track file, or 'all' for every catalogue track")
    race.add_argument("--drivers", default="racing_line,pure_pursuit", help=DRIVERS_HELP)
    race.add_argument("--race-type", default="head_to_head",
                      choices=RACE_TYPES,
                      help="race preset: laps, penalties, obstacles or bot cars (DeepRacer's "
                           "race types)")
    race.add_argument("--bots", type=int, default=None, metavar="N",
                      help="scripted bot cars (default: 3 in head_to_bot, else 0); they are not "
                           "in the results table")
    race.add_argument("--bot-speed", type=float, default=None, metavar="M/S",
                      help="speed of the bot cars (default 0.75 m/s)")
    race.add_argument("--laps", type=int, default=None, help="lap target (default: preset)")
    race.add_argument("--seed", type=int, default=0, help=SEED_HELP)
    race.add_argument("--video", default=None, metavar="RACE.mp4|RACE.webm",
                      help="write a top-down video of the race here: .mp4 is H.264 where "
                           "OpenCV has the encoder (pip's has not: MPEG-4 Part 2 then, which "
                           "browsers do not play), .webm is VP8, which browsers play")
    race.add_argument("--save", default=None, metavar="RACE.rrd",
                      help="write a rerun recording of the race (needs h2h-racing[viz])")
    race.add_argument("--spawn", action="store_true",
                      help="watch the race in the native rerun viewer (needs a display)")
    race.add_argument("--serve", action="store_true",
                      help="serve the race in the rerun web viewer on 127.0.0.1 until Ctrl-C")
    race.add_argument("--serve-seconds", type=float, default=None, metavar="N",
                      help="with --serve: stop serving after N seconds instead of at Ctrl-C")
    race.add_argument("--web-port", type=int, default=9090, help="web viewer port (--serve)")
    race.add_argument("--grpc-port", type=int, default=9876, help="rerun server port (--serve)")
    race.add_argument("--simtrace", default=None, metavar="DIR",
                      help="write DeepRacer simtrace CSV + metrics JSON here (one folder per car)")
    race.add_argument("--reward-function", default=None, metavar="REWARD.py",
                      help="a DeepRacer reward_function file: print each car's total reward")
    race.add_argument("--reward-time-limit", type=float, default=None, metavar="SECONDS",
                      help="stop with an error when one call of the reward function runs longer "
                           "than this (default: no limit)")
    race.add_argument("--model-metadata", default=None, metavar="model_metadata.json",
                      help="race with a DeepRacer action space (as the policy was trained)")
    add_progress_flag(race)
    race.set_defaults(func=_cmd_race)

    add_training_commands(sub)

    camera = sub.add_parser("camera", help="save what a car's camera sees as a PNG")
    camera.add_argument("--track", default="speedway", help="catalogue name or track file")
    camera.add_argument("--drivers", default="pure_pursuit,racing_line",
                        help="comma-separated drivers, one per car (car 0 first on the grid)")
    camera.add_argument("--car", type=int, default=1, help="whose camera (car index)")
    camera.add_argument("--steps", type=int, default=20, help="steps to drive before the shot")
    camera.add_argument("--seed", type=int, default=0, help=SEED_HELP)
    camera.add_argument("--scale", type=int, default=4, help="enlarge the 160x120 image")
    camera.add_argument("--out", default="camera.png", help="PNG path")
    camera.set_defaults(func=_cmd_camera)

    tracks_help = ("list the tracks with their length, width and lap-time estimates (the "
                   "minimum-time reference lap and racing_line's profile lap; point masses on "
                   "the racing line's path, which a real car lags)")
    tracks = sub.add_parser("tracks", help="list (the default), preview and import tracks",
                            description=tracks_help[:1].upper() + tracks_help[1:] + "; "
                            "'tracks show' previews a track, 'tracks import' converts one.")
    track_help = ("comma-separated catalogue names, track files (.json, .npy, .csv) or folders "
                  "of them (default: every catalogue track)")
    tracks.add_argument("--track", default=None, help=track_help)
    tracks.set_defaults(func=_cmd_tracks_list)
    tsub = tracks.add_subparsers(dest="tracks_command")
    tlist = tsub.add_parser("list", help=tracks_help)
    tlist.add_argument("--track", default=None, help=track_help)
    tlist.set_defaults(func=_cmd_tracks_list)
    show = tsub.add_parser("show", help="write a PNG preview of a track")
    show.add_argument("name", help="catalogue name or track file")
    show.add_argument("--out", default=None, help="PNG path (default: NAME.png)")
    show.add_argument("--width", type=int, default=720, help="image width in pixels")
    show.set_defaults(func=_cmd_tracks_show)
    imp = tsub.add_parser("import", help="convert a DeepRacer .npy or centre-line .csv track")
    imp.add_argument("file", help="a .npy (DeepRacer route) or .csv (x_m,y_m,w_tr_right_m,"
                                  "w_tr_left_m) file")
    imp.add_argument("--name", default=None, help="track name (default: file stem)")
    imp.add_argument("--scale", type=_scale, default=None,
                     help="scale factor S, or L,W for separate length and width factors")
    imp.add_argument("--reverse", action="store_true", help="drive the track the other way")
    imp.add_argument("--out", default=None, help="output .json (default: NAME.json)")
    imp.set_defaults(func=_cmd_tracks_import)

    from h2h_racing.league.cli import add_commands

    add_commands(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except (ValueError, FileNotFoundError, ImportError) as exc:
        print(f"h2h-racing: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # python -m h2h_racing.cli.command (or h2h_racing.cli)
    sys.exit(main())
