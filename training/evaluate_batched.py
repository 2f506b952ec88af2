"""Drivers that act once per core step for every run of a core (``training.evaluate_tracks``).

``_race_all`` races several runs (a driver on a track) as the copies of one core. A run's
driver, built for a core of its track alone, acts on its own copies (a ``CoreView``): one
``act`` call per run and step, ~0.1-0.3 ms each, most of a route evaluation's time. The
batched drivers here act for the copies of every run of a group (the runs of one driver spec)
in one call, and give each copy the bits that its own driver gives it:

- ``BatchedPolicy``: a trained MLP in numpy (``policies.trained_numpy``) over the rows of
  every run in one forward pass. A row of a BLAS matmul does not get the same bits whatever
  the batch (OpenBLAS's sgemm handles rows in groups, a partial group with another kernel);
  the numpy actor multiplies each run's block of copies as tiles of its own, sized by the
  block alone, so that a run's rows get the bits they get alone. That is checked, not
  assumed: before a group is batched, random inputs are passed both ways, one forward pass
  of all the group's rows against one per run's block, at the sizes the race uses (they do
  not change during a race: a done copy is stepped on with the others); a row that differs
  keeps the group on one call per run. The kernels depend on the shapes only, not on the
  values, so random inputs stand for the race's.
- ``BatchedRacingLine``: ``racing_line``'s time-trial ``act`` over the copies of every run,
  each row reading its own run's line and track tables by index (``RowTables``): the same
  numpy operations per element, with ``np.interp``'s arithmetic written out
  (``interp_rows``), so no Python loop over the runs in a step.

Anything else (camera or lidar policies, an MLP acting with torch, other drivers,
``racing_line`` with other cars, boxes or bots) acts one run at a time, as before. Camera
policies render a camera per track and run rsl-rl's CNN, whose convolutions pick oneDNN
kernels by batch size too; they are left as they were.
"""

from __future__ import annotations

from collections.abc import Sequence
from types import SimpleNamespace
from typing import Any

import numpy as np
import numpy.typing as npt

from h2h_racing.policies.scripted import RacingLine
from h2h_racing.policies.steering import lookahead, pursuit_steer, to_action
from h2h_racing.policies.trained import TrainedPolicy
from h2h_racing.policies.trained_numpy import NumpyActor

FloatArray = npt.NDArray[np.float64]
IndexArray = npt.NDArray[np.int64]


class RowTables:
    """Several piecewise-linear tables ``(xp_k, fp_k)`` stored end to end, read per row.

    Each row ``i`` of a query reads table ``table[i]``: ``interp(x)`` is
    ``np.interp(x[i], xp_k, fp_k)`` for every row, to the bit (``interp_rows``).
    """

    def __init__(self, tables: Sequence[tuple[FloatArray, FloatArray]]) -> None:
        sizes = np.array([len(xp) for xp, _ in tables], dtype=np.int64)
        if np.any(sizes < 2):
            raise ValueError("each table needs at least 2 points")
        self.start = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        self.last = self.start + sizes - 1
        self.xp = np.concatenate([np.asarray(xp, dtype=np.float64) for xp, _ in tables])
        self.fp = np.concatenate([np.asarray(fp, dtype=np.float64) for _, fp in tables])
        # Complex numbers sort by real part, then imaginary part: (table, x) pairs in order,
        # so one searchsorted finds each row's interval in its own table, exactly.
        self._keys = np.repeat(np.arange(len(tables), dtype=np.float64), sizes) + 1j * self.xp

    def interp(self, x: FloatArray, table: IndexArray) -> FloatArray:
        """``np.interp(x[i], xp_k, fp_k)`` with ``k = table[i]`` (``x``: (R,) or (R, C);
        ``table``: (R,))."""
        table = table.reshape(table.shape + (1,) * (x.ndim - 1))
        return interp_rows(self, x, np.broadcast_to(table, x.shape))


