"""Tournaments: schedule races between players, run them on a backend, store every match once.

A tournament is a list of *jobs*. A job is one group of players on one track, raced on
several seeds, every seed in every seat order: all of a job's races run at once as env copies
of one batched ``RaceCore`` (the same layout as ``training.evaluate.head_to_head``), so a job
costs about as much as its longest race. Seat orders permute the grid slots, not the
drivers, and every pairing uses the same start points (drawn from the tournament seed and the
race index), so two players meet on exactly the conditions every other pair meets on.

Each race is stored as one match whose key names the tournament, track, players, seat order
and seed. Before running, the scheduler drops the races whose keys are already in the store,
so a tournament killed at any moment continues where it stopped and never counts a race
twice. What else decides a race's outcome (laps, seed, race type, rules, car and physics
settings, each track's geometry) is the tournament's identity, stored in the league file's
``meta`` under ``tournament:<name>:settings``: running a stored name with other settings is
an error, not a resume that would report the old races as the new ones.

Schedules:

- ``round_robin``: every pair of players, ``races`` seeds x 2 seat orders per track; with
  ``field_races`` > 0 also races of all players together, every seed in every cyclic
  rotation of the grid.
- ``swiss``: ``rounds`` rounds; in each, players are sorted by their score so far and paired
  with the nearest-ranked player they have not met (a bye for an odd one out). For fields too
  large for a full round robin.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import os
import sys
import zlib
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from h2h_racing.league.players import check_distinct_names
from h2h_racing.league.store import CarResult, LeagueStore, MatchRecord, player_for

SCHEDULES = ("round_robin", "swiss")
RACE_TYPE = "head_to_head"
"""Race type of every tournament race."""
SETTINGS_FORMAT = 1
"""Version of the stored tournament settings."""
OUTCOME_FIELDS = ("race_type", "rules", "car", "step_dt", "physics_substeps", "max_cycles")
"""``EnvConfig`` fields that decide a race's outcome; part of a tournament's identity."""


@dataclass(frozen=True, kw_only=True)
class TournamentConfig:
    """What to play."""

    players: tuple[str, ...]
    """Driver names (scripted ones with any settings, ``racing_line:grip_factor=0.7``: the
    player is named by its spec), shipped policy names or ``policy.pt`` paths (see
    ``make_driver``)."""
    tracks: tuple[str, ...] = ("speedway",)
    """Catalogue names or track files."""
    races: int = 2
    """Seeds per pairing and track; each seed is raced in both seat orders."""
    laps: int = 2
    """Laps per race."""
    field_races: int = 0
    """Seeds of races with all players on the grid together (each in every cyclic rotation of
    the grid); 0 for 2-car races only."""
    schedule: Literal["round_robin", "swiss"] = "round_robin"
    """Pairing scheme."""
    rounds: int = 0
    """Swiss rounds; 0 means ceil(log2(players)) + 1."""
    seed: int = 0
    """Seeds the start points of the races."""
    name: str = "default"
    """Name of the tournament in the store (match keys and context)."""
    anchor: str | None = None
    """Player held at ``anchor_rating`` in the ratings; None picks ``racing_line`` when it
    plays, else the mean rating is ``anchor_rating``."""
    anchor_rating: float = 1000.0
    """Rating of the anchor [Elo]."""

    def __post_init__(self) -> None:
        if len(self.players) < 2:
            raise ValueError(f"a tournament needs at least 2 players, got {list(self.players)}")
        if len(set(self.players)) != len(self.players):
            raise ValueError(f"players must be distinct, got {list(self.players)}")
        if not self.tracks:
            raise ValueError("give at least one track")
        for name in ("races", "laps"):
            if getattr(self, name) < 1:
                raise ValueError(f"TournamentConfig.{name} must be >= 1, got "
                                 f"{getattr(self, name)}")
        if self.field_races < 0 or self.rounds < 0:
            raise ValueError("TournamentConfig.field_races and rounds must be >= 0")
        if self.schedule not in SCHEDULES:
            raise ValueError(f"schedule must be one of {SCHEDULES}, got {self.schedule!r}")
        if ":" in self.name or not self.name:
            raise ValueError(f"tournament name must be non-empty without ':', got {self.name!r}")

    @property
    def context(self) -> str:
        """The ``matches.context`` of this tournament's matches."""
        return f"tournament:{self.name}"

    @property
    def swiss_rounds(self) -> int:
        """Rounds of a Swiss schedule."""
        return self.rounds or math.ceil(math.log2(len(self.players))) + 1


