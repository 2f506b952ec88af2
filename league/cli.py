"""League commands of ``h2h-racing``.

    h2h-racing tournament --players A,B,C --tracks T1,T2 [--races 2] [--laps 2] [--field-races N]
                          [--schedule round_robin|swiss] [--league FILE] [--name NAME]
                          [--backend inprocess|local|ray] [--workers N] [--address ADDR]
    h2h-racing league train --config recommended|smoke|FILE.toml [--out runs/leagues/NAME]
                          [--minutes M] [--backend ...]
    h2h-racing league table --league FILE [--context PREFIX]
    h2h-racing league plot --league FILE [--out DIR]
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

from h2h_racing.progress import Progress, add_progress_flag, progress_mode

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
    """``run_tournament``'s progress callback drawing ``progress``."""
    return lambda done, total: progress.update(done / max(total, 1), f"{done}/{total} races")


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
    from h2h_racing.league.store import LeagueStore
    from h2h_racing.league.tournament import TournamentConfig, run_tournament

    _exit_on_sigterm()

    config = TournamentConfig(players=args.players, tracks=args.tracks, races=args.races,
                              laps=args.laps, field_races=args.field_races,
                              schedule=args.schedule, rounds=args.rounds, seed=args.seed,
                              name=args.name, anchor=args.anchor)
    backend = _backend(args)
    start = time.perf_counter()
    progress = Progress("tournament", mode=progress_mode(args))
    try:
        with LeagueStore(args.league) as store:
            report = run_tournament(config, store, backend, progress=_races_progress(progress))
    finally:
        backend.close()
        progress.close()
    print(f"tournament {config.name!r}: {report.ran} races run, {report.skipped} already in "
          f"{args.league}, {time.perf_counter() - start:.1f} s")
    print(report.table())
    return 0


def _cmd_league_train(args: argparse.Namespace) -> int:
    import dataclasses

    from h2h_racing.league.config import LeagueConfig
    from h2h_racing.league.selfplay import League

    _exit_on_sigterm()
    from h2h_racing.configs import resolve_config

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
    league = League(config, out, backend=_backend(args), progress=progress_mode(args))
    try:
        league.run()
        print(f"league {config.name!r} in {out}: {league.league_steps() / 1e6:.2f} M steps, "
              f"{len(league.snapshots())} snapshots")
        from h2h_racing.league.ratings import format_standings

        rows = league.standings()
        print(format_standings(rows))
        print(_trends(league.store, rows))
    finally:
        league.close()
    return 0


def _cmd_league_table(args: argparse.Namespace) -> int:
    from h2h_racing.league.ratings import format_standings, standings
    from h2h_racing.league.store import LeagueStore

    if not Path(args.league).is_file():
        raise FileNotFoundError(f"league file not found: {args.league}")
    with LeagueStore(args.league) as store:
        races = store.races(context_prefix=args.context)
        if not races:
            raise ValueError(f"{args.league} has no finished matches"
                             + (f" with context {args.context!r}" if args.context else ""))
        players = {p for race in races for p in race}
        anchor = args.anchor if args.anchor in players else None
        # Canonical race order and the fixed bootstrap seed: the table is the same whatever
        # order the matches were stored in, and equals the one `tournament` printed.
        rows = standings(races, anchor=anchor, n_boot=args.boot)
        trends = _trends(store, rows)
    print(f"{len(races)} races" + (f", anchor {anchor} = 1000" if anchor else ""))
    print(format_standings(rows))
    print(trends)
    return 0


def _trends(store: Any, rows: Any) -> str:
    """The snapshot-rating trends of each learner lineage, as text ('' without snapshots)."""
    from h2h_racing.league.ratings import format_trends, rating_trends

    snapshots = [(p.name, p.parent or p.name, p.training_steps)
                 for p in store.players("snapshot")]
    trends = rating_trends(snapshots, {row.player: row.rating for row in rows})
    if not trends:
        return ""
    return ("\nsnapshot ratings over training (rank correlation of rating with training "
            "steps):\n" + format_trends(trends))


def _cmd_league_plot(args: argparse.Namespace) -> int:
    from h2h_racing.league.plots import plot_ratings, plot_standings, plot_win_matrix
    from h2h_racing.league.ratings import pairwise
    from h2h_racing.league.store import LeagueStore

    if not Path(args.league).is_file():
        raise FileNotFoundError(f"league file not found: {args.league}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with LeagueStore(args.league) as store:
        history = store.rating_history("bradley_terry")
        players = {p.name: p for p in store.players()}
        races = store.races(context_prefix=args.context)
    written = []
    if history:
        path = out / "ratings.png"
        if any(player.parent for player in players.values()):
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
    tour.set_defaults(func=_league_errors(_cmd_tournament))

    league = sub.add_parser("league", help="self-play league: train, table, plot")
    lsub = league.add_subparsers(dest="league_command", required=True)
    train = lsub.add_parser("train", help="run a self-play league (needs h2h-racing[train])")
    train.add_argument("--config", required=True, metavar="LEAGUE.toml|NAME",
                       help="league config: a TOML file, or a shipped one by name: recommended "
                            "(the 30-minute league that made the best racer's recipe) or smoke "
                            "(a one-minute look)")
    train.add_argument("--out", default=None, help="league folder (default runs/leagues/NAME)")
    train.add_argument("--minutes", type=float, default=None,
                       help="override the time budget (default: the config's minutes)")
    train.add_argument("--rounds", type=int, default=None,
                       help="override the round cap (default: the config's max_rounds)")
    train.add_argument("--seed", type=int, default=None,
                       help="override the training seed; the default folder becomes "
                            "runs/leagues/NAME-seedSEED (default: the config's seed)")
    _add_backend_args(train, "local")
    add_progress_flag(train)
    train.set_defaults(func=_league_errors(_cmd_league_train))
    table = lsub.add_parser("table", help="print the standings of a league file")
    table.add_argument("--league", default=DEFAULT_LEAGUE, help=LEAGUE_FILE_HELP)
    table.add_argument("--context", default=None,
                       help="only matches whose context starts with this (e.g. tournament:x)")
    table.add_argument("--anchor", default="racing_line", help="player rated 1000")
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
