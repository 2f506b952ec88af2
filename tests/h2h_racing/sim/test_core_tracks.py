"""One core, many tracks: a RaceCore whose env copies race different tracks.

The main check: a core of all the shipped tracks races every copy exactly (to the bit) as a
core of that copy's track alone does, seeded with that track's seed, with the same actions,
at the same place in the shared pymunk Space (``env_offset``: pymunk works in world
coordinates, so the last bits of a copy's motion depend on where it is). Each core there holds
64 bodies or more, so pymunk sorts contacts with its spatial hash, which orders a contact's two
boxes by when they were created; with fewer it uses a bounding-box tree, whose order of the
two depends on every body in the Space (the same holds between cores of one track).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from h2h_racing.sim import rewards
from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import ENV_GAP, RaceCore
from h2h_racing.sim.view import BLOCKS, PER_COPY, CoreView
from h2h_racing.sim.physics import HASH_MIN_BODIES
from h2h_racing.sensors.camera import CameraSensor
from h2h_racing.sensors.lidar import LidarSensor
from h2h_racing.sensors.state import state_observation
from h2h_racing.track.io import list_tracks, load_track

SHIPPED = list_tracks()
TRACKS = [load_track(name) for name in SHIPPED]

RACE_TYPES = {
    # Race rules: off-tracks and crashes freeze cars for a penalty and put them back.
    "head_to_head": dict(race_type="head_to_head", num_cars=4),
    "object_avoidance": dict(race_type="object_avoidance", randomize_obstacles=True),
    "head_to_bot": dict(race_type="head_to_bot", randomize_bots=True),
    # Training rules: an infraction ends the car's episode; ended copies are reset.
    "training": dict(rules=RaceRules.preset("time_trial", "training"), num_cars=4),
}


def events_of(events, rows: slice, num_envs: int) -> dict[str, object]:
    """The step's events of the copies ``rows``, numbered from the first of them."""
    out: dict[str, object] = {}
    for name, value in vars(events).items():
        if name == "bots_paused" and value is None:  # no copy's bots paused
            value = np.zeros(num_envs, dtype=bool)
        if isinstance(value, np.ndarray):
            out[name] = value[rows]
        elif isinstance(value, list):
            out[name] = [(e - rows.start, *rest) for e, *rest in value
                         if rows.start <= e < rows.stop]
    return out


def snapshot(core: RaceCore, events, sensors: dict[str, object]) -> dict[str, object]:
    """Everything a step gives, of every copy (``cut`` takes some copies' part)."""
    out = events_of(events, slice(0, core.num_envs), core.num_envs)
    for name in ("position", "yaw", "velocity", "yaw_rate", "s", "d", "distance", "laps",
                 "done", "finished", "frozen_until", "resets", "penalties", "rank",
                 "off_tracks", "crashes", "collisions", "overtakes", "defences", "time",
                 "steps", "obstacle_position", "bot_position", "bot_yaw", "bot_s",
                 "best_lap_time", "episode_progress", "lap_times"):
        out[name] = getattr(core, name)
    out["state"] = state_observation(core)
    for name, sensor in sensors.items():
        out[name] = (sensor.observe(core, np.random.default_rng(0)) if name == "lidar"
                     else sensor.observe(core))
    return out


def cut(values: dict[str, object], rows: slice) -> dict[str, object]:
    """The part of ``snapshot``'s values of the copies ``rows``, numbered from the first."""
    out = {}
    for name, value in values.items():
        if isinstance(value, np.ndarray) or name == "lap_times":
            out[name] = value[rows]
        else:  # event lists: (env, ...) tuples
            out[name] = [(e - rows.start, *rest) for e, *rest in value
                         if rows.start <= e < rows.stop]
    return out


def assert_same(a: dict[str, object], b: dict[str, object], where: str) -> None:
    assert a.keys() == b.keys()
    for key in a:
        if isinstance(a[key], np.ndarray):
            assert a[key].dtype == b[key].dtype, (where, key)
            assert np.array_equal(a[key], b[key], equal_nan=True), (where, key)
        else:
            assert a[key] == b[key], (where, key)


