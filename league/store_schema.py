"""The league file's schema and the checks made when one is opened.

The tables are described in :mod:`h2h_racing.league.store`. A file is refused, with an error
that says what to do, when it is empty (0 bytes), damaged (SQLite's ``quick_check``), an
SQLite file of something else, or written by a newer schema version.
"""

from __future__ import annotations

import sqlite3
import time
from pathlib import Path

SCHEMA_VERSION = 1
"""Version of the schema this module writes; files of a newer version are refused."""

_SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (
    key TEXT PRIMARY KEY,
    value TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS players (
    name TEXT PRIMARY KEY,
    kind TEXT NOT NULL CHECK (kind IN ('scripted', 'policy', 'snapshot', 'learner')),
    role TEXT,
    checkpoint TEXT,
    checkpoint_sha256 TEXT,
    parent TEXT REFERENCES players(name),
    created REAL NOT NULL,
    training_steps INTEGER NOT NULL DEFAULT 0 CHECK (training_steps >= 0)
);
CREATE TABLE IF NOT EXISTS matches (
    id INTEGER PRIMARY KEY,
    key TEXT NOT NULL UNIQUE,
    context TEXT NOT NULL,
    track TEXT NOT NULL,
    race_type TEXT NOT NULL,
    laps INTEGER NOT NULL,
    seed INTEGER NOT NULL,
    start REAL,
    steps INTEGER NOT NULL DEFAULT 0,
    status TEXT NOT NULL CHECK (status IN ('done', 'failed')),
    error TEXT,
    created REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS match_cars (
    match_id INTEGER NOT NULL REFERENCES matches(id) ON DELETE CASCADE,
    seat INTEGER NOT NULL,
    grid_slot INTEGER,
    player TEXT NOT NULL REFERENCES players(name),
    position INTEGER NOT NULL CHECK (position >= 1),
    finished INTEGER NOT NULL,
    laps INTEGER NOT NULL,
    total_time REAL,
    best_lap REAL,
    collisions INTEGER NOT NULL,
    crashes INTEGER NOT NULL,
    overtakes INTEGER NOT NULL,
    penalties INTEGER NOT NULL,
    penalty_time REAL NOT NULL,
    off_tracks INTEGER NOT NULL,
    PRIMARY KEY (match_id, seat)
);
CREATE INDEX IF NOT EXISTS match_cars_player ON match_cars(player);
CREATE TABLE IF NOT EXISTS ratings (
    id INTEGER PRIMARY KEY,
    computed REAL NOT NULL,
    method TEXT NOT NULL,
    player TEXT NOT NULL REFERENCES players(name),
    rating REAL NOT NULL,
    low REAL,
    high REAL,
    training_steps INTEGER NOT NULL DEFAULT 0,
    matches INTEGER NOT NULL DEFAULT 0
);
"""


class LeagueStoreError(RuntimeError):
    """The league file cannot be used (newer schema, not a league, conflicting data)."""


def check_not_empty(path: Path) -> None:
    """Refuse a 0-byte file: only a path that does not exist starts a new league.

    SQLite would take an empty file for a new database, so a league file emptied by accident
    (a failed copy, ``> file``) would silently become a new, empty league. A new league's file
    is never empty for long: creating it writes its schema at once (the SQLite header, or a
    ``-wal`` file beside it while it is open).
    """
    if not path.is_file() or path.stat().st_size > 0:
        return
    wal = path.with_name(path.name + "-wal")
    if wal.is_file() and wal.stat().st_size > 0:
        return
    raise LeagueStoreError(f"{path} is empty (0 bytes), not a league file; delete it to start "
                           f"a new league there, or give another path")


def check_league_file(db: sqlite3.Connection, path: Path) -> None:
    """Refuse a file that is damaged, not a league, or written by a newer schema.

    Raises:
        LeagueStoreError: What is wrong with the file and what to do.
    """
    try:
        tables = {row[0] for row in db.execute(
            "SELECT name FROM sqlite_master WHERE type = 'table'")}
        # A damaged page may lie anywhere: find it now, not after hours of racing into the
        # file (about 0.7 s for 200,000 matches).
        damage = db.execute("PRAGMA quick_check(1)").fetchone()[0] if tables else "ok"
    except sqlite3.DatabaseError as err:
        raise LeagueStoreError(f"{path} is not a league file, or a damaged one (SQLite "
                               f"says: {err})") from None
    if damage != "ok":
        damage = " ".join(damage.split())
        raise LeagueStoreError(f"{path} is damaged (SQLite's quick_check: {damage}); "
                               f"restore it from a copy, or give another path")
    if tables and "meta" not in tables:
        raise LeagueStoreError(
            f"{path} is an SQLite file but not a league (no 'meta' table; tables: "
            f"{sorted(tables)}); give a new path or a league file")
    if "meta" in tables:
        row = db.execute(
            "SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
        version = int(row[0]) if row is not None else 0
        if version > SCHEMA_VERSION:
            raise LeagueStoreError(
                f"{path} was written with league schema version {version}, but this "
                f"h2h-racing reads versions up to {SCHEMA_VERSION}; upgrade h2h-racing to "
                f"open it")


def create_schema(db: sqlite3.Connection, name: str) -> None:
    """Create the tables a league file lacks and its first ``meta`` entries (inside a
    transaction the caller holds)."""
    for statement in _SCHEMA.split(";"):
        if statement.strip():
            db.execute(statement)
    db.execute("INSERT OR IGNORE INTO meta VALUES ('schema_version', ?)",
               (str(SCHEMA_VERSION),))
    db.execute("INSERT OR IGNORE INTO meta VALUES ('created', ?)", (str(time.time()),))
    db.execute("INSERT OR IGNORE INTO meta VALUES ('name', ?)", (name,))
