"""League commands of ``h2h-racing``.

    h2h-racing tournament --players A,B,C --tracks T1,T2 [--races 2] [--laps 2] [--field-races N]
                          [--schedule round_robin|swiss] [--league FILE] [--name NAME]
                          [--backend inprocess|local|ray] [--workers N] [--address ADDR]
    h2h-racing league train --config recommended|smoke|FILE.toml [--out runs/leagues/NAME]
                          [--minutes M [--this-run]] [--backend ...]
    h2h-racing league table --league FILE [--context PREFIX]
    h2h-racing league plot --league FILE [--out DIR]

Ctrl-C stops ``tournament`` and ``league train`` with one line that says what was kept and
the command that resumes, exit status 130 (``league.stopping``).
"""

from __future__ import annotations

import argparse
import functools
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from h2h_racing.common.progress import NO_ETA, Progress, add_progress_flag, progress_mode

DEFAULT_LEAGUE = "runs/league.sqlite"
LEAGUE_FILE_HELP = "league file (SQLite; a league run writes runs/leagues/NAME/league.sqlite)"


def _names(text: str) -> tuple[str, ...]:
    names = tuple(p.strip() for p in text.split(",") if p.strip())
    if not names:
        raise argparse.ArgumentTypeError(f"expected comma-separated names, got {text!r}")
    return names


def _backend(args: argparse.Namespace) -> Any:
    from h2h_racing.league.backends import make_backend

    return make_backend(args.backend, workers=args.workers, address=args.address)


def _add_backend_args(parser: argparse.ArgumentParser, default: str) -> None:
    parser.add_argument("--backend", default=default, choices=["inprocess", "local", "ray"],
                        help="where races and learners run: this process, local worker "
                             "processes, or Ray (needs h2h-racing[ray])")
    parser.add_argument("--workers", type=int, default=None,
                        help="worker processes (local) or CPUs of a local Ray (default: all)")
    parser.add_argument("--address", default=None,
                        help="Ray cluster address for --backend ray (default: a local Ray, which "
                             "listens on 127.0.0.1 only)")


def _races_progress(progress: Progress) -> Callable[[int, int], None]:
    """``run_tournament``'s progress callback drawing ``progress``.

    The ETA is extrapolated from the races finished after the first ones: those carry the
    workers' start and the kernels' compilation, which made ETAs several times the real time;
    until then the line says ``starting`` and shows none. The bar stops at 99 % when every
    race is run (the ratings are fitted then): the command shows 100 % when it is done.
    """
    first: list[float] = []  # (time, races) when the first job finished

    def show(done: int, total: int) -> None:
        now = time.monotonic()
        eta: float = NO_ETA
        info = f"{done}/{total} races"
        if done >= total:
            info += ", rating"
        elif not first or done <= first[1]:
            if done and not first:
                first[:] = [now, done]
            info += ", starting"
        else:
            eta = (total - done) * (now - first[0]) / (done - first[1])
        progress.update(min(done / max(total, 1), 0.99), info, eta=eta)

    return show


def _exit_on_sigterm() -> None:
    """Turn SIGTERM (``kill PID``) into ``SystemExit``, so that the command's ``finally`` closes
    its backend: by default Python dies at once and leaves the worker processes running their
    jobs with no parent. Matches stored so far stay stored either way."""
    import signal

    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))


def _league_errors(command: Callable[[argparse.Namespace], int]
                   ) -> Callable[[argparse.Namespace], int]:
    """``command`` with an unusable league file (empty, corrupt, newer, not a league) reported
    as one clear line on stderr and exit status 2, not a traceback."""

    @functools.wraps(command)
    def run(args: argparse.Namespace) -> int:
        import sqlite3

        from h2h_racing.league.store import LeagueStoreError

        try:
            return command(args)
        except LeagueStoreError as err:
            print(f"h2h-racing: error: {err}", file=sys.stderr)
        except sqlite3.DatabaseError as err:
            where = getattr(args, "league", None) or "the league file"
            print(f"h2h-racing: error: cannot read {where} (SQLite says: {err}); restore it "
                  f"from a copy or give another league file", file=sys.stderr)
        return 2

    return run