def interp_rows(tables: RowTables, x: FloatArray, table: IndexArray) -> FloatArray:
    """``np.interp`` of each element of ``x`` in its own table, as numpy computes it
    (``numpy/_core/src/multiarray/compiled_base.c``, ``arr_interp``): left of the first point
    ``fp[0]``, right of the last ``fp[-1]``, on the last point ``fp[-1]``, on a point ``xp[j]``
    exactly ``fp[j]``, else ``slope * (x - xp[j]) + fp[j]`` with ``slope = (fp[j+1] - fp[j]) /
    (xp[j+1] - xp[j])`` and ``xp[j] <= x < xp[j+1]`` (a NaN tried from the other end)."""
    x = np.asarray(x, dtype=np.float64)
    start, last = tables.start[table], tables.last[table]
    j = np.searchsorted(tables._keys, table + 1j * x, side="right") - 1
    xp, fp = tables.xp, tables.fp
    k = np.clip(j, start, last - 1)
    # A repeated point divides by zero; numpy's C loop does so silently, and its result is
    # replaced below (x on the point, or NaN tried from the other end).
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = (fp[k + 1] - fp[k]) / (xp[k + 1] - xp[k])
        out = slope * (x - xp[k]) + fp[k]
        bad = np.isnan(out)
        if bad.any():
            other = slope * (x - xp[k + 1]) + fp[k + 1]
            flat = np.isnan(other) & (fp[k] == fp[k + 1])
            out = np.where(bad, np.where(flat, fp[k], other), out)
    out = np.where(xp[k] == x, fp[k], out)
    out = np.where(j >= last, fp[last], out)
    out = np.where(x < xp[start], fp[start], out)
    return np.where(x > xp[last], fp[last], out)


class BatchedPolicy:
    """One forward pass of a trained MLP over the copies of several runs (same weights).

    Args:
        driver: One of the runs' drivers (reset).
        block: Copies of each run; run r has the rows ``r * block ... (r + 1) * block - 1``
            of the rows ``act`` is given.
    """

    def __init__(self, driver: TrainedPolicy, block: int) -> None:
        self.forward: NumpyActor = driver._forward
        self.driver = driver
        self.block = block

    @staticmethod
    def fits(drivers: Sequence[Any]) -> bool:
        """Whether ``drivers`` (reset on their views) are trained MLPs acting in numpy on state
        observations only."""
        # The class itself: a subclass may act otherwise.
        return all(type(d) is TrainedPolicy and isinstance(d._forward, NumpyActor)
                   and d._camera is None and d._lidar is None for d in drivers)

    def invariant(self, runs: int, seed: int = 0) -> bool:
        """Whether a forward pass of ``runs`` blocks gives each row the bits of its block
        alone, as its run's own driver computes it (random inputs of the observation groups'
        widths)."""
        example = self.driver._example
        assert example is not None
        block = self.block
        rng = np.random.default_rng(seed)
        obs = {k: rng.normal(size=(runs * block, v.shape[1])).astype(np.float32)
               for k, v in example.items()}
        whole = self.forward(obs, block)
        for r in range(runs):
            part = {k: np.ascontiguousarray(v[r * block:(r + 1) * block])
                    for k, v in obs.items()}
            if not np.array_equal(self.forward(part), whole[r * block:(r + 1) * block]):
                return False
        return True

    def act(self, core: Any, rows: IndexArray, car: int) -> npt.NDArray[np.float32]:
        """Actions of car ``car`` in copies ``rows`` of ``core``, as ``TrainedPolicy.act``."""
        from h2h_racing.sensors.state import MOTION_FEATURES, state_observation

        # TrainedPolicy._observe's groups, of the rows (the state is per copy).
        state = state_observation(core)[rows, car]
        obs = {"policy": np.ascontiguousarray(state),
               "motion": np.ascontiguousarray(state[:, list(MOTION_FEATURES)])}
        return np.clip(self.forward(obs, self.block), -1.0, 1.0).astype(np.float32)


