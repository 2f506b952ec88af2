"""The league store: schema, idempotent match records, transactions, crash safety."""

from __future__ import annotations

import math
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time

import pytest

from h2h_racing.league.store import (
    SCHEMA_VERSION,
    CarResult,
    LeagueStore,
    LeagueStoreError,
    MatchRecord,
    Player,
    file_sha256,
    player_for,
)


def _match(key: str, a: str = "racing_line", b: str = "pure_pursuit", winner: int = 0,
           status: str = "done") -> MatchRecord:
    cars = (CarResult(seat=0, player=a, position=1 if winner == 0 else 2, finished=True, laps=2,
                      total_time=20.5, best_lap=10.1, overtakes=1),
            CarResult(seat=1, player=b, position=2 if winner == 0 else 1, finished=False, laps=1,
                      crashes=1))
    return MatchRecord(key=key, track="oval", race_type="head_to_head", laps=2, seed=3,
                       cars=cars, context="tournament:t", start=4.5, steps=300, status=status)


@pytest.fixture
def store(tmp_path):
    s = LeagueStore(tmp_path / "league.sqlite")
    s.add_player(Player(name="racing_line", kind="scripted", checkpoint="racing_line"))
    s.add_player(Player(name="pure_pursuit", kind="scripted", checkpoint="pure_pursuit"))
    yield s
    s.close()


def test_new_file_has_schema_version_and_wal(store):
    assert store.meta()["schema_version"] == str(SCHEMA_VERSION)
    mode = sqlite3.connect(store.path).execute("PRAGMA journal_mode").fetchone()[0]
    assert mode == "wal"


def test_match_round_trip(store):
    assert store.record_match(_match("k1"))
    (back,) = store.matches()
    assert back.key == "k1" and back.track == "oval" and back.seed == 3 and back.start == 4.5
    assert back.cars[0].total_time == 20.5 and back.cars[0].overtakes == 1
    # A DNF's time is stored as NULL and comes back as inf.
    assert math.isinf(back.cars[1].total_time) and back.cars[1].crashes == 1
    assert back.places == {"racing_line": 1.0, "pure_pursuit": 2.0}


def test_same_key_is_stored_once(store):
    assert store.record_match(_match("k1"))
    assert not store.record_match(_match("k1", winner=1))
    assert store.count_matches() == 1
    assert store.races() == [{"racing_line": 1.0, "pure_pursuit": 2.0}]


def test_failed_match_is_replaced_by_a_later_done_one(store):
    assert store.record_match(_match("k1", status="failed"))
    assert store.count_matches() == 0 and store.count_matches(status="failed") == 1
    assert store.record_match(_match("k1"))
    assert store.count_matches() == 1 and store.count_matches(status="failed") == 0
    # ...but a failure never overwrites a finished match.
    assert not store.record_match(_match("k1", status="failed"))
    assert store.count_matches() == 1


def test_done_keys_by_prefix(store):
    for key in ("a:1", "a:2", "b:1"):
        store.record_match(_match(key))
    assert store.done_keys("a:") == {"a:1", "a:2"}
    assert store.done_keys() == {"a:1", "a:2", "b:1"}


def test_unknown_player_is_refused_and_nothing_is_written(store):
    with pytest.raises(ValueError, match="not in the league"):
        store.record_match(_match("k1", b="ghost"))
    assert store.count_matches() == 0
    assert store._db.execute("SELECT COUNT(*) FROM match_cars").fetchone()[0] == 0


def test_bad_status_and_seats(store):
    with pytest.raises(ValueError, match="status must be one of"):
        store.record_match(_match("k", status="maybe"))
    m = _match("k")
    dup = MatchRecord(key="k", track="oval", race_type="head_to_head", laps=1, seed=0,
                      cars=(m.cars[0], m.cars[0]))
    with pytest.raises(ValueError, match="duplicate seats"):
        store.record_match(dup)


def test_players(store, tmp_path):
    assert [p.name for p in store.players()] == ["racing_line", "pure_pursuit"]
    # Adding the same player again is a no-op, a different one of that name is an error.
    store.add_player(Player(name="racing_line", kind="scripted", checkpoint="racing_line"))
    with pytest.raises(ValueError, match="different player named 'racing_line'"):
        store.add_player(Player(name="racing_line", kind="policy", checkpoint="x.pt"))
    with pytest.raises(ValueError, match="kind must be one of"):
        store.add_player(Player(name="x", kind="robot"))
    with pytest.raises(ValueError, match="parent 'nobody' is not in the league"):
        store.add_player(Player(name="x_v1", kind="snapshot", parent="nobody"))
    store.add_player(Player(name="main", kind="learner", role="main"))
    store.add_player(Player(name="main_v1", kind="snapshot", parent="main", training_steps=5))
    assert store.player("main_v1").parent == "main"
    assert [p.name for p in store.players(kind="snapshot")] == ["main_v1"]