@dataclass(frozen=True)
class Job:
    """Races of one group of players on one track: ``len(keys)`` env copies of one core.

    Copy i drives car c with ``drivers[c]`` from grid slot ``slots[i][c]``, starting at arc
    position ``starts[i]`` [m] of the lap.
    """

    track: str
    players: tuple[str, ...]
    """Player of each car."""
    drivers: tuple[str, ...]
    """What ``make_driver`` builds each car's driver from (name or checkpoint path)."""
    keys: tuple[str, ...]
    seeds: tuple[int, ...]
    """Race index of each copy (start point and key)."""
    slots: tuple[tuple[int, ...], ...]
    starts: tuple[float, ...]
    laps: int
    context: str
    seed: int
    """Seed of the core's reset."""


def _race_start(seed: int, track: str, race: int, length: float) -> float:
    """Arc position [m] where race ``race`` of a tournament starts on ``track``: the same for
    every pairing, different per race (crc32 keeps it stable across processes and runs,
    unlike ``hash``)."""
    mix = zlib.crc32(f"{seed}:{track}:{race}".encode())
    return float(np.random.default_rng(mix).uniform(0.0, length))


def race_config(track: str, num_cars: int, laps: int) -> Any:
    """The ``EnvConfig`` of a tournament (or league) race of ``laps`` laps."""
    from h2h_racing.config.env import EnvConfig, RaceRules

    rules = RaceRules(laps=laps, time_limit=60.0 * laps)
    return EnvConfig(track=track, num_cars=num_cars, race_type=RACE_TYPE, rules=rules)


def track_fingerprint(track: str) -> str:
    """SHA-256 (hex, 16 digits) of a track's geometry: a track file edited between two runs of
    a tournament is a different track under the same name."""
    from h2h_racing.track.io import load_track

    loaded = load_track(track)
    digest = hashlib.sha256()
    for name in ("centre", "width_left", "width_right", "left_border", "right_border",
                 "waypoints"):
        value = getattr(loaded, name, None)
        digest.update(name.encode())
        if value is not None:
            digest.update(np.ascontiguousarray(value, dtype="<f8").tobytes())
    return digest.hexdigest()[:16]


def tournament_settings(config: TournamentConfig) -> dict[str, Any]:
    """Everything besides the match keys that decides the outcome of ``config``'s races."""
    env = dataclasses.asdict(race_config(config.tracks[0], 2, config.laps))
    settings = {"format": SETTINGS_FORMAT, "laps": config.laps, "seed": config.seed,
                "schedule": config.schedule, **{name: env[name] for name in OUTCOME_FIELDS},
                "tracks": {track: track_fingerprint(track) for track in config.tracks}}
    return json.loads(json.dumps(settings))  # as stored: tuples become lists