def _cmd_tournament(args: argparse.Namespace) -> int:
    from h2h_racing.league.backends import JobsStopped
    from h2h_racing.league.stopping import EXIT_INTERRUPTED, StopSwitch, resume_command
    from h2h_racing.league.store import LeagueStore
    from h2h_racing.league.tournament import TournamentConfig, run_tournament

    _exit_on_sigterm()
    counts = [0, 0]  # races stored, races in all (the progress callback's last call)
    resume = resume_command(args, args.parser, ("tournament",))

    def hard_stop() -> str:
        return (f"tournament {args.name!r} stopped at once (Ctrl-C): {counts[0]} of "
                f"{counts[1] or '?'} races stored in {args.league}; to play the rest: {resume}")

    config = TournamentConfig(players=args.players, tracks=args.tracks, races=args.races,
                              laps=args.laps, field_races=args.field_races,
                              schedule=args.schedule, rounds=args.rounds, seed=args.seed,
                              name=args.name, anchor=args.anchor)
    start = time.perf_counter()
    progress = Progress("tournament", mode=progress_mode(args))
    show = _races_progress(progress)

    def shown(done: int, total: int) -> None:
        counts[:] = [done, total]
        show(done, total)

    stop = StopSwitch(hard_stop=hard_stop).install()
    backend = None
    try:
        backend = _backend(args)
        with LeagueStore(args.league) as store:
            report = run_tournament(config, store, backend, progress=shown,
                                    stop=lambda: stop.requested)
        progress.update(1.0, f"{counts[0]}/{counts[1]} races, rated", force=True)
    except JobsStopped:
        report = None
    finally:
        if backend is not None:
            backend.close(now=stop.requested)
        progress.close()
        stop.uninstall()
    if report is None:
        print(f"tournament {config.name!r} stopped (Ctrl-C): {counts[0]} of "
              f"{counts[1] or '?'} races stored in {args.league} (a race is stored whole or "
              f"not at all); to play the rest: {resume}", file=sys.stderr)
        return EXIT_INTERRUPTED
    print(f"tournament {config.name!r}: {report.ran} races run, {report.skipped} already in "
          f"{args.league}, {time.perf_counter() - start:.1f} s")
    print(report.table())
    return 0