def test_rating_history(store):
    store.record_ratings("bradley_terry", {"racing_line": 1000.0, "pure_pursuit": 900.0},
                         {"racing_line": (990.0, 1010.0), "pure_pursuit": (850.0, 950.0)},
                         training_steps=100, matches=4)
    store.record_ratings("bradley_terry", {"racing_line": 1000.0}, training_steps=200)
    history = store.rating_history()
    assert history["pure_pursuit"] == [(100.0, 900.0, 850.0, 950.0)]
    steps, rating, low, high = history["racing_line"][1]
    assert (steps, rating) == (200.0, 1000.0) and math.isnan(low) and math.isnan(high)


def test_newer_schema_is_refused(tmp_path):
    path = tmp_path / "league.sqlite"
    LeagueStore(path).close()
    db = sqlite3.connect(path)
    db.execute("UPDATE meta SET value = ? WHERE key = 'schema_version'",
               (str(SCHEMA_VERSION + 1),))
    db.commit()
    db.close()
    with pytest.raises(LeagueStoreError, match=f"schema version {SCHEMA_VERSION + 1}.*upgrade"):
        LeagueStore(path)


def test_other_files_are_refused(tmp_path):
    other = tmp_path / "other.sqlite"
    db = sqlite3.connect(other)
    db.execute("CREATE TABLE foo (x)")
    db.commit()
    db.close()
    with pytest.raises(LeagueStoreError, match="not a league"):
        LeagueStore(other)
    text = tmp_path / "notes.sqlite"
    text.write_text("hello, this is not a database" * 100)
    with pytest.raises(LeagueStoreError, match="not a league file"):
        LeagueStore(text)


def test_player_for(tmp_path):
    assert player_for("racing_line").kind == "scripted"
    shipped = player_for("ppo_generalist")
    assert shipped.kind == "policy" and len(shipped.checkpoint_sha256) == 64
    policy = tmp_path / "myrun" / "policy.pt"
    policy.parent.mkdir()
    policy.write_bytes(b"abc")
    mine = player_for(str(policy))
    # sha256("abc"), the FIPS 180-2 test vector.
    assert mine.name == "myrun" and mine.checkpoint_sha256 == (
        "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad")
    assert file_sha256(policy) == mine.checkpoint_sha256
    with pytest.raises(ValueError, match="unknown player 'nobody'"):
        player_for("nobody")


def test_player_for_a_driver_with_settings():
    # Named and built by its spec written back: two spellings of one pace are one player.
    paced = player_for("racing_line: grip_factor=0.70")
    assert (paced.name, paced.kind, paced.checkpoint) == (
        "racing_line:grip_factor=0.7", "scripted", "racing_line:grip_factor=0.7")
    assert player_for("racing_line:grip_factor=0.7") == paced
    with pytest.raises(ValueError, match=r"racing_line: grip_factor must be a number in \(0, 1\]"):
        player_for("racing_line:grip_factor=1.5")
    with pytest.raises(ValueError, match="league_racer: a trained policy takes no settings"):
        player_for("league_racer:grip_factor=0.7")


def test_kill_9_while_writing_loses_nothing_committed(tmp_path):
    """A writer killed mid-stream leaves whole matches only (each with both cars)."""
    path = tmp_path / "league.sqlite"
    script = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(tmp_path)!r})
        from h2h_racing.league.store import CarResult, LeagueStore, MatchRecord, Player
        s = LeagueStore({str(path)!r})
        s.add_player(Player(name="a", kind="scripted"))
        s.add_player(Player(name="b", kind="scripted"))
        i = 0
        while True:
            cars = (CarResult(seat=0, player="a", position=1, finished=True, laps=1),
                    CarResult(seat=1, player="b", position=2, finished=True, laps=1))
            s.record_match(MatchRecord(key=f"m{{i}}", track="oval", race_type="head_to_head",
                                       laps=1, seed=i, cars=cars))
            i += 1
            if i == 20:
                print("ready", flush=True)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "ready"
    time.sleep(0.2)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    with LeagueStore(path) as store:
        count = store.count_matches()
        cars = store._db.execute("SELECT COUNT(*) FROM match_cars").fetchone()[0]
        keys = store.done_keys()
    assert count >= 20
    assert cars == 2 * count
    assert keys == {f"m{i}" for i in range(count)}
