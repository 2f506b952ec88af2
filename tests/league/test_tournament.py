"""Tournament schedules, the race runner, resuming after a kill, and the Ray backend."""

from __future__ import annotations

import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from h2h_racing.league.store import LeagueStore
from h2h_racing.league.tournament import (
    TournamentConfig,
    make_job,
    round_robin_jobs,
    run_job,
    run_tournament,
    swiss_pairs,
)

PLAYERS = ("racing_line", "pure_pursuit", "blocker")


def _config(**kwargs):
    base = dict(players=PLAYERS, tracks=("oval",), races=1, laps=1, name="t")
    base.update(kwargs)
    return TournamentConfig(**base)


def test_round_robin_schedule():
    cfg = _config(tracks=("oval", "kidney"), races=2, field_races=1)
    jobs = round_robin_jobs(cfg, {p: p for p in PLAYERS}, set())
    pairs = [j for j in jobs if len(j.players) == 2]
    field = [j for j in jobs if len(j.players) == 3]
    # 3 players -> 3 pairs, x 2 tracks; each pair: 2 seeds x 2 seat orders = 4 races.
    assert len(pairs) == 6 and all(len(j.keys) == 4 for j in pairs)
    assert {j.slots for j in pairs} == {((0, 1), (1, 0), (0, 1), (1, 0))}
    # Field races: 1 seed x 3 cyclic rotations of the grid, per track.
    assert len(field) == 2 and all(j.slots == ((0, 1, 2), (1, 2, 0), (2, 0, 1)) for j in field)
    keys = [k for j in jobs for k in j.keys]
    assert len(keys) == len(set(keys)) == 6 * 4 + 2 * 3
    # Every pairing starts race r of a track at the same point; races differ.
    oval = [j for j in pairs if j.track == "oval"]
    assert len({j.starts for j in oval}) == 1
    assert oval[0].starts[0] == oval[0].starts[1] != oval[0].starts[2]
    # Already stored races are not scheduled again.
    done = set(pairs[0].keys[:3])
    again = round_robin_jobs(cfg, {p: p for p in PLAYERS}, done)
    assert len([k for j in again for k in j.keys]) == len(keys) - 3


def test_config_validation():
    with pytest.raises(ValueError, match="at least 2 players"):
        TournamentConfig(players=("racing_line",))
    with pytest.raises(ValueError, match="distinct"):
        TournamentConfig(players=("a", "a"))
    with pytest.raises(ValueError, match="races must be >= 1"):
        _config(races=0)
    with pytest.raises(ValueError, match="schedule must be one of"):
        _config(schedule="knockout")
    assert _config(players=tuple("abcdefgh")).swiss_rounds == 4  # ceil(log2 8) + 1


def test_swiss_pairs():
    players = ["a", "b", "c", "d"]
    scores = {"a": 3, "b": 2, "c": 1, "d": 0}
    assert swiss_pairs(players, scores, set()) == [("a", "b"), ("c", "d")]
    # a and b have met: a takes the next-ranked player it has not met.
    assert swiss_pairs(players, scores, {frozenset("ab")}) == [("a", "c"), ("b", "d")]
    # Everyone has met a: a takes the nearest-ranked one anyway.
    met = {frozenset("ab"), frozenset("ac"), frozenset("ad")}
    assert swiss_pairs(players, scores, met)[0] == ("a", "b")
    # Odd field: the lowest-ranked player sits out.
    assert swiss_pairs(["a", "b", "c"], scores, set()) == [("a", "b")]


def test_run_job_records_both_seat_orders_deterministically():
    job = make_job("oval", ("racing_line", "pure_pursuit"),
                   {"racing_line": "racing_line", "pure_pursuit": "pure_pursuit"},
                   [(0, 1), (1, 0)], range(1), "t", set(), laps=1, seed=0, context="t")
    first, second = run_job(job), run_job(job)
    assert first == [r.__class__(**{**r.__dict__, "created": s.created})
                     for r, s in zip(second, first)]
    for record, slots in zip(first, job.slots):
        assert sorted(c.position for c in record.cars) == [1, 2]
        assert tuple(c.grid_slot for c in record.cars) == slots
        assert [c.player for c in record.cars] == ["racing_line", "pure_pursuit"]
        assert record.steps > 0
    # racing_line is the faster driver on the oval (README lap table): it wins from either
    # grid slot.
    assert all(r.places["racing_line"] == 1 for r in first)