@pytest.mark.parametrize("kind", list(RACE_TYPES))
def test_every_copy_races_as_a_core_of_its_track_alone(kind: str) -> None:
    cfg = EnvConfig(track="speedway", **{"num_cars": 2, **RACE_TYPES[kind]})
    bodies = cfg.num_cars + cfg.obstacle_count + cfg.bot_count
    per = math.ceil(HASH_MIN_BODIES / bodies)  # copies of each track: every core hashes
    mixed = RaceCore(cfg, TRACKS, num_envs=per * len(TRACKS))
    seeds = RaceCore.track_seeds(11, len(TRACKS))
    alone = []
    for k, track in enumerate(TRACKS):
        core = RaceCore(cfg, track, num_envs=per)
        core.env_offset = mixed.env_offset[k * per:(k + 1) * per].copy()
        alone.append(core)
    mixed.reset(seed=11)
    for core, seed in zip(alone, seeds):
        core.reset(seed=seed)
    weights = rewards.weights_of(cfg.reward)

    def sensors(core: RaceCore) -> dict[str, object]:
        out: dict[str, object] = {"lidar": LidarSensor(cfg.lidar, cfg.car)}
        if kind == "head_to_bot":
            out["camera"] = CameraSensor(cfg.camera, core.tracks, cfg.car)
        return out

    mixed_sensors, alone_sensors = sensors(mixed), [sensors(core) for core in alone]
    steps = 150
    actions = np.random.default_rng(5).uniform([-0.35, 0.3], [0.35, 3.5],
                                               (steps, mixed.num_envs, cfg.num_cars, 2))
    seen = dict.fromkeys(("off_track", "replaced", "collided", "reset", "bot_contacts"), 0)
    for step in range(steps):
        # The camera (the slow part) every 10 steps.
        keep = ("lidar", "camera") if step % 10 == 0 else ("lidar",)
        racing = mixed.racing
        events = mixed.step(actions[step, ..., 0], actions[step, ..., 1])
        terms, _ = rewards.reward_terms(weights, events, mixed.speed, racing)
        want = snapshot(mixed, events, {k: v for k, v in mixed_sensors.items() if k in keep})
        # Copies that ended (training) and every third copy at step 75 start anew.
        ended = mixed.done.all(axis=1)
        if step == steps // 2:
            ended |= np.arange(mixed.num_envs) % 3 == 0
        for k, core in enumerate(alone):
            rows = slice(k * per, (k + 1) * per)
            racing_alone = core.racing
            mine = core.step(actions[step, rows, :, 0], actions[step, rows, :, 1])
            my_terms, _ = rewards.reward_terms(weights, mine, core.speed, racing_alone)
            got = snapshot(core, mine,
                           {k: v for k, v in alone_sensors[k].items() if k in keep})
            assert_same(cut(want, rows), got, f"{SHIPPED[k]}, step {step}")
            assert np.array_equal(terms[:, rows], my_terms)
            if ended[rows].any():
                core.reset_envs(ended[rows])
        if ended.any():
            mixed.reset_envs(ended)
        seen["off_track"] += int(events.off_track.sum())
        seen["replaced"] += int(events.replaced.sum())
        seen["collided"] += int(events.collided.sum())
        seen["reset"] += int(ended.sum())
        seen["bot_contacts"] += len(events.bot_contacts)
    # The run went through what it compares: infractions, contacts, resets (and bots).
    assert seen["off_track"] and seen["collided"] and seen["reset"]
    assert seen["replaced"] or kind == "training"
    assert seen["bot_contacts"] or kind != "head_to_bot"