def check_settings(config: TournamentConfig, store: LeagueStore) -> None:
    """Store ``config``'s settings as the tournament's identity, or check them against the
    stored ones. New tracks join the tournament; a stored track must keep its geometry.

    Raises:
        ValueError: The name was played with other settings, or races of the name were
            stored without settings (by an older h2h-racing), so they cannot be checked.
    """
    key = f"{config.context}:settings"
    new = tournament_settings(config)

    def decide(stored_text: str | None) -> str | None:
        # Runs inside one write transaction (LeagueStore.update_meta): two runs of one name
        # started together take turns, and the second checks what the first stored.
        if stored_text is None:
            stored_races = (store.count_matches(context=config.context)
                            + store.count_matches(context=config.context, status="failed"))
            if stored_races:
                raise ValueError(
                    f"{store.path} holds {stored_races} races of tournament {config.name!r} "
                    f"stored without their settings (by an older h2h-racing), so they cannot be "
                    f"checked against laps={config.laps}, seed={config.seed}; give another "
                    f"--name or --league file")
            return json.dumps(new, sort_keys=True)
        stored = json.loads(stored_text)
        old_leaves = _leaves({k: v for k, v in stored.items() if k != "tracks"})
        new_leaves = _leaves({k: v for k, v in new.items() if k != "tracks"})
        changed = [f"{name}: stored {json.dumps(old_leaves.get(name))}, now "
                   f"{json.dumps(new_leaves.get(name))}"
                   for name in sorted(old_leaves.keys() | new_leaves.keys())
                   if old_leaves.get(name) != new_leaves.get(name)]
        changed += [f"track {track!r}: its geometry changed (fingerprint stored "
                    f"{stored['tracks'][track]}, now {fingerprint})"
                    for track, fingerprint in new["tracks"].items()
                    if stored.get("tracks", {}).get(track, fingerprint) != fingerprint]
        if changed:
            raise ValueError(
                f"tournament {config.name!r} in {store.path} was played with other settings ("
                + "; ".join(changed) + "); its stored races would be reported as these. Give "
                "another --name (or --league file) for these settings, or the stored ones to "
                "resume it")
        if set(new["tracks"]) - set(stored["tracks"]):
            stored["tracks"] = {**stored["tracks"], **new["tracks"]}
            return json.dumps(stored, sort_keys=True)
        return None

    store.update_meta(key, decide)