def test_tournament_runs_once_and_resumes(tmp_path):
    cfg = _config()
    with LeagueStore(tmp_path / "l.sqlite") as store:
        report = run_tournament(cfg, store, n_boot=20)
        # 3 pairs x 1 seed x 2 seat orders.
        assert (report.ran, report.skipped) == (6, 0)
        assert store.count_matches(context="tournament:t") == 6
        again = run_tournament(cfg, store, n_boot=20)
        assert (again.ran, again.skipped) == (0, 6)
        assert store.count_matches() == 6
        ratings = {r.player: r.rating for r in report.standings}
        assert ratings["racing_line"] == pytest.approx(1000.0)  # the default anchor
        assert set(ratings) == set(PLAYERS)
        assert "racing_line" in report.table()


def test_players_with_settings(tmp_path):
    # A paced racing_line is its own player, named by its spec, and rated beside the default.
    cfg = _config(players=("racing_line:grip_factor=0.50", "racing_line"))
    with LeagueStore(tmp_path / "l.sqlite") as store:
        report = run_tournament(cfg, store, n_boot=10)
        assert report.ran == 2  # 1 pair x 1 seed x 2 seat orders
        assert {r.player for r in report.standings} == {"racing_line:grip_factor=0.5",
                                                         "racing_line"}
        assert store.player("racing_line:grip_factor=0.5").checkpoint == \
            "racing_line:grip_factor=0.5"
        assert "racing_line:grip_factor=0.5" in report.table()
        # Two spellings of one pace are one player: refused before any race.
        same = _config(players=("racing_line:grip_factor=0.5", "racing_line:grip_factor=.50"),
                       name="same")
        with pytest.raises(ValueError, match=r"racing_line:grip_factor=0.5 and "
                                             r"racing_line:grip_factor=.50 are both named "
                                             r"'racing_line:grip_factor=0.5'"):
            run_tournament(same, store, n_boot=10)
        assert store.count_matches(context="tournament:same") == 0


def test_swiss_tournament(tmp_path):
    cfg = _config(players=("racing_line", "pure_pursuit", "blocker", "random"),
                  schedule="swiss", rounds=2)
    with LeagueStore(tmp_path / "l.sqlite") as store:
        report = run_tournament(cfg, store, n_boot=10)
        # 2 rounds x 2 pairs x 1 seed x 2 seat orders.
        assert report.ran == 8
        pairs = {frozenset(m.places) for m in store.matches()}
        assert len(pairs) == 4  # round 2 paired players that had not met


def test_killed_tournament_resumes_without_double_counting(tmp_path):
    league = tmp_path / "l.sqlite"
    cmd = [sys.executable, "-m", "h2h_racing.cli.command", "tournament", "--players", ",".join(PLAYERS),
           "--tracks", "oval,kidney", "--races", "2", "--laps", "1", "--name", "k",
           "--backend", "inprocess", "--league", str(league)]
    total = 3 * 2 * 2 * 2  # pairs x tracks x seeds x seat orders
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    count = 0
    deadline = time.time() + 240
    while time.time() < deadline and proc.poll() is None:
        if league.exists():
            try:
                count = sqlite3.connect(league).execute(
                    "SELECT COUNT(*) FROM matches").fetchone()[0]
            except sqlite3.OperationalError:
                count = 0
            if count >= 4:
                break
        time.sleep(0.05)
    assert proc.poll() is None, "the tournament finished before it could be killed"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    with LeagueStore(league) as store:
        stored = store.count_matches()
    assert 4 <= stored < total
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert f"{total - stored} races run, {stored} already in" in done.stdout
    with LeagueStore(league) as store:
        keys = [m.key for m in store.matches()]
    assert len(keys) == len(set(keys)) == total