class BatchedRacingLine:
    """``RacingLine.act`` of several runs' drivers (one car, no boxes, no bots) in one call.

    Args:
        drivers: The runs' ``RacingLine`` drivers, reset on their views (their lines set).
        block: Copies of each run; run r has the rows ``r * block ... (r + 1) * block - 1``
            of the rows ``act`` is given.
    """

    def __init__(self, drivers: Sequence[RacingLine], block: int) -> None:
        first = drivers[0]
        self.settings = (first.lookahead_base, first.lookahead_gain, first.speed_preview)
        self.block = block
        runs = len(drivers)
        self.run = np.repeat(np.arange(runs, dtype=np.int64), block)
        lines = [d.line for d in drivers]
        self.length = np.array([line.track_length for line in lines])[self.run]
        self.ds = np.array([line.track_length / len(line.s) for line in lines])
        self.speeds = RowTables([(line._grid, line._closed["speed"]) for line in lines])
        # RaceLine.point_at: the line's own points (alone on its line, RacingLine steers
        # at them), closed by the first.
        self.px = RowTables([(line._grid, np.append(line.points[:, 0], line.points[0, 0]))
                             for line in lines])
        self.py = RowTables([(line._grid, np.append(line.points[:, 1], line.points[0, 1]))
                             for line in lines])

    @staticmethod
    def fits(drivers: Sequence[Any], core: Any) -> bool:
        """Whether ``drivers`` are ``RacingLine`` drivers of one setting, with lines, in a
        core of one car without boxes or bots (``RacingLine.act`` then only follows its
        line)."""
        if core.num_cars != 1 or core.num_bots or core.num_obstacles:
            return False
        if not all(type(d) is RacingLine and d.line is not None for d in drivers):
            return False
        first = drivers[0]
        key = (first.lookahead_base, first.lookahead_gain, first.speed_preview)
        return all((d.lookahead_base, d.lookahead_gain, d.speed_preview) == key
                   for d in drivers)

    def _min_speed_ahead(self, s: FloatArray, horizon: FloatArray) -> FloatArray:
        """``RaceLine.min_speed_ahead`` of each run's rows: its sample count from its own
        rows' longest horizon, the shorter runs' samples padded with their last (``frac`` 1:
        a repeat does not change a minimum)."""
        longest = horizon.reshape(-1, self.block).max(axis=1)
        count = np.maximum(1, np.ceil(longest / self.ds)).astype(np.int64) + 1
        width = int(count.max())
        per_row = count[self.run]
        j = np.arange(width, dtype=np.int64)
        # np.linspace(0, 1, n): arange(n) * (1 / (n - 1)), its last point set to 1.
        step = 1.0 / (per_row - 1).astype(np.float64)
        frac = np.minimum(j[None, :], (per_row - 1)[:, None]) * step[:, None]
        frac = np.where(j[None, :] >= (per_row - 1)[:, None], 1.0, frac)
        samples = s[:, None] + horizon[:, None] * frac
        wrapped = np.remainder(samples, self.length[:, None])
        return self.speeds.interp(wrapped, self.run).min(axis=-1)

    def act(self, core: Any, rows: IndexArray, car: int) -> npt.NDArray[np.float32]:
        """Actions of car ``car`` in copies ``rows`` of ``core`` (the runs' rows in order)."""
        base, gain, preview = self.settings
        s = core.s[rows, car]
        v = core.speed[rows, car]
        ld = lookahead(v, base, gain, 1.5)
        s_target = s + ld
        horizon = np.maximum(v, 1.0) * preview
        speed = self._min_speed_ahead(s, horizon)
        wrapped = np.remainder(s_target, self.length)
        target = np.stack([self.px.interp(wrapped, self.run), self.py.interp(wrapped, self.run)],
                          axis=-1)
        rows_core = SimpleNamespace(config=core.config, yaw=core.yaw[rows],
                                    position=core.position[rows])
        steer = pursuit_steer(rows_core, car, target)  # type: ignore[arg-type]
        return to_action(rows_core, steer, speed)  # type: ignore[arg-type]


def batched_driver(drivers: Sequence[Any], core: Any,
                   block: int) -> BatchedPolicy | BatchedRacingLine | None:
    """A batched driver for the runs of ``drivers`` (same spec, each reset on its run's view
    of ``core``, ``block`` copies each), or None where they act one run at a time (see the
    module docstring)."""
    if len(drivers) < 2:
        return None
    if BatchedPolicy.fits(drivers):
        policy = BatchedPolicy(drivers[0], block)
        return policy if policy.invariant(len(drivers)) else None
    if BatchedRacingLine.fits(drivers, core):
        return BatchedRacingLine(drivers, block)
    return None
