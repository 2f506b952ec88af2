"""The league store: players, matches and rating history in one SQLite file per league.

Why SQLite: a league is written by one driver process for hours while workers come and go;
it must survive ``kill -9`` at any moment without losing or double-counting a match, and a
user must be able to open it with any SQLite tool. The file runs in WAL mode and every write
is one transaction, so a killed process leaves either the whole match or none of it. Each
match carries a ``key`` that its scheduler derives from what the match is (tournament,
track, players, seat order, seed); the key is UNIQUE, so recording a match twice (a retried
worker, a resumed tournament) stores it once.

Schema (version 1):

- ``meta(key, value)``: ``schema_version``, ``created``, ``name``, free-form settings.
- ``players``: ``name`` (unique), ``kind`` (``scripted`` driver, ``policy`` file,
  ``snapshot`` of a learner, ``learner``), ``role`` (``main``, ``main_exploiter``,
  ``league_exploiter``, ``anchor``...), ``checkpoint`` (driver name or file path),
  ``checkpoint_sha256``, ``parent`` (the learner a snapshot came from), ``created`` (unix
  seconds), ``training_steps`` (agent steps the player had trained for).
- ``matches``: ``key`` (unique), ``context`` (``tournament:<name>``, ``training``...),
  ``track``, ``race_type``, ``laps``, ``seed``, ``start`` (arc position of the grid [m]),
  ``steps``, ``status`` (``done`` or ``failed``; only ``done`` matches count), ``error``,
  ``created``.
- ``match_cars``: one row per car of a match: ``seat`` (car index), ``grid_slot``,
  ``player``, ``position`` (1 = winner), ``finished``, ``laps``, ``total_time`` and
  ``best_lap`` [s] (NULL when none), ``collisions``, ``crashes`` (contacts the car caused),
  ``overtakes``, ``penalties``, ``penalty_time`` [s], ``off_tracks``.
- ``ratings``: rating history: ``computed`` (unix seconds), ``method`` (``bradley_terry`` or
  ``elo``), ``player``, ``rating``, ``low``/``high`` (confidence interval, NULL for Elo),
  ``training_steps`` (league clock the rating belongs to), ``matches`` (matches it used).

The schema and the checks made on opening a file live in :mod:`h2h_racing.league.store_schema`,
the players in :mod:`h2h_racing.league.players`.
"""

from __future__ import annotations

import math
import os
import re
import secrets
import sqlite3
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

# Player, player_for, file_sha256, SCHEMA_VERSION and LeagueStoreError are re-exported here,
# where the league's users import them from.
from h2h_racing.league.players import (
    PLAYER_KINDS,
    Player,
    file_sha256,  # noqa: F401 (re-exported)
    player_for,  # noqa: F401 (re-exported)
)
from h2h_racing.league.store_schema import (
    SCHEMA_VERSION,  # noqa: F401 (re-exported)
    LeagueStoreError,
    check_league_file,
    check_not_empty,
    create_schema,
)

MATCH_STATUSES = ("done", "failed")
"""Allowed match statuses; only ``done`` matches enter ratings and payoffs."""


@dataclass(frozen=True)
class CarResult:
    """One car's outcome in a match."""

    seat: int
    """Car index in the race."""
    player: str
    position: int
    """Finishing position, 1 = winner."""
    finished: bool
    laps: int
    total_time: float = math.inf
    """Finish time [s]; inf when the car did not finish."""
    best_lap: float = math.inf
    """Best valid lap [s]; inf when none."""
    collisions: int = 0
    crashes: int = 0
    """Contacts this car was judged to have caused."""
    overtakes: int = 0
    penalties: int = 0
    penalty_time: float = 0.0
    """Penalty time served [s]."""
    off_tracks: int = 0
    grid_slot: int | None = None


@dataclass(frozen=True)
class MatchRecord:
    """A finished (or failed) match."""

    key: str
    """Unique identity of the match, chosen by its scheduler."""
    track: str
    race_type: str
    laps: int
    seed: int
    cars: tuple[CarResult, ...]
    context: str = ""
    start: float | None = None
    """Arc position of the grid [m]."""
    steps: int = 0
    status: str = "done"
    error: str | None = None
    created: float = field(default_factory=time.time)

    @property
    def places(self) -> dict[str, float]:
        """Player -> finishing position (the input of ``h2h_racing.league.ratings``)."""
        return {car.player: float(car.position) for car in self.cars}


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def _bounds(interval: tuple[float, float] | None) -> tuple[float | None, float | None]:
    return (None, None) if interval is None else (float(interval[0]), float(interval[1]))


def _inf_if_none(value: float | None) -> float:
    return math.inf if value is None else float(value)