class TestLayout:
    def test_copies_split_into_blocks_in_track_order(self) -> None:
        cfg = EnvConfig(track="oval", num_cars=2)
        core = RaceCore(cfg, TRACKS[:3], num_envs=7)
        assert core.track_index.tolist() == [0, 0, 0, 1, 1, 2, 2]
        assert core.num_tracks == 3 and core.tracks == tuple(TRACKS[:3])
        assert np.array_equal(core.lengths, [TRACKS[k].length for k in core.track_index])
        one = RaceCore(cfg, TRACKS[2], num_envs=2)
        assert one.num_tracks == 1 and one.track is TRACKS[2] and one.tracks == (TRACKS[2],)
        assert one.track_index.tolist() == [0, 0]

    def test_each_copy_gets_a_cell_clear_of_its_neighbours(self) -> None:
        # Every copy's track and parked cars, at its offset, keep ENV_GAP from every other's.
        core = RaceCore(EnvConfig(track="oval", num_cars=3), TRACKS, num_envs=11,
                        track_index=np.array([6, 0, 3, 3, 1, 5, 2, 4, 0, 6, 2]))
        boxes = []
        for e in range(core.num_envs):
            xmin, ymin, xmax, ymax = core.tracks[core.track_index[e]].bounds
            xmax = max(xmax, core._park[e, :, 0].max())
            ymax = max(ymax, core._park[e, :, 1].max())
            x, y = core.env_offset[e]
            boxes.append((xmin + x, ymin + y, xmax + x, ymax + y))
        for a in range(len(boxes)):
            for b in range(a):
                ax0, ay0, ax1, ay1 = boxes[a]
                bx0, by0, bx1, by1 = boxes[b]
                gap = max(bx0 - ax1, ax0 - bx1, by0 - ay1, ay0 - by1)
                assert gap >= ENV_GAP - 1e-9, (a, b, gap)

    def test_bad_tracks_and_track_index_are_refused(self) -> None:
        cfg = EnvConfig(track="oval", num_cars=2)
        with pytest.raises(ValueError, match=r"3 tracks need at least one env copy each, got "
                                             r"num_envs=2"):
            RaceCore(cfg, TRACKS[:3], num_envs=2)
        with pytest.raises(ValueError, match=r"track_index must hold one track index in "
                                             r"\[0, 2\) per env copy, shape \(3,\)"):
            RaceCore(cfg, TRACKS[:2], num_envs=3, track_index=[0, 2, 1])
        with pytest.raises(ValueError, match="shape \\(3,\\) ints, got float64"):
            RaceCore(cfg, TRACKS[:2], num_envs=3, track_index=[0.0, 1.0, 1.0])
        with pytest.raises(TypeError, match="a Track or a non-empty sequence of Tracks"):
            RaceCore(cfg, [], num_envs=1)
        with pytest.raises(TypeError, match="got str"):
            RaceCore(cfg, "oval", num_envs=1)

    def test_single_track_names_say_what_a_core_of_several_has(self) -> None:
        core = RaceCore(EnvConfig(track="oval", num_cars=2), TRACKS[:2], num_envs=2)
        for name in ("track", "forward_track", "rng", "inner_sign"):
            with pytest.raises(AttributeError, match=f"races 2 tracks, so it has no single "
                                                     f"{name}: copy e races "
                                                     r"tracks\[track_index\[e\]\]"):
                getattr(core, name)

    def test_each_track_has_its_generator(self) -> None:
        core = RaceCore(EnvConfig(track="oval", num_cars=2), TRACKS[:3], num_envs=3)
        core.seed(4)
        seeds = RaceCore.track_seeds(4, 3)
        assert len(set(seeds)) == 3
        for rng, seed in zip(core.rngs, seeds):
            assert rng.random() == np.random.default_rng(seed).random()
        one = RaceCore(EnvConfig(track="oval", num_cars=2), TRACKS[0], num_envs=3)
        one.seed(4)  # one track: the seed itself, as before
        assert one.rng.random() == np.random.default_rng(4).random()

    def test_reversed_core_drives_every_track_the_other_way(self) -> None:
        core = RaceCore(EnvConfig(track="oval", num_cars=2), TRACKS[:2], num_envs=2)
        core.reset(seed=0, reverse=True)
        assert core.is_reversed and core.forward_tracks == tuple(TRACKS[:2])
        assert [t.is_ccw for t in core.tracks] == [not t.is_ccw for t in TRACKS[:2]]
        view = core.track_views()[1][1]
        assert view.track is core.tracks[1] and view.forward_track is TRACKS[1]


