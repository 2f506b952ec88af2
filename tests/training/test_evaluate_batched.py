"""``training.evaluate_batched``: one driver call for the copies of several runs gives every
copy the bits that its own run's driver gives it on its view."""

from __future__ import annotations

import numpy as np
import pytest

from h2h_racing.policies import make_driver
from h2h_racing.sim.core import RaceCore
from h2h_racing.track.io import load_track
from h2h_racing.training.evaluate import evaluate, lap_config, lap_starts
from h2h_racing.training.evaluate_batched import (BatchedPolicy, BatchedRacingLine, RowTables,
                                                  batched_driver)
from h2h_racing.training.evaluate_routes import one_torch_thread
from h2h_racing.training.evaluate_tracks import Run, lap_runs

NAMES = ("oval", "kidney", "speedway")


def test_interp_rows_is_np_interp_to_the_bit() -> None:
    rng = np.random.default_rng(3)
    tables = []
    for size in (2, 7, 40):
        xp = np.sort(rng.uniform(-3.0, 30.0, size))
        xp[size // 2:size // 2 + 1] = xp[size // 2 - 1]  # a repeated point
        tables.append((xp, rng.normal(size=size)))
    rows = RowTables(tables)
    table = rng.integers(0, 3, 600)
    x = rng.uniform(-5.0, 33.0, 600)
    # On the points, on the ends and beyond them.
    x[:3] = [tables[t][0][0] for t in table[:3]]
    x[3:6] = [tables[t][0][-1] for t in table[3:6]]
    x[6:9] = [tables[t][0][1] for t in table[6:9]]
    want = np.array([np.interp(v, *tables[t]) for v, t in zip(x, table)])
    got = rows.interp(x, table)
    assert np.array_equal(got, want)
    # Columns of one row read that row's table.
    grid = np.stack([x[:50], x[50:100]], axis=1)
    assert np.array_equal(rows.interp(grid, table[:50]),
                          np.stack([want[:50], [np.interp(v, *tables[t])
                                                for v, t in zip(x[50:100], table[:50])]], 1))


def _core(block: int) -> tuple[RaceCore, list]:
    tracks = [load_track(n) for n in NAMES]
    core = RaceCore(lap_config(NAMES[0]), tracks, num_envs=block * len(tracks), overlay=True)
    core.seed_tracks([0, 5, 9])
    core.reset(start=np.concatenate([lap_starts(t, block) for t in tracks]))
    return core, core.track_views()


@pytest.mark.parametrize("spec", ["racing_line", "racing_line:grip_factor=0.5",
                                  "ppo_generalist"])
def test_batched_driver_acts_as_each_runs_driver(spec: str) -> None:
    """Every step, each copy's action from the batched driver is its run's driver's, to the
    bit, while the cars drive off their starts (run 0 faster than its driver wants, run 2
    slower: a preview's sample count is each run's own)."""
    block = 5
    core, views = _core(block)
    drivers = [make_driver(spec, seed=0) for _ in views]
    for driver, (_, view) in zip(drivers, views):
        driver.reset(view)
    every = np.arange(core.num_envs)
    union = np.concatenate([every[rows] for rows, _ in views])
    with one_torch_thread():
        batched = batched_driver(drivers, core, block)
        assert isinstance(batched, BatchedPolicy if spec == "ppo_generalist"
                          else BatchedRacingLine)
        config = core.config
        for _ in range(40):
            want = np.concatenate([d.act(view, 0) for d, (_, view) in zip(drivers, views)])
            got = batched.act(core, union, 0)
            assert got.dtype == want.dtype and np.array_equal(got, want)
            actions = np.zeros((core.num_envs, 2))
            actions[union] = want
            # Run 0 at full throttle, run 2 slow: the runs' longest speed previews differ.
            actions[every[views[0][0]], 1] = 1.0
            actions[every[views[2][0]], 1] = -0.8
            core.step(*config.commands(actions[:, None, :]))
    assert core.speed[every[views[0][0]], 0].max() > 2 * core.speed[every[views[2][0]], 0].max()


SHIPPED_MLPS = ("ppo_generalist", "obstacle_generalist", "league_racer",
                "racing_line_student")


@pytest.mark.parametrize("name", SHIPPED_MLPS)
def test_policy_batches_only_where_its_rows_keep_their_bits(name: str) -> None:
    """``invariant`` says what a forward pass of the runs' rows does to a row: checked here
    against the network itself at 1-5, 10, 17 and 40 rows a run, on every shipped MLP policy
    (the numpy actor multiplies each run's block as tiles of its own, so every size keeps its
    bits), and against a forward pass that takes all rows as one block (OpenBLAS gives a row
    other bits by where it sits: such a group would stay one call per run)."""
    core, views = _core(5)
    driver = make_driver(name, seed=0)
    driver.reset(views[0][1])
    assert BatchedPolicy.fits([driver])
    rng = np.random.default_rng(0)
    for block in (1, 2, 3, 4, 5, 10, 17, 40):
        policy = BatchedPolicy(driver, block)
        obs = {k: rng.normal(size=(3 * block, v.shape[1])).astype(np.float32)
               for k, v in driver._example.items()}
        whole = policy.forward(obs, block)
        parts = np.concatenate([policy.forward(
            {k: np.ascontiguousarray(v[r * block:(r + 1) * block]) for k, v in obs.items()})
            for r in range(3)])
        assert np.array_equal(whole, parts)
        assert policy.invariant(3)
    # A forward pass blind to the blocks (15 rows as one: on OpenBLAS, other bits), and one
    # whose rows change with the batch size: the check must see what they do to the rows.
    obs = {k: rng.normal(size=(15, v.shape[1])).astype(np.float32)
           for k, v in driver._example.items()}
    actor = BatchedPolicy(driver, 5).forward
    parts = np.concatenate([actor({k: np.ascontiguousarray(v[r * 5:(r + 1) * 5])
                                   for k, v in obs.items()}) for r in range(3)])
    blind = BatchedPolicy(driver, 5)
    blind.forward = lambda obs, block=None: actor(obs)  # type: ignore[assignment,misc]
    assert blind.invariant(3) == np.array_equal(actor(obs), parts)
    sized = BatchedPolicy(driver, 5)
    sized.forward = lambda obs, block=None: (  # type: ignore[assignment,misc]
        actor(obs, block) + np.float32(1e-3) * len(obs["policy"]))
    assert not sized.invariant(3)


def test_lap_runs_of_two_copies_are_evaluate_to_the_bit() -> None:
    """Blocks of 2 copies: the policy's runs act one by one (``invariant``), racing_line's
    together; the figures are ``evaluate``'s."""
    tracks = [load_track(n) for n in NAMES]
    runs = [Run(driver, track, seed) for track, seed in zip(tracks, (0, 5, 9))
            for driver in ("ppo_generalist", "racing_line")]
    with one_torch_thread():
        got = lap_runs(runs, 2)
        want = [evaluate(run.driver, run.track, episodes=2, seed=run.seed) for run in runs]
    assert got == want