def _leaves(settings: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"rules": {"laps": 2}}`` -> ``{"rules.laps": 2}`` (to name what changed)."""
    leaves: dict[str, Any] = {}
    for name, value in settings.items():
        if isinstance(value, dict):
            leaves.update(_leaves(value, f"{prefix}{name}."))
        else:
            leaves[prefix + name] = value
    return leaves


def _track_length(track: str) -> float:
    from h2h_racing.track.io import load_track

    return load_track(track).length  # load_track caches named tracks


def make_job(track: str, group: Sequence[str], drivers: dict[str, str],
             orders: Sequence[Sequence[int]], races: Iterable[int], prefix: str,
             done: set[str], *, laps: int, seed: int, context: str) -> Job | None:
    """The job racing ``group`` on ``track`` for every race index x seat order whose key is
    not in ``done``; None when nothing is left.

    Args:
        track: Track name.
        group: Player of each car.
        drivers: Player -> ``make_driver`` argument.
        orders: Seat orders: grid slot of each car.
        races: Race indices (each gets its own start point, the same for every group).
        prefix: Key prefix (context, round...).
        done: Keys already stored.
        laps: Laps per race.
        seed: Seeds the start points.
        context: ``matches.context`` of the records.
    """
    length = _track_length(track)
    keys, seeds, slots, starts = [], [], [], []
    for race in races:
        for order in orders:
            key = (f"{prefix}:{track}:{','.join(group)}:slots={''.join(map(str, order))}"
                   f":race={race}")
            if key in done:
                continue
            keys.append(key)
            seeds.append(race)
            slots.append(tuple(int(s) for s in order))
            starts.append(_race_start(seed, track, race, length))
    if not keys:
        return None
    return Job(track=track, players=tuple(group), drivers=tuple(drivers[p] for p in group),
               keys=tuple(keys), seeds=tuple(seeds), slots=tuple(slots), starts=tuple(starts),
               laps=laps, context=context,
               seed=zlib.crc32(f"{seed}:{track}:{','.join(group)}".encode()))


PAIR_ORDERS = ((0, 1), (1, 0))
"""Both seat orders of a 2-car race."""


def round_robin_jobs(config: TournamentConfig, drivers: dict[str, str],
                     done: set[str]) -> list[Job]:
    """Every job of a round robin that still has races to run."""
    jobs = []
    prefix = config.context
    common = {"laps": config.laps, "seed": config.seed, "context": config.context}
    for track in config.tracks:
        for pair in itertools.combinations(config.players, 2):
            jobs.append(make_job(track, pair, drivers, PAIR_ORDERS, range(config.races), prefix,
                                 done, **common))
        if config.field_races and len(config.players) > 2:
            n = len(config.players)
            rotations = [tuple((i + shift) % n for i in range(n)) for shift in range(n)]
            jobs.append(make_job(track, config.players, drivers, rotations,
                                 range(config.field_races), prefix + ":field", done, **common))
    return [job for job in jobs if job is not None]


def swiss_pairs(players: Sequence[str], scores: dict[str, float],
                met: set[frozenset[str]]) -> list[tuple[str, str]]:
    """Pair players for one Swiss round.

    Players are ordered by score (best first; ties keep the given order) and each takes the
    highest-ranked player below it that it has not met yet; if everyone left has been met, the
    nearest-ranked one. An odd player out sits the round out.
    """
    order = sorted(players, key=lambda p: -scores.get(p, 0.0))
    pairs = []
    free = list(order)
    while len(free) >= 2:
        first = free.pop(0)
        partner = next((p for p in free if frozenset((first, p)) not in met), free[0])
        free.remove(partner)
        pairs.append((first, partner))
    return pairs


def run_job(job: Job) -> list[MatchRecord]:
    """Run every race of ``job`` at once and return one ``MatchRecord`` per race.

    Pure function of ``job``: workers in other processes or on other machines give the same
    records.
    """
    os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")
    from h2h_racing.sim.core import RaceCore
    from h2h_racing.policies import make_driver
    from h2h_racing.envs.results import race_results
    from h2h_racing.track.io import load_track

    _one_thread()
    track = load_track(job.track)
    num = len(job.players)
    config = race_config(job.track, num, job.laps)
    core = RaceCore(config, track, num_envs=len(job.keys))
    core.reset(seed=job.seed, slots=np.asarray(job.slots), start=np.asarray(job.starts))
    # The random driver draws from its own generator, seeded per job and car.
    drivers = [make_driver(d, rng=np.random.default_rng([job.seed, car])) if d == "random"
               else make_driver(d) for car, d in enumerate(job.drivers)]
    for driver in drivers:
        driver.reset(core)
    steps = 0
    race_steps = np.zeros(len(job.keys), dtype=np.int64)
    while not core.done.all():
        actions = np.stack([d.act(core, car) for car, d in enumerate(drivers)], axis=1)
        core.step(*config.commands(actions))
        steps += 1
        race_steps[core.done.all(axis=1) & (race_steps == 0)] = steps
    seats = [f"car_{i}" for i in range(num)]
    records = []
    for copy, key in enumerate(job.keys):
        cars = []
        for row in race_results(core, copy, seats):
            seat = int(row["agent"].removeprefix("car_"))
            cars.append(CarResult(
                seat=seat, player=job.players[seat], position=row["position"],
                finished=row["finished"], laps=row["laps"], total_time=row["total_time"],
                best_lap=row["best_lap"], collisions=row["collisions"], crashes=row["crashes"],
                overtakes=row["overtakes"], penalties=row["penalties"],
                penalty_time=row["penalty_time"], off_tracks=row["off_tracks"],
                grid_slot=job.slots[copy][seat]))
        records.append(MatchRecord(
            key=key, track=track.name, race_type=RACE_TYPE, laps=job.laps,
            seed=job.seeds[copy], cars=tuple(sorted(cars, key=lambda c: c.seat)),
            context=job.context, start=job.starts[copy], steps=int(race_steps[copy])))
    return records


def _one_thread() -> None:
    """Small networks on a busy machine: one torch thread per worker (see TrainConfig). Set
    without importing torch, which a state-observation driver never needs (it acts in numpy):
    torch reads ``OMP_NUM_THREADS`` when a camera driver imports it."""
    torch = sys.modules.get("torch")
    if torch is None:
        os.environ["OMP_NUM_THREADS"] = "1"
    else:
        torch.set_num_threads(1)


@dataclass(frozen=True)
class TournamentReport:
    """What ``run_tournament`` did and the standings after it."""

    config: TournamentConfig
    ran: int
    """Races run and stored by this call."""
    skipped: int
    """Races already in the store (a resumed tournament)."""
    standings: list[Any]
    """``h2h_racing.league.ratings.Standing`` rows, best first."""

    def table(self) -> str:
        """The standings as text."""
        from h2h_racing.league.ratings import format_standings

        return format_standings(self.standings)


def run_tournament(config: TournamentConfig, store: LeagueStore, backend: Any | None = None,
                   progress: Callable[[int, int], None] | None = None,
                   n_boot: int = 200,
                   stop: Callable[[], bool] | None = None) -> TournamentReport:
    """Play ``config`` into ``store`` and rate the players.

    Args:
        config: The tournament.
        store: The league file; players are added to it, finished races are skipped.
        backend: Where jobs run (``league.backends``); None runs them in this process.
        progress: Called with (races done, races in all) after each job.
        n_boot: Bootstrap resamples for the rating intervals.
        stop: Checked while races run; when it turns true, ``JobsStopped``
            (``league.backends``) is raised: the races stored so far stay stored, and the same
            call later plays the rest.
    """
    from h2h_racing.league.backends import InProcessBackend
    from h2h_racing.league.ratings import standings
    from h2h_racing.policies.registry import SEPARATOR, canonical_spec

    backend = backend or InProcessBackend()
    players = [player_for(name) for name in config.players]
    names = [p.name for p in players]
    check_distinct_names(config.players, names)
    check_settings(config, store)
    for player in players:
        store.add_player(player)
    config = dataclasses.replace(config, players=tuple(names))
    drivers = {p.name: p.checkpoint or p.name for p in players}
    done = store.done_keys(config.context + ":")
    ran = 0
    total = 0
    if config.schedule == "round_robin":
        jobs = round_robin_jobs(config, drivers, done)
        total = len(done) + sum(len(j.keys) for j in jobs)
        ran = _run_jobs(jobs, store, backend, progress, len(done), total, stop)
    else:
        for round_index in range(config.swiss_rounds):
            matches = store.matches(context=config.context)
            scores, met = _swiss_state(names, matches)
            pairs = swiss_pairs(names, scores, met)
            prefix = f"{config.context}:round={round_index}"
            jobs = [make_job(track, pair, drivers, PAIR_ORDERS, range(config.races), prefix,
                             done, laps=config.laps, seed=config.seed, context=config.context)
                    for track in config.tracks for pair in pairs]
            jobs = [job for job in jobs if job is not None]
            total = len(matches) + sum(len(j.keys) for j in jobs)
            ran += _run_jobs(jobs, store, backend, progress, len(matches), total, stop)
    # In canonical order with the fixed bootstrap seed (store.races, ratings.standings):
    # workers finish jobs in any order and a resume stores the rest later, and the table must
    # not depend on that (it equals `league table --context tournament:NAME`).
    races = store.races(context=config.context)
    anchor = config.anchor
    if anchor is not None and anchor not in names and SEPARATOR in anchor:
        anchor = canonical_spec(anchor)  # the player's name: racing_line:grip_factor=0.7
    if anchor is None and "racing_line" in names:
        anchor = "racing_line"
    rows = standings(races, anchor=anchor, anchor_rating=config.anchor_rating, n_boot=n_boot)
    store.record_ratings("bradley_terry", {r.player: r.rating for r in rows},
                         {r.player: (r.low, r.high) for r in rows}, matches=len(races))
    return TournamentReport(config=config, ran=ran, skipped=len(done), standings=rows)


def _swiss_state(players: Sequence[str], matches: Sequence[MatchRecord]
                 ) -> tuple[dict[str, float], set[frozenset[str]]]:
    """Pairwise score of each player so far and the pairs that have met."""
    scores = {p: 0.0 for p in players}
    met: set[frozenset[str]] = set()
    for match in matches:
        for a, b in itertools.combinations(match.cars, 2):
            met.add(frozenset((a.player, b.player)))
            if a.position < b.position:
                scores[a.player] += 1.0
            elif b.position < a.position:
                scores[b.player] += 1.0
    return scores, met


def _run_jobs(jobs: list[Job], store: LeagueStore, backend: Any,
              progress: Callable[[int, int], None] | None, already: int, total: int,
              stop: Callable[[], bool] | None = None) -> int:
    """Run ``jobs`` on ``backend``; store each race as its job completes."""
    ran = 0
    if progress is not None:
        progress(already, total)  # the line shows from the start, not after the first job
    for _job_done, records in backend.map(run_job, jobs, stop=stop):
        for record in records:
            ran += int(store.record_match(record))
        if progress is not None:
            progress(already + ran, total)
    return ran