def _children(pid: int) -> set[int]:
    """PIDs whose parent is ``pid`` (Linux /proc)."""
    found = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[1]) == pid:
            found.add(int(stat.parent.name))
    return found


def _cmdline(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_terminated_tournament_stops_its_workers(tmp_path):
    league = tmp_path / "l.sqlite"
    cmd = [sys.executable, "-m", "h2h_racing.cli.command", "tournament", "--players", ",".join(PLAYERS),
           "--tracks", "oval,kidney", "--races", "2", "--laps", "1", "--name", "t",
           "--backend", "local", "--workers", "2", "--league", str(league)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    workers: set[int] = set()
    deadline = time.time() + 240
    while time.time() < deadline and proc.poll() is None and len(workers) < 2:
        # Two spawned workers (the pool's resource tracker is a third child).
        workers = {pid for pid in _children(proc.pid) if b"multiprocessing.spawn" in _cmdline(pid)}
        time.sleep(0.05)
    assert proc.poll() is None and len(workers) == 2, "no workers seen before the end"
    proc.send_signal(signal.SIGTERM)
    # SIGTERM exits through the command's finally, which shuts the pool down: by default
    # Python would die at once and leave both workers running without a parent.
    assert proc.wait(timeout=120) == 128 + signal.SIGTERM
    deadline = time.time() + 30
    while time.time() < deadline and any(Path(f"/proc/{pid}").exists() for pid in workers):
        time.sleep(0.1)
    assert not any(Path(f"/proc/{pid}").exists() for pid in workers)


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_ray_backend_gives_the_same_table(tmp_path):
    ray = pytest.importorskip("ray")
    from h2h_racing.league.backends import RayBackend

    cfg = _config()
    with LeagueStore(tmp_path / "a.sqlite") as store:
        local = run_tournament(cfg, store, n_boot=20)
        local_races = store.races()
    backend = RayBackend(num_cpus=2)
    try:
        with LeagueStore(tmp_path / "b.sqlite") as store:
            remote = run_tournament(cfg, store, backend, n_boot=20)
            remote_races = store.races()
    finally:
        backend.close()
    assert not ray.is_initialized()
    # Jobs finish in any order on Ray; the races themselves are identical.
    key = lambda r: sorted(r.items())  # noqa: E731
    assert sorted(map(key, local_races)) == sorted(map(key, remote_races))
    # The whole table, intervals and sequential Elo included: both are rated in key order.
    assert local.table() == remote.table()
    assert np.isfinite([r.rating for r in remote.standings]).all()


class TestBatchDependence:
    """A race's result depends on its batch only by float rounding (issue 38), as
    docs/league.md says; league runs are documented as not reproducible from run to run."""

    def test_scripted_race_alone_and_in_a_batch(self):
        drivers = {"racing_line": "racing_line", "pure_pursuit": "pure_pursuit"}
        group = ("racing_line", "pure_pursuit")
        batch = run_job(make_job("oval", group, drivers, [(0, 1), (1, 0)], range(1), "t", set(),
                                 laps=1, seed=0, context="t"))
        # The same first race, resumed alone (its partner already stored).
        alone = run_job(make_job("oval", group, drivers, [(0, 1), (1, 0)], range(1), "t",
                                 {batch[1].key}, laps=1, seed=0, context="t"))
        assert alone[0].key == batch[0].key
        for a, b in zip(alone[0].cars, batch[0].cars):
            assert (a.player, a.position, a.laps) == (b.player, b.position, b.laps)
            # 0.11 ms here: rounding differences amplified by two cars racing close together.
            assert abs(a.total_time - b.total_time) < 1e-3

    def test_docs_say_so(self):
        text = (Path(__file__).parents[2] / "docs" / "league.md").read_text()
        assert "depends slightly on which races share its batch" in text
        assert "League runs are not reproducible from run to run" in text