class LeagueStore:
    """One league's SQLite file.

    Args:
        path: The ``.sqlite`` file; created (with its folder) when missing.
        name: League name written into a new file's ``meta``.

    Raises:
        LeagueStoreError: The file is empty (0 bytes), damaged, not a league file, or was
            written by a newer schema.
    """

    def __init__(self, path: str | Path, name: str | None = None) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if not self.path.exists():
            _create_league_file(self.path, name or self.path.stem)
        check_not_empty(self.path)
        # isolation_level=None: we issue BEGIN/COMMIT ourselves, so every write is exactly
        # one transaction. timeout: wait for another process's write lock instead of failing.
        try:
            self._db = sqlite3.connect(self.path, isolation_level=None, timeout=60.0)
        except sqlite3.Error as err:
            raise LeagueStoreError(f"cannot open the league file {self.path} (SQLite says: "
                                   f"{err}); give a file path in a writable folder") from None
        self._db.row_factory = sqlite3.Row
        try:
            self._open(name)
        except BaseException:
            self._db.close()
            raise

    def _open(self, name: str | None) -> None:
        check_league_file(self._db, self.path)
        self._db.execute("PRAGMA journal_mode = WAL")
        # FULL: a committed match survives even a power cut, not only a killed process.
        self._db.execute("PRAGMA synchronous = FULL")
        self._db.execute("PRAGMA foreign_keys = ON")
        with self.transaction() as db:
            create_schema(db, name or self.path.stem)

    def close(self) -> None:
        """Close the file."""
        self._db.close()

    def __enter__(self) -> LeagueStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @contextmanager
    def transaction(self) -> Iterator[sqlite3.Connection]:
        """One write transaction: everything inside commits together or not at all."""
        self._db.execute("BEGIN IMMEDIATE")
        try:
            yield self._db
        except BaseException:
            self._db.execute("ROLLBACK")
            raise
        self._db.execute("COMMIT")

    # ---------------------------------------------------------------- meta

    def meta(self) -> dict[str, str]:
        """The ``meta`` table as a dict."""
        return {row["key"]: row["value"] for row in self._db.execute("SELECT * FROM meta")}

    def update_meta(self, key: str, update: Callable[[str | None], str | None]) -> None:
        """Read ``meta[key]`` and write ``update(value)`` in one write transaction.

        ``BEGIN IMMEDIATE`` takes the file's write lock before the read, so two processes
        checking and claiming one key (a tournament's settings) take turns: the second reads
        what the first wrote. ``update`` gets None when the key is missing, returns the new
        value or None to leave it, and may raise to refuse (nothing is written).
        """
        with self.transaction() as db:
            row = db.execute("SELECT value FROM meta WHERE key = ?", (key,)).fetchone()
            value = update(None if row is None else row["value"])
            if value is not None:
                db.execute("INSERT OR REPLACE INTO meta VALUES (?, ?)", (key, value))

    def set_meta(self, key: str, value: str) -> None:
        """Set one ``meta`` entry."""
        self.set_metas({key: value})

    def set_metas(self, values: dict[str, str]) -> None:
        """Set several ``meta`` entries in one transaction."""
        with self.transaction() as db:
            db.executemany("INSERT OR REPLACE INTO meta VALUES (?, ?)",
                           [(k, str(v)) for k, v in values.items()])

    # ------------------------------------------------------------- players

    def add_player(self, player: Player, metas: dict[str, str] | None = None) -> Player:
        """Add ``player``; adding the same player again is a no-op.

        ``metas`` are written in the same transaction as the player (a league's snapshot and
        its learner's counters): a kill leaves both or neither.

        Raises:
            ValueError: Unknown kind, unknown parent, or a different player of that name
                already in the league.
        """
        if player.kind not in PLAYER_KINDS:
            raise ValueError(f"player {player.name!r}: kind must be one of {PLAYER_KINDS}, got "
                             f"{player.kind!r}")
        if not player.name:
            raise ValueError("player name must not be empty")
        existing = self.player(player.name)
        if existing is not None:
            same = (existing.kind, existing.checkpoint, existing.checkpoint_sha256) == (
                player.kind, player.checkpoint, player.checkpoint_sha256)
            if not same:
                raise ValueError(
                    f"{self.path} already has a different player named {player.name!r} "
                    f"({existing.kind}, {existing.checkpoint}, sha256 "
                    f"{existing.checkpoint_sha256}); now {player.kind}, {player.checkpoint}, "
                    f"sha256 {player.checkpoint_sha256}: a file that changed since, or "
                    f"another file of that name. Give another league file (--league), or "
                    f"copy the file to a name of its own")
            return existing
        if player.parent is not None and self.player(player.parent) is None:
            raise ValueError(f"player {player.name!r}: parent {player.parent!r} is not in the "
                             f"league; add the parent first")
        created = player.created or time.time()
        with self.transaction() as db:
            db.execute("INSERT INTO players VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                       (player.name, player.kind, player.role, player.checkpoint,
                        player.checkpoint_sha256, player.parent, created,
                        int(player.training_steps)))
            if metas:
                db.executemany("INSERT OR REPLACE INTO meta VALUES (?, ?)",
                               [(str(k), str(v)) for k, v in metas.items()])
        return self.player(player.name)  # type: ignore[return-value]

    def player(self, name: str) -> Player | None:
        """The player called ``name``, or None."""
        row = self._db.execute("SELECT * FROM players WHERE name = ?", (name,)).fetchone()
        return None if row is None else Player(**dict(row))

    def players(self, kind: str | None = None) -> list[Player]:
        """All players (of one ``kind``), oldest first."""
        sql = "SELECT * FROM players"
        rows = (self._db.execute(sql + " WHERE kind = ? ORDER BY created, name", (kind,))
                if kind else self._db.execute(sql + " ORDER BY created, name"))
        return [Player(**dict(row)) for row in rows]

    # ------------------------------------------------------------- matches

    def record_match(self, match: MatchRecord) -> bool:
        """Store ``match`` in one transaction; return False when its key was already done.

        A ``failed`` match of the same key is replaced by a later ``done`` one, so a retried
        match is stored once.

        Raises:
            ValueError: Unknown status, a player not in the league, or duplicate seats.
        """
        if match.status not in MATCH_STATUSES:
            raise ValueError(f"match {match.key!r}: status must be one of {MATCH_STATUSES}, "
                             f"got {match.status!r}")
        seats = [car.seat for car in match.cars]
        if len(set(seats)) != len(seats):
            raise ValueError(f"match {match.key!r}: duplicate seats {seats}")
        with self.transaction() as db:
            row = db.execute("SELECT id, status FROM matches WHERE key = ?",
                             (match.key,)).fetchone()
            if row is not None:
                if row["status"] == "done" or match.status != "done":
                    return False
                db.execute("DELETE FROM match_cars WHERE match_id = ?", (row["id"],))
                db.execute("DELETE FROM matches WHERE id = ?", (row["id"],))
            known = {r[0] for r in db.execute("SELECT name FROM players")}
            missing = sorted({car.player for car in match.cars} - known)
            if missing:
                raise ValueError(f"match {match.key!r}: players {missing} are not in the league; "
                                 f"add them with add_player first")
            cursor = db.execute(
                "INSERT INTO matches (key, context, track, race_type, laps, seed, start, steps, "
                "status, error, created) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (match.key, match.context, match.track, match.race_type, int(match.laps),
                 int(match.seed), match.start, int(match.steps), match.status, match.error,
                 match.created))
            db.executemany(
                "INSERT INTO match_cars VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                [(cursor.lastrowid, car.seat, car.grid_slot, car.player, car.position,
                  int(car.finished), car.laps, _finite_or_none(car.total_time),
                  _finite_or_none(car.best_lap), car.collisions, car.crashes, car.overtakes,
                  car.penalties, car.penalty_time, car.off_tracks) for car in match.cars])
        return True

    def done_keys(self, prefix: str = "") -> set[str]:
        """Keys of the ``done`` matches whose key starts with ``prefix``."""
        rows = self._db.execute(
            "SELECT key FROM matches WHERE status = 'done' AND substr(key, 1, ?) = ?",
            (len(prefix), prefix))
        return {row[0] for row in rows}

    def count_matches(self, context: str | None = None, status: str = "done") -> int:
        """Number of matches with ``status`` (in one ``context``)."""
        if context is None:
            row = self._db.execute("SELECT COUNT(*) FROM matches WHERE status = ?", (status,))
        else:
            row = self._db.execute(
                "SELECT COUNT(*) FROM matches WHERE status = ? AND context = ?",
                (status, context))
        return int(row.fetchone()[0])

    def matches(self, context: str | None = None, context_prefix: str | None = None,
                status: str = "done") -> list[MatchRecord]:
        """Matches in the order they were recorded (optionally of one context or prefix);
        ``races`` gives them in canonical order."""
        sql = "SELECT * FROM matches WHERE status = ?"
        args: list[Any] = [status]
        if context is not None:
            sql += " AND context = ?"
            args.append(context)
        if context_prefix is not None:
            sql += " AND substr(context, 1, ?) = ?"
            args += [len(context_prefix), context_prefix]
        rows = self._db.execute(sql + " ORDER BY id", args).fetchall()
        cars: dict[int, list[CarResult]] = {row["id"]: [] for row in rows}
        for car in self._db.execute("SELECT * FROM match_cars ORDER BY match_id, seat"):
            if car["match_id"] in cars:
                values = dict(car)
                del values["match_id"]
                values["finished"] = bool(values["finished"])
                values["total_time"] = _inf_if_none(values["total_time"])
                values["best_lap"] = _inf_if_none(values["best_lap"])
                cars[car["match_id"]].append(CarResult(**values))
        return [MatchRecord(key=row["key"], track=row["track"], race_type=row["race_type"],
                            laps=row["laps"], seed=row["seed"], cars=tuple(cars[row["id"]]),
                            context=row["context"], start=row["start"], steps=row["steps"],
                            status=row["status"], error=row["error"], created=row["created"])
                for row in rows]

    def races(self, context: str | None = None,
              context_prefix: str | None = None) -> list[dict[str, float]]:
        """Finishing places of every ``done`` match in canonical order (ratings input).

        The sequential Elo and the bootstrap read the order of the races. Recorded order
        depends on which worker finished first and on where a resumed run picked up, so the
        same matches would rate differently; ordered by ``canonical_key`` they rate the same
        whatever order they were stored in.
        """
        matches = self.matches(context=context, context_prefix=context_prefix)
        return [m.places for m in sorted(matches, key=lambda m: canonical_key(m.key))]

    # ------------------------------------------------------------- ratings

    def record_ratings(self, method: str, ratings: dict[str, float],
                       intervals: dict[str, tuple[float, float]] | None = None,
                       training_steps: int = 0, matches: int = 0) -> None:
        """Append one row per player to the rating history, in one transaction."""
        now = time.time()
        intervals = intervals or {}
        with self.transaction() as db:
            db.executemany(
                "INSERT INTO ratings (computed, method, player, rating, low, high, "
                "training_steps, matches) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                [(now, method, player, float(value), *_bounds(intervals.get(player)),
                  int(training_steps), int(matches))
                 for player, value in ratings.items()])

    def rating_history(self, method: str = "bradley_terry"
                       ) -> dict[str, list[tuple[float, float, float, float]]]:
        """Player -> [(training_steps, rating, low, high)] in recorded order (NaN bounds
        when no interval was stored)."""
        history: dict[str, list[tuple[float, float, float, float]]] = {}
        for row in self._db.execute("SELECT * FROM ratings WHERE method = ? ORDER BY id",
                                    (method,)):
            low = math.nan if row["low"] is None else row["low"]
            high = math.nan if row["high"] is None else row["high"]
            history.setdefault(row["player"], []).append(
                (float(row["training_steps"]), row["rating"], low, high))
        return history


