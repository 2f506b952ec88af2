"""An overlaid core (``RaceCore(overlay=True)``): each track's copies lie in the pymunk Space
where a core of that track alone puts them, over the other tracks' copies, which they pass
through; so each copy races as in its own core to the bit, pymunk's last bits included,
without moving cores to a common offset (``test_core_tracks.py`` does that)."""

from __future__ import annotations

import numpy as np
import pytest

from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.sim.tracks import MAX_OVERLAID_TRACKS
from h2h_racing.track.io import load_track

NAMES = ("oval", "speedway", "kidney")


def state(core: RaceCore, rows: slice | None = None) -> dict[str, np.ndarray]:
    rows = slice(None) if rows is None else rows
    return {name: getattr(core, name)[rows].copy()
            for name in ("position", "yaw", "velocity", "yaw_rate", "s", "d", "distance",
                         "laps", "done", "crashes", "collisions", "resets", "off_tracks",
                         "obstacle_position", "bot_position", "time")}


class Centre:
    """Pure pursuit of the centre line at 2.5 m/s, blind to boxes and bots."""

    def reset(self, core: RaceCore) -> None:
        pass

    def act(self, core: RaceCore, car: int) -> np.ndarray:
        from h2h_racing.policies.steering import pursuit_steer, to_action

        target = core.track.point_at(core.s[:, car] + 0.6)
        return to_action(core, pursuit_steer(core, car, target), np.full(core.num_envs, 2.5))


def race(mixed: RaceCore, alone: list[RaceCore], config: EnvConfig, steps: int
         ) -> tuple[list[dict[str, np.ndarray]], list[list[dict[str, np.ndarray]]]]:
    """Drive every copy along the centre line (``Centre``: into boxes and bots) in the
    overlaid core (a driver per track, on its view) and in the cores alone; the state after
    every step."""
    parts = [(rows, view, Centre()) for rows, view in mixed.track_views()]
    drivers = [Centre() for _ in alone]
    for (_, view, driver), core, own in zip(parts, alone, drivers):
        driver.reset(view)
        own.reset(core)
    mine: list[dict[str, np.ndarray]] = []
    theirs: list[list[dict[str, np.ndarray]]] = [[] for _ in alone]
    for _ in range(steps):
        actions = np.zeros((mixed.num_envs, 1, 2))
        for rows, view, driver in parts:
            actions[rows, 0] = driver.act(view, 0)
        mixed.step(*config.commands(actions))
        mine.append(state(mixed))
        for k, (core, own) in enumerate(zip(alone, drivers)):
            core.step(*config.commands(np.asarray(own.act(core, 0))[:, None, :]))
            theirs[k].append(state(core))
    return mine, theirs


def overlaid_and_alone(config: EnvConfig, tracks: list, copies: int, seeds: list[int]
                       ) -> tuple[RaceCore, list[RaceCore]]:
    mixed = RaceCore(config, tracks, num_envs=copies * len(tracks), overlay=True)
    mixed.seed_tracks(seeds)
    mixed.reset()
    alone = []
    for track, seed in zip(tracks, seeds):
        core = RaceCore(config, track, num_envs=copies)
        core.reset(seed=seed)
        alone.append(core)
    return mixed, alone


def test_each_track_is_laid_out_as_its_own_core() -> None:
    tracks = [load_track(n) for n in NAMES]
    config = EnvConfig(num_cars=2)
    mixed = RaceCore(config, tracks, num_envs=12, track_index=np.arange(12) % 3, overlay=True)
    for k, track in enumerate(tracks):
        alone = RaceCore(config, track, num_envs=4)
        assert np.array_equal(mixed.env_offset[k::3], alone.env_offset)
        assert np.array_equal(mixed._park[k::3], alone._park)
    apart = RaceCore(config, tracks, num_envs=12)
    # Without overlay every copy has a cell of its own.
    assert len({tuple(o) for o in apart.env_offset}) == 12


@pytest.mark.parametrize("kind", ["time_trial", "object_avoidance", "head_to_bot"])
def test_every_copy_races_as_in_its_own_core(kind: str) -> None:
    tracks = [load_track(n) for n in NAMES]
    extra = ({"rules": RaceRules.preset("time_trial", "training")} if kind == "time_trial"
             else {"randomize_obstacles": True} if kind == "object_avoidance" else {})
    config = EnvConfig(num_cars=1, race_type=kind, **extra)
    # Enough copies that each core alone has 64 bodies and sorts contacts by its spatial
    # hash, as the overlaid one does (evaluate_tracks.batchable).
    copies = 1 if kind == "time_trial" else 16
    mixed, alone = overlaid_and_alone(config, tracks, copies, [7, 8, 9])
    mine, theirs = race(mixed, alone, config, 200)
    for step in range(200):
        for k in range(3):
            rows = slice(copies * k, copies * (k + 1))
            for name, want in theirs[k][step].items():
                assert np.array_equal(mine[step][name][rows], want), (NAMES[k], step, name)
    if kind != "time_trial":  # the cars did run into boxes or bots
        assert mixed.crashes.sum() > 0


def test_copies_of_different_tracks_pass_through_each_other() -> None:
    """The same track twice: its two copies start at the same place and drive the same
    actions, so their cars overlap every step. Overlaid, neither feels the other (each is
    its own core's car); without the collision groups they would crash into each other."""
    oval = load_track("oval")
    config = EnvConfig(num_cars=1, race_type="time_trial",
                       rules=RaceRules.preset("time_trial", "training"))
    mixed = RaceCore(config, [oval, oval], num_envs=2, overlay=True)
    mixed.seed_tracks([0, 0])
    mixed.reset(start=np.zeros(2))
    alone = RaceCore(config, oval, num_envs=1)
    alone.reset(seed=0, start=np.zeros(1))
    assert np.array_equal(mixed.position[0], mixed.position[1])
    for _ in range(60):
        mixed.step(np.full((2, 1), 0.1), np.full((2, 1), 2.0))
        alone.step(np.full((1, 1), 0.1), np.full((1, 1), 2.0))
        assert np.array_equal(mixed.position[0], alone.position[0])
        assert np.array_equal(mixed.position[1], alone.position[0])
    assert mixed.collisions.sum() == 0


def test_overlay_settings_are_checked() -> None:
    oval = load_track("oval")
    config = EnvConfig(num_cars=1)
    with pytest.raises(ValueError, match=f"at most {MAX_OVERLAID_TRACKS} tracks"):
        RaceCore(config, [oval] * (MAX_OVERLAID_TRACKS + 1), num_envs=33, overlay=True)
    with pytest.raises(TypeError, match="overlay must be True or False"):
        RaceCore(config, oval, overlay=1)  # type: ignore[arg-type]
    core = RaceCore(config, [oval, oval], num_envs=2)
    with pytest.raises(ValueError, match="one seed per track"):
        core.seed_tracks([1])
    with pytest.raises(ValueError, match="a seed for every track"):
        core.seed_tracks([1, None])  # type: ignore[list-item]