class TestViews:
    def make(self) -> RaceCore:
        cfg = EnvConfig(track="oval", num_cars=2, race_type="head_to_bot")
        core = RaceCore(cfg, TRACKS[:3], num_envs=6, track_index=np.array([1, 0, 1, 2, 2, 1]))
        core.reset(seed=3)
        for _ in range(20):
            core.step(np.full((6, 2), 0.1), np.full((6, 2), 2.0))
        return core

    def test_a_view_reads_its_track_s_copies_as_a_one_track_core(self) -> None:
        core = self.make()
        views = core.track_views()
        assert [view.track_number for _, view in views] == [0, 1, 2]
        rows, view = views[1]
        assert rows.tolist() == [0, 2, 5]  # not consecutive: indices
        assert views[2][0] == slice(3, 5)  # consecutive: a slice, views of the core's memory
        assert view.num_envs == 3 and view.track is TRACKS[1] and view.num_tracks == 1
        assert view.track_index.tolist() == [0, 0, 0] and view.tables.tracks == (TRACKS[1],)
        assert view.inner_sign == (1 if TRACKS[1].is_ccw else -1) and view.rng is core.rngs[1]
        assert np.array_equal(view.s, core.s[rows]) and np.array_equal(view.racing,
                                                                      core.racing[rows])
        assert view.lap_times == [core.lap_times[e] for e in rows.tolist()]
        assert view.config is core.config and view.num_bots == core.num_bots
        # The state kernel reads a view's blocks and one-track tables.
        assert np.array_equal(state_observation(view), state_observation(core)[rows])
        camera = CameraSensor(core.config.camera, view.track, core.config.car)
        whole = CameraSensor(core.config.camera, core.tracks, core.config.car)
        assert np.array_equal(camera.observe(view), whole.observe(core)[rows])
        assert core.track_views() is views  # built once

    def test_a_view_does_not_step(self) -> None:
        view = self.make().track_views()[0][1]
        for name in ("step", "reset", "reset_envs", "seed", "world"):
            with pytest.raises(AttributeError, match=f"it has no '{name}': step, reset and "
                                                     "seed the core itself"):
                getattr(view, name)

    def test_every_per_copy_array_is_cut_by_a_view(self) -> None:
        # E = 7 differs from every other size here (cars, boxes, bots, wheels, fields), so an
        # array with 7 rows is per copy: a view must cut it (or its blocks, on axis 1).
        cfg = EnvConfig(track="oval", num_cars=2, num_obstacles=3, num_bots=1)
        core = RaceCore(cfg, TRACKS[:2], num_envs=7)
        core.reset(seed=0)
        scratch = {"_points", "_point_track", "_selected", "_scratch", "_wheel_first",
                   "track_index"}
        for name, value in vars(core).items():
            if name in scratch or not isinstance(value, (np.ndarray, list)):
                continue
            if len(value) == 7:
                assert name in PER_COPY, name
            elif isinstance(value, np.ndarray) and value.ndim > 1 and value.shape[1] == 7:
                assert name in BLOCKS, name
        assert isinstance(core.track_views()[0][1], CoreView)


def test_a_copy_s_reset_leaves_the_others_bodies_alone() -> None:
    # Bots drift from their lanes by rounding in pymunk; a reset of copy 1 used to write
    # every copy's bodies back from the core's arrays, which moved copy 0's bots.
    still = RaceRules(laps=0, time_limit=1e9, immobilised_steps=10**6, reversed_steps=10**6)
    cfg = EnvConfig(track="oval", num_cars=2, race_type="head_to_bot", rules=still)
    core = RaceCore(cfg, TRACKS[SHIPPED.index("oval")], num_envs=2)
    core.reset(seed=0)
    for _ in range(90):
        core.step(np.zeros((2, 2)), np.zeros((2, 2)))
    bots = slice(4, 7)  # copy 0's bots: after the 4 cars of both copies
    offset = core.env_offset[0]
    assert not np.array_equal(core.world.state[bots, :2], core.bot_position[0] + offset)
    before = core.world.state.copy()
    core.reset_envs(np.array([False, True]))
    after = core.world.state
    assert np.array_equal(after[:2], before[:2]) and np.array_equal(after[bots], before[bots])
    assert not np.array_equal(after[2:4], before[2:4])  # copy 1's cars did move