def _create_league_file(path: Path, name: str) -> None:
    """Create a new league file at ``path`` whole, or leave the one another process made.

    SQLite creates a 0-byte file at ``connect`` and writes the schema later, and a 0-byte
    league file is refused (``check_not_empty``): a second process opening the path in between
    was told to delete a file the first was writing. The schema is written to a file of its
    own beside ``path``, closed, and hard-linked to ``path`` (atomic, and refused when ``path``
    exists): the path holds nothing or a whole league file. Of two processes creating one
    league at once, the second's link fails and it opens the first's file.
    """
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.new")
    try:
        db = sqlite3.connect(tmp, isolation_level=None)
    except sqlite3.Error as err:
        raise LeagueStoreError(f"cannot create the league file {path} (SQLite says: {err}); "
                               f"give a file path in a writable folder") from None
    try:
        try:
            check_league_file(db, tmp)
            db.execute("PRAGMA journal_mode = WAL")
            db.execute("BEGIN IMMEDIATE")
            create_schema(db, name)
            db.execute("COMMIT")
        finally:
            db.close()  # the last connection: SQLite folds the -wal file into the database
        try:
            os.link(tmp, path)
        except FileExistsError:
            pass  # another process created the league first: open its file
    finally:
        for leftover in (tmp, tmp.with_name(tmp.name + "-wal"), tmp.with_name(tmp.name + "-shm")):
            leftover.unlink(missing_ok=True)


def canonical_key(key: str) -> tuple[tuple[tuple[int, int | str], ...], str]:
    """Sort key of a match key: its digit runs compare as numbers, so ``race=2`` comes before
    ``race=10`` and ``round=9`` before ``round=10`` (schedule order, not text order); the key
    itself breaks ties (``race=01`` and ``race=1``)."""
    parts = tuple((0, int(part)) if part.isdigit() else (1, part)
                  for part in re.split(r"(\d+)", key) if part)
    return parts, key