def _cmd_league_train(args: argparse.Namespace) -> int:
    import dataclasses

    from h2h_racing.config.shipped import resolve_config
    from h2h_racing.league.config import LeagueConfig
    from h2h_racing.league.selfplay import STOP_FILE, League
    from h2h_racing.league.stopping import EXIT_INTERRUPTED, StopSwitch, resume_command
    from h2h_racing.league.store import LeagueStore
    from h2h_racing.league.table import table_text

    _exit_on_sigterm()
    try:
        config = LeagueConfig.from_toml(resolve_config(args.config, "league"))
    except FileNotFoundError as err:
        raise SystemExit(f"error: {err}") from None
    if args.minutes is not None:
        config = dataclasses.replace(config, minutes=args.minutes)
    if args.rounds is not None:
        config = dataclasses.replace(config, max_rounds=args.rounds)
    default_out = Path("runs") / "leagues" / config.name
    if args.seed is not None:
        config = dataclasses.replace(config, seed=args.seed)
        default_out = default_out.with_name(f"{config.name}-seed{args.seed}")
    out = Path(args.out or default_out)
    out.mkdir(parents=True, exist_ok=True)
    league: League | None = None

    def resume() -> str:
        # The same budget, on the league's clock: a --this-run budget becomes the league
        # time it ends at.
        minutes = args.minutes
        if args.this_run and league is not None:
            minutes = round(league.display.budget / 60.0 + 0.05, 1)
        return resume_command(args, args.parser, ("league", "train"),
                              {"out": str(out), "minutes": minutes, "this_run": False})

    def hard_stop() -> str:
        line = (f"[league {config.name}] stopped at once (Ctrl-C): the running round's "
                f"training and running races are lost, everything stored in "
                f"{out / 'league.sqlite'} is kept; to resume: {resume()}")
        if league is not None:
            league.display.log(line)
        return line

    backend = _backend(args)
    stop = StopSwitch(out / STOP_FILE, hard_stop=hard_stop).install()
    try:
        league = League(config, out, backend=backend, progress=progress_mode(args),
                        this_run=args.this_run, stop=stop)
        ended = "stopped" if stop.requested else league.run()
    except BaseException:
        if league is not None:
            league.close()
        else:
            backend.close(now=True)
        stop.uninstall()
        raise
    league.close()  # race jobs a stop or the budget left running are not waited for
    stop.uninstall()
    path = out / "league.sqlite"
    if ended == "stopped":
        line = (f"[league {config.name}] stopped (Ctrl-C) after {league.display.elapsed() / 60:.1f}"
                f" min of league time: kept every finished round in {path}"
                + (f", and {league.kept}" if league.kept else "") + f"; to resume: {resume()}")
        league.display.log(line)
        print(line, file=sys.stderr)
        return EXIT_INTERRUPTED
    with LeagueStore(path) as store:
        rounds = int(store.meta().get("round", "0"))
        steps = sum(float(v) for k, v in store.meta().items() if k.endswith(".steps"))
        snapshots = len(store.players("snapshot"))
        table = table_text(store) if store.count_matches() else ""
    why = {"rounds": "its round cap",
           "budget": "its time budget (a larger --minutes, the league's total, or --this-run "
                     "trains on)"}[ended]
    summary = (f"league {config.name!r} in {out}: ended at {why}, {rounds} rounds, "
               f"{league.display.elapsed() / 60:.1f} min, {steps / 1e6:.2f} M steps, "
               f"{snapshots} snapshots" + (f"; {league.kept}" if league.kept else ""))
    league.display.log(summary)
    print(summary)
    if table:
        print(f"ratings of every player in {path} (the table `h2h-racing league table "
              f"--league {path}` prints):")
        print(table)
    return 0


def _cmd_league_table(args: argparse.Namespace) -> int:
    from h2h_racing.league.store import LeagueStore
    from h2h_racing.league.table import table_text

    if not Path(args.league).is_file():
        raise FileNotFoundError(f"league file not found: {args.league}")
    with LeagueStore(args.league) as store:
        text = table_text(store, context=args.context, anchor=args.anchor, n_boot=args.boot)
    print(text)
    return 0


