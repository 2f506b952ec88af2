"""Race rules as pure functions over batched arrays.

Every function takes arrays with leading axes ``(E, N)`` (env copies, cars) or flat
arrays, returns new arrays and has no side effects, so the rules are testable without
physics. The simulation core (``h2h_racing.core``) calls them once per step.

Conventions:
    distance: unwrapped arc length driven along the centre line [m], measured from the
        start line (negative behind it on the grid); it grows by one track length per lap.
    racing: cars that are neither frozen by a penalty nor done.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]


def wrap_arc(delta_s: FloatArray, length: float) -> FloatArray:
    """Wrap an arc-position difference into [-length/2, length/2).

    >>> float(wrap_arc(np.array(9.5), 10.0))   # 9.5 m forward on a 10 m lap is 0.5 m back
    -0.5
    """
    half = 0.5 * length
    return np.mod(delta_s + half, length) - half


def count_laps(distance: FloatArray, lap_origin: FloatArray, length: float) -> IntArray:
    """Return the number of complete laps driven since ``lap_origin``.

    A lap is complete each time ``distance - lap_origin`` reaches a multiple of the track
    length; a car behind its origin has completed 0 laps.

    >>> count_laps(np.array([-0.7, 0.0, 9.99, 10.0, 25.0]), np.zeros(5), 10.0).tolist()
    [0, 0, 0, 1, 2]
    """
    laps = np.floor((distance - lap_origin) * (1.0 / length)).astype(np.int64)
    return np.maximum(laps, 0)


def crossing_time(time: FloatArray | float, dt: float, distance: FloatArray,
                  step_distance: FloatArray, line: FloatArray) -> FloatArray:
    """Interpolate when a car crossed ``line`` during the last step.

    The car moved from ``distance - step_distance`` to ``distance`` during the step that
    ended at ``time``; assuming constant speed within the step it reached ``line`` at
    ``time - dt * (distance - line) / step_distance``.

    >>> round(float(crossing_time(1.0, 0.1, np.array(10.2), np.array(0.4), np.array(10.0))), 9)
    0.95
    """
    fraction = (distance - line) / np.maximum(step_distance, 1e-12)
    fraction = np.minimum(np.maximum(fraction, 0.0), 1.0)
    return time - dt * fraction


def all_wheels_off(lateral: FloatArray, width_left: FloatArray,
                   width_right: FloatArray) -> BoolArray:
    """Return True where every wheel is off the track surface (DeepRacer's off-track rule).

    Args:
        lateral: Signed lateral offset of each wheel, shape (..., W), metres, left positive.
        width_left: Track width left of the centre line at each wheel, shape (..., W).
        width_right: Track width right of the centre line at each wheel, shape (..., W).

    Returns:
        Shape (...): True when no wheel is on the surface; a car partly off is on track.
    """
    on = (lateral <= width_left) & (lateral >= -width_right)
    return ~np.any(on, axis=-1)


def consecutive(count: IntArray, condition: BoolArray) -> IntArray:
    """Count consecutive steps for which ``condition`` held (reset to 0 when it fails).

    >>> consecutive(np.array([3, 3]), np.array([True, False])).tolist()
    [4, 0]
    """
    return (count + 1) * condition


def judge_contacts(body_a: IntArray, body_b: IntArray, num_envs: int, num_cars: int,
                   num_obstacles: int, distance: FloatArray, racing: BoolArray,
                   ) -> tuple[BoolArray, BoolArray, list[tuple[int, int, int, bool]]]:
    """Decide who caused each new contact, as DeepRacer judges crashes.

    Car-car contact: the car behind (smaller ``distance``) is at fault; the car ahead
    continues. Car-obstacle contact: the car is at fault. Only racing cars are judged.

    Args:
        body_a: First body of each new contact, flat body index, shape (P,). Cars are
            ``e * num_cars + n``; obstacles follow all cars as
            ``num_envs * num_cars + e * num_obstacles + k``.
        body_b: Second body of each contact, shape (P,).
        num_envs: E.
        num_cars: N.
        num_obstacles: Obstacles per env copy.
        distance: Race distance of each car, shape (E, N), metres.
        racing: Which cars are racing, shape (E, N).

    Returns:
        ``(at_fault (E, N), collided (E, N), events)``: events are
        ``(env, car, other, other_is_obstacle)`` with ``car`` the car at fault (behind)
        and ``other`` the car or obstacle index it hit, in pymunk's report order.
    """
    at_fault = np.zeros((num_envs, num_cars), dtype=bool)
    collided = np.zeros((num_envs, num_cars), dtype=bool)
    events: list[tuple[int, int, int, bool]] = []
    total_cars = num_envs * num_cars
    flat_distance = distance.reshape(-1)
    flat_racing = racing.reshape(-1)
    # Each contact involves at most a few bodies; there are few contacts per step, so this
    # loop runs over contact events (usually none), never over cars or env copies.
    for a, b in zip(body_a.tolist(), body_b.tolist()):
        if a >= total_cars and b >= total_cars:
            continue
        if a >= total_cars:
            a, b = b, a
        env, car = divmod(a, num_cars)
        if b >= total_cars:
            obstacle = (b - total_cars) % max(num_obstacles, 1)
            collided[env, car] = True
            if flat_racing[a]:
                at_fault[env, car] = True
                events.append((env, car, obstacle, True))
            continue
        other = b % num_cars
        collided[env, car] = True
        collided[env, other] = True
        behind, ahead = (a, b) if flat_distance[a] <= flat_distance[b] else (b, a)
        if flat_racing[behind]:
            at_fault.reshape(-1)[behind] = True
            events.append((env, behind % num_cars, ahead % num_cars, False))
    return at_fault, collided, events


def race_order_key(distance: FloatArray, finished: BoolArray, finish_time: FloatArray,
                   best_lap: FloatArray, ranking: str) -> FloatArray:
    """Return a key per car whose ascending order is the race order (leader first).

    ``total_time``: finished cars first, by finish time; then by distance driven.
    ``best_lap``: by best valid lap time; cars without one by distance driven.
    """
    if ranking == "best_lap":
        has_lap = np.isfinite(best_lap)
        return np.where(has_lap, best_lap - 1e9, -distance)
    return np.where(finished, finish_time - 1e12, -distance)


def ranks(key: FloatArray) -> IntArray:
    """Return 1-based ranks along the last axis from an ascending key (ties: lower index).

    >>> ranks(np.array([[-3.0, -5.0, -4.0]])).tolist()
    [[3, 1, 2]]
    """
    # The rank of a car is the position of its index in the sorted order: argsort of argsort.
    order = np.argsort(key, axis=-1, kind="stable")
    return np.argsort(order, axis=-1, kind="stable") + 1


def pairwise_gap(distance: FloatArray) -> FloatArray:
    """Return ``gap[e, i, j] = distance[e, i] - distance[e, j]`` (positive: i ahead of j)."""
    return distance[:, :, None] - distance[:, None, :]


def detect_overtakes(prev_gap: FloatArray, gap: FloatArray, eligible: BoolArray,
                     length: float) -> BoolArray:
    """Return ``passed[e, i, j]``: car i passed car j on track during this step.

    A pass is a change of the gap from behind (< 0) to ahead (> 0) while both cars were
    racing before and after the step and neither was re-placed (``eligible[e, i, j]``),
    and the gap stayed below half a lap (so a lapped car is not 'passed' by a jump).
    """
    close = np.abs(gap) < 0.5 * length
    return (prev_gap < 0.0) & (gap > 0.0) & eligible & close


def update_pressure(pressure: FloatArray, faster: BoolArray, gap: FloatArray,
                    speed: FloatArray, eligible: BoolArray, passed: BoolArray, dt: float,
                    gap_limit: float, time_limit: float,
                    ) -> tuple[FloatArray, BoolArray, BoolArray]:
    """Track attackers close behind a car and count successful defences.

    Car i pressures car j when it is racing less than ``gap_limit`` metres behind it
    (``0 < -gap[e, i, j] < gap_limit``). A defence by j against i is counted when i stops
    pressuring j after at least ``time_limit`` seconds of pressure, having been the faster
    car at some moment of it, without passing.

    Args:
        pressure: Seconds of continuous pressure by i on j, shape (E, N, N).
        faster: Whether i was faster than j at some moment of the current pressure.
        gap: Current pairwise gap, shape (E, N, N), metres.
        speed: Forward speed of each car, shape (E, N), m/s.
        eligible: Both cars racing, shape (E, N, N).
        passed: Overtakes this step, shape (E, N, N).
        dt: Step length [s].
        gap_limit: Pressure distance [m].
        time_limit: Pressure duration that makes a defence [s].

    Returns:
        ``(pressure, faster, defended)`` with ``defended[e, i, j]`` True when j completed a
        defence against i on this step.
    """
    close = eligible & (gap < 0.0) & (gap > -gap_limit)
    quicker = speed[:, :, None] > speed[:, None, :]
    ended = (~close) & (pressure >= time_limit) & faster & ~passed
    pressure = np.where(close, pressure + dt, 0.0)
    faster = close & (faster | quicker)
    return pressure, faster, ended