def _cmd_league_plot(args: argparse.Namespace) -> int:
    from h2h_racing.league.plots import plot_ratings, plot_standings, plot_win_matrix
    from h2h_racing.league.ratings import pairwise
    from h2h_racing.league.store import LeagueStore
    from h2h_racing.league.table import table_rows

    if not Path(args.league).is_file():
        raise FileNotFoundError(f"league file not found: {args.league}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with LeagueStore(args.league) as store:
        history = store.rating_history("bradley_terry")
        players = {p.name: p for p in store.players()}
        races = store.races(context_prefix=args.context)
        # The ratings of `league table` (every player of every race), not a second fit.
        rows = table_rows(store, context=args.context)[0]
        meta = store.meta()
    if rows:
        history = {row.player: [(0.0, row.rating, row.low, row.high)] for row in rows}
    written = []
    if history:
        path = out / "ratings.png"
        trained = any(p.parent or p.kind == "learner" for p in players.values())
        if rows and trained:
            steps = {name: float(meta.get(f"{name}.steps", "0")) for name in players}
            plot_ratings(table_series(rows, players, steps), path)
        elif trained:  # ratings stored by an older league, without races to rate
            plot_ratings(rating_series(history, players), path)
        else:
            # A tournament: nobody trained, so the ratings have no time axis to be drawn over.
            plot_standings({name: rows[-1][1:] for name, rows in history.items()}, path)
        written.append(path)
    if races:
        shown = matrix_players(races, history, players, args.players)
        races = [{p: place for p, place in race.items() if p in shown} for race in races]
        players, wins, games = pairwise([race for race in races if len(race) > 1], shown)
        with_games = games > 0
        rate = wins / games.clip(min=1)
        rate[~with_games] = float("nan")
        path = out / "win_matrix.png"
        plot_win_matrix(players, rate, games, path)
        written.append(path)
    if not written:
        raise ValueError(f"{args.league} has no ratings or matches to plot")
    for path in written:
        print(path)
    return 0


def table_series(rows: Any, players: dict[str, Any], steps: dict[str, float]
                 ) -> dict[str, list[tuple[float, float, float, float]]]:
    """Every player of ``league table``'s ``rows`` over training time: one line per learner,
    through its snapshots at the training steps they were frozen at and ending at the learner
    itself at its ``steps`` now; the other players (anchors, policies) flat across."""
    series: dict[str, list[tuple[float, float, float, float]]] = {}
    flat = []
    for row in rows:
        player = players.get(row.player)
        point = (row.rating, row.low, row.high)
        if player is not None and player.parent:
            series.setdefault(player.parent, []).append((float(player.training_steps), *point))
        elif player is not None and player.kind == "learner":
            series.setdefault(player.name, []).append((steps.get(player.name, 0.0), *point))
        else:
            flat.append((row.player, point))
    end = max((x for points in series.values() for x, *_ in points), default=0.0) or 1.0
    for name, point in flat:
        series[name] = [(0.0, *point), (end, *point)]
    return {name: sorted(points) for name, points in series.items()}


def matrix_players(races: list[dict[str, int]],
                   history: dict[str, list[tuple[float, float, float, float]]],
                   players: dict[str, Any], limit: int) -> list[str]:
    """The rows of the win matrix: the ``limit`` best players by their latest fitted rating
    (by score when the league has no ratings), plus every scripted anchor, best first."""
    if limit < 2:
        raise ValueError(f"--players must be >= 2 (rows of the win matrix), got {limit}")
    names = sorted({name for race in races for name in race})
    if history:
        key = {name: history[name][-1][1] if name in history else -math.inf for name in names}
    else:
        score = {name: 0.0 for name in names}
        for race in races:
            for name, place in race.items():
                # Share of the other cars beaten in this race (ties count half).
                others = [p for other, p in race.items() if other != name]
                score[name] += sum(1.0 if place < p else 0.5 if place == p else 0.0
                                   for p in others) / max(len(others), 1)
        key = score
    ranked = sorted(names, key=lambda name: (-key[name], name))
    anchors = {name for name in names
               if getattr(players.get(name), "kind", None) == "scripted"}
    keep = set(ranked[:limit]) | anchors
    return [name for name in ranked if name in keep]


def rating_series(history: dict[str, list[tuple[float, float, float, float]]],
                  players: dict[str, Any]) -> dict[str, list[tuple[float, float, float, float]]]:
    """Rating over training time, one line per learner lineage.

    Each snapshot contributes its latest fitted rating at the training steps it was frozen at
    (``Player.training_steps``), on the line of its parent learner; players without a parent
    (anchors, tournament entrants) are flat lines across the plotted range.
    """
    latest = {name: rows[-1] for name, rows in history.items()}
    series: dict[str, list[tuple[float, float, float, float]]] = {}
    for name, (_, rating, low, high) in latest.items():
        player = players.get(name)
        if player is not None and player.parent:
            series.setdefault(player.parent, []).append(
                (float(player.training_steps), rating, low, high))
    end = max((x for rows in series.values() for x, *_ in rows), default=1.0)
    for name, (_, rating, low, high) in latest.items():
        player = players.get(name)
        if player is None or not player.parent:
            series[name] = [(0.0, rating, low, high), (end, rating, low, high)]
    return {name: sorted(rows) for name, rows in series.items()}


def add_commands(sub: Any) -> None:
    """Add ``tournament`` and ``league`` to the ``h2h-racing`` sub-command parsers."""
    tour = sub.add_parser("tournament", help="round robin or Swiss tournament; prints ratings")
    tour.add_argument("--players", type=_names, required=True,
                      help="comma-separated drivers (scripted ones with any settings, "
                           "racing_line:grip_factor=0.7: a player of its own), shipped "
                           "policies or policy.pt files")
    tour.add_argument("--tracks", type=_names, default="speedway",
                      help="comma-separated tracks")
    tour.add_argument("--races", type=int, default=2,
                      help="seeds per pairing and track (each raced in both seat orders)")
    tour.add_argument("--laps", type=int, default=2, help="laps per race")
    tour.add_argument("--field-races", type=int, default=0,
                      help="seeds of races with every player on the grid (every rotation)")
    tour.add_argument("--schedule", default="round_robin", choices=["round_robin", "swiss"],
                      help="every pairing (round_robin) or rounds of pairings of players with "
                           "similar scores (swiss, for large fields)")
    tour.add_argument("--rounds", type=int, default=0, help="Swiss rounds (0: log2(P) + 1)")
    tour.add_argument("--seed", type=int, default=0,
                      help="first seed of the races' start points")
    tour.add_argument("--name", default="default", help="tournament name in the league file")
    tour.add_argument("--anchor", default=None,
                      help="player rated 1000 (default: racing_line when it plays)")
    tour.add_argument("--league", default=DEFAULT_LEAGUE, help="league file (SQLite)")
    _add_backend_args(tour, "local")
    add_progress_flag(tour)
    tour.set_defaults(func=_league_errors(_cmd_tournament), parser=tour)

    league = sub.add_parser("league", help="self-play league: train, table, plot")
    lsub = league.add_subparsers(dest="league_command", required=True)
    train = lsub.add_parser("train", help="run a self-play league (needs h2h-racing[train])")
    train.add_argument("--config", required=True, metavar="LEAGUE.toml|NAME",
                       help="league config: a TOML file, or a shipped one by name: recommended "
                            "(the 30-minute league that made the best racer's recipe) or smoke "
                            "(a one-minute look)")
    train.add_argument("--out", default=None, help="league folder (default runs/leagues/NAME)")
    train.add_argument("--minutes", type=float, default=None,
                       help="the league's time budget in minutes, counted over all its runs "
                            "(a resumed league goes on until its total reaches it; default: "
                            "the config's minutes)")
    train.add_argument("--this-run", action="store_true",
                       help="count --minutes (or the config's minutes) from this run's start "
                            "instead of over all the league's runs (default: off)")
    train.add_argument("--rounds", type=int, default=None,
                       help="override the round cap (default: the config's max_rounds)")
    train.add_argument("--seed", type=int, default=None,
                       help="override the training seed; the default folder becomes "
                            "runs/leagues/NAME-seedSEED (default: the config's seed)")
    _add_backend_args(train, "local")
    add_progress_flag(train)
    train.set_defaults(func=_league_errors(_cmd_league_train), parser=train)
    table = lsub.add_parser("table", help="print the standings of a league file")
    table.add_argument("--league", default=DEFAULT_LEAGUE, help=LEAGUE_FILE_HELP)
    table.add_argument("--context", default=None,
                       help="only matches whose context starts with this (e.g. tournament:x)")
    table.add_argument("--anchor", default=None,
                       help="player rated 1000 (default: the league's rating anchor, else "
                            "racing_line; the mean is 1000 when it did not race)")
    table.add_argument("--boot", type=int, default=200, help="bootstrap resamples")
    table.set_defaults(func=_league_errors(_cmd_league_table))
    plot = lsub.add_parser("plot", help="PNGs of the ratings (over training in a league) and "
                                        "the win matrix")
    plot.add_argument("--league", default=DEFAULT_LEAGUE, help=LEAGUE_FILE_HELP)
    plot.add_argument("--context", default=None, help="matches of the win matrix (prefix)")
    plot.add_argument("--out", default="plots", help="output folder")
    plot.add_argument("--players", type=int, default=16,
                      help="rows of the win matrix: the N best-rated players plus the scripted "
                           "anchors")
    plot.set_defaults(func=_league_errors(_cmd_league_plot))
