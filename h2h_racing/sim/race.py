"""Race rules as pure functions over batched arrays.

Every function takes arrays with leading axes ``(E, N)`` (env copies, cars) or flat
arrays, returns new arrays and has no side effects, so the rules are testable without
physics. The simulation core (``h2h_racing.sim.core``) calls them once per step.

Conventions:
    distance: unwrapped arc length driven along the centre line [m], measured from the
        start line (negative behind it on the grid); it grows by one track length per lap.
    racing: cars that are neither frozen by a penalty nor done.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from h2h_racing.track import tables as tt
from h2h_racing.track.lookup import lookup_span, wrap_arc
from h2h_racing.track.tables import project_on


FloatArray = npt.NDArray[np.float64]

TIME_EPS = 1e-9
"""Times closer than this [s] are equal. Simulated time is ``steps * dt``, and penalties and
limits are decimal seconds that ``dt = 1/15 s`` does not divide exactly in binary floating
point (75 * (1/15) may differ from 5.0 in the last bit)."""
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]


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


def judge_bot_contacts(body_a: IntArray, body_b: IntArray, num_envs: int, num_cars: int,
                       first_bot: int, num_bots: int, s: FloatArray, bot_s: FloatArray,
                       length: float | FloatArray, racing: BoolArray, done: BoolArray,
                       ) -> tuple[BoolArray, BoolArray, list[tuple[int, int, int, bool]],
                                  BoolArray]:
    """Decide who caused each new contact between a car and a bot, as DeepRacer judges it.

    The one behind along the track is at fault, by the wrapped arc gap
    ``g = wrap(bot_s - s)`` in [-L/2, L/2) between their centres: ``g >= 0`` (the bot is
    ahead, or level) makes the car, if racing, the crashing car; ``g < 0`` means the bot ran
    into the car from behind, and every bot of that env copy pauses (the car goes free).
    Contacts with a parked car, and bot-bot or bot-obstacle pairs, are ignored.

    Args:
        body_a: First body of each new contact, flat body index, shape (P,). Cars are
            ``e * num_cars + n``; bots are ``first_bot + e * num_bots + j``.
        body_b: Second body of each contact, shape (P,).
        num_envs: E.
        num_cars: N.
        first_bot: Flat body index of bot 0 of env copy 0.
        num_bots: Bots per env copy B.
        s: Arc position of each car, shape (E, N) [m].
        bot_s: Arc position of each bot, shape (E, B) [m].
        length: Lap length L [m], one for every copy or each copy's, shape (E,).
        racing: Which cars are racing, shape (E, N).
        done: Which cars are done (parked), shape (E, N).

    Returns:
        ``(at_fault (E, N), collided (E, N), events, pause (E,))``: events are
        ``(env, car, bot, car_at_fault)`` in pymunk's report order.
    """
    lengths = np.broadcast_to(np.asarray(length, dtype=np.float64), (num_envs,))
    at_fault = np.zeros((num_envs, num_cars), dtype=bool)
    collided = np.zeros((num_envs, num_cars), dtype=bool)
    pause = np.zeros(num_envs, dtype=bool)
    events: list[tuple[int, int, int, bool]] = []
    total_cars = num_envs * num_cars
    # Loops over this step's few new contacts (usually none), never over cars or copies.
    for a, b in zip(body_a.tolist(), body_b.tolist()):
        if a >= total_cars:
            a, b = b, a
        if a >= total_cars or b < first_bot:
            continue
        env, car = divmod(a, num_cars)
        bot = (b - first_bot) % num_bots
        if done[env, car]:
            continue
        collided[env, car] = True
        gap = wrap_arc(bot_s[env, bot] - s[env, car], lengths[env])
        if gap >= 0.0:
            # A frozen car that a bot ahead touches (being pushed back onto it) is not judged.
            if racing[env, car]:
                at_fault[env, car] = True
                events.append((env, car, bot, True))
        else:
            pause[env] = True
            events.append((env, car, bot, False))
    return at_fault, collided, events, pause


def race_ranks(distance: FloatArray, finished: BoolArray, finish_time: FloatArray,
               best_lap: FloatArray, ranking: str) -> IntArray:
    """Return each car's race position (1 = leader), shape (E, N).

    ``total_time``: finished cars first, by finish time; then by distance driven.
    ``best_lap``: by best valid lap time; cars without one after them, by distance driven.
    Exact ties go to the lower car index.

    >>> race_ranks(np.array([[3.0, 5.0, 4.0]]), np.zeros((1, 3), bool), np.full((1, 3), np.inf),
    ...            np.full((1, 3), np.inf), "total_time").tolist()
    [[3, 1, 2]]
    """
    out = np.empty(distance.shape, dtype=np.int64)
    _rank_kernel(distance, finished, finish_time, best_lap, ranking == "best_lap", out)
    return out


@njit(cache=True, inline="always")
def _order_key(distance, finished, finish_time, best_lap, by_best_lap):  # pragma: no cover
    # Ascending key: finished cars (or cars with a valid lap) first, by time, then by distance.
    if by_best_lap:
        return (0.0, best_lap) if best_lap < np.inf else (1.0, -distance)
    return (0.0, finish_time) if finished else (1.0, -distance)


@njit(cache=True)
def _rank_kernel(distance, finished, finish_time, best_lap, by_best_lap, out):  # pragma: no cover
    # rank_i = 1 + the number of cars ordered before i (smaller key, or equal key and lower
    # index): O(N^2) per env copy, which beats sorting for the few cars of a race.
    for e in range(distance.shape[0]):
        for i in range(distance.shape[1]):
            ki = _order_key(distance[e, i], finished[e, i], finish_time[e, i], best_lap[e, i],
                            by_best_lap)
            r = 1
            for j in range(distance.shape[1]):
                kj = _order_key(distance[e, j], finished[e, j], finish_time[e, j],
                                best_lap[e, j], by_best_lap)
                if kj < ki or (kj == ki and j < i):
                    r += 1
            out[e, i] = r


def overtakes_and_defences(distance: FloatArray, prev_gap: FloatArray, eligible: BoolArray,
                           speed: FloatArray, pressure: FloatArray, faster: BoolArray,
                           length: float | FloatArray, dt: float, gap_limit: float,
                           time_limit: float,
                           ) -> tuple[FloatArray, BoolArray, BoolArray]:
    """Detect on-track passes and completed defences between every pair of cars.

    With ``gap[e, i, j] = distance[e, i] - distance[e, j]`` (positive: i ahead of j):

    - car i **passed** car j when the gap changed from behind (< 0) to ahead (> 0) while both
      were racing before and after the step and neither was re-placed (``eligible[e, i]``
      and ``eligible[e, j]``), and the gap stayed below half a lap (a lapped car is not
      passed by a jump of one lap);
    - car i **pressures** car j while racing less than ``gap_limit`` metres behind it;
      ``pressure`` counts the seconds, ``faster`` whether i was faster than j at some moment
      of it. A **defence** by j against i is counted when i stops pressuring j after at least
      ``time_limit`` seconds, having been faster at some moment, without passing.

    Args:
        distance: Race distance after the step, (E, N) [m].
        prev_gap: ``gap`` before the step, (E, N, N) [m].
        eligible: Cars racing before and after the step and not re-placed, (E, N).
        speed: Forward speed after the step, (E, N) [m/s].
        pressure: Seconds of continuous pressure by i on j, (E, N, N); updated in place.
        faster: Whether i was faster than j during the current pressure; updated in place.
        length: Lap length [m], one for every copy or each copy's, shape (E,).
        dt: Step length [s].
        gap_limit: Pressure distance [m].
        time_limit: Pressure duration that makes a defence [s].

    Returns:
        ``(gap (E, N, N), passed (E, N, N), defended (E, N, N))`` with ``passed[e, i, j]``:
        i passed j on this step, ``defended[e, i, j]``: j completed a defence against i.
    """
    e, n = distance.shape
    pair_floats = np.stack([prev_gap, pressure]).astype(np.float64)
    pair_flags = np.zeros((len(PAIR_FLAGS), e, n, n), dtype=np.bool_)
    pair_flags[0] = faster
    lengths = np.broadcast_to(np.asarray(length, dtype=np.float64), (e,)).copy()
    pairs_kernel(distance, eligible, speed, pair_floats, pair_flags, lengths, dt, gap_limit,
                 time_limit)
    pressure[...] = pair_floats[1]
    faster[...] = pair_flags[0]
    return pair_floats[0], pair_flags[1], pair_flags[2]





@njit(cache=True)
def pairs_kernel(distance, eligible, speed, pair_floats, pair_flags, lengths, dt, gap_limit,
                 time_limit):  # pragma: no cover
    """The compiled kernel behind :func:`overtakes_and_defences` (the core's hot path).

    ``lengths`` (E,) is each copy's lap length [m]. The pair arrays come as two blocks (rows
    as in ``PAIR_FLOATS`` and ``PAIR_FLAGS``):
    ``gap`` holds the gaps before the step and is overwritten with those after it (each
    entry is read before it is written), ``pressure`` and ``faster`` are updated in place,
    ``passed`` and ``defended`` are filled (every entry is written); returns
    ``(any passed, any defended)``.
    """
    gap, pressure = pair_floats[0], pair_floats[1]
    faster, passed, defended = pair_flags[0], pair_flags[1], pair_flags[2]
    any_passed = False
    any_defended = False
    for e in range(distance.shape[0]):
        half = 0.5 * lengths[e]
        for i in range(distance.shape[1]):
            for j in range(distance.shape[1]):
                before = gap[e, i, j]
                g = distance[e, i] - distance[e, j]
                gap[e, i, j] = g
                both = i != j and eligible[e, i] and eligible[e, j]
                did_pass = both and before < 0.0 < g and abs(g) < half
                passed[e, i, j] = did_pass
                any_passed = any_passed or did_pass
                close = both and -gap_limit < g < 0.0
                held = (both and not close and pressure[e, i, j] >= time_limit
                        and faster[e, i, j] and not did_pass)
                defended[e, i, j] = held
                any_defended = any_defended or held
                if close:
                    pressure[e, i, j] += dt
                    faster[e, i, j] = faster[e, i, j] or speed[e, i] > speed[e, j]
                else:
                    pressure[e, i, j] = 0.0
                    faster[e, i, j] = False
    return any_passed, any_defended


def pack_rule_scalars(dt: float, rules: Any, wheel_reach: float) -> FloatArray:
    """The ``rule_scalars`` argument of ``advance_cars`` (constants of the rules and car)."""
    return np.array([dt, rules.reversed_steps, rules.immobilised_steps,
                     rules.immobilised_distance, wheel_reach], dtype=np.float64)


CAR_VECTORS: tuple[str, ...] = ("position", "velocity")
"""The rows of ``RaceCore``'s block of per-car 2-vectors (E, N, 2); the kernels unpack them
by these indices."""
CAR_FLOATS: tuple[str, ...] = ("yaw", "yaw_rate", "steer", "speed", "s", "d", "distance",
                               "start_distance", "lap_origin", "last_lap_time", "best_lap_time",
                               "frozen_until")
"""The rows of ``RaceCore``'s block of per-car floats (E, N)."""
CAR_COUNTS: tuple[str, ...] = ("laps", "reverse_count", "immobile_count", "resets",
                               "penalties", "overtakes", "overtaken", "defences", "rank")
"""The rows of ``RaceCore``'s block of per-car counts (E, N), int64."""
CAR_FLAGS: tuple[str, ...] = ("done", "finished")
"""The rows of ``RaceCore``'s block of per-car flags (E, N)."""
PAIR_FLOATS: tuple[str, ...] = ("_gap", "_pressure")
"""The rows of ``RaceCore``'s block of per-pair floats (E, N, N) (``pairs_kernel``)."""
PAIR_FLAGS: tuple[str, ...] = ("_faster", "_passed", "_defended")
"""The rows of ``RaceCore``'s block of per-pair flags (E, N, N) (``pairs_kernel``)."""


@njit(cache=True)
def advance_cars(body_state, env_offset, wheels, racing, time, steps, time_limit, max_cycles,
                 car_vectors, car_floats, car_counts, car_flags, rule_scalars, points,
                 point_track, selected, wheel_first, scratch, track_index, track_scalars,
                 fields, proj_start, proj_cert, proj_tab, proj_tab_full, step_distance, flags,
                 new_laps):  # pragma: no cover
    """Read the physics state back and apply the per-car rules, for every car at once.

    The car fields come as ``RaceCore``'s blocks, rows as in ``CAR_VECTORS``, ``CAR_FLOATS``,
    ``CAR_COUNTS`` and ``CAR_FLAGS``, and the constants come packed (a compiled call costs
    about 80 ns per array argument): ``rule_scalars`` = (dt, reversed_steps,
    immobilised_steps, immobile_distance, wheel_reach) (see ``pack_rule_scalars``); the
    tracks as the arrays of a ``TrackTables`` (``track_scalars``, ``fields``, ``proj_*``), and
    env copy e races track ``track_index[e]``; ``scratch`` (3, P) rows: each car's
    displacement this step, then the projections' s and d of the queued points
    (``point_track`` (P,): the track of each); ``flags`` (3, E, N) is filled with off_track,
    reversed and immobilised.

    For each car (E, N), given pymunk's state ``body_state`` (E * N + ..., 6) =
    (x, y, angle, vx, vy, angular velocity) in the shared Space:

    - position, yaw (wrapped into [-pi, pi)), velocity, yaw rate and forward ``speed`` in
      track coordinates;
    - the centre and the wheel centres (``wheels`` (W, 2) in the body frame) are projected
      onto the centre line (racing cars only);
    - ``step_distance``: centre-line progress since the last step, wrapped into
      [-L/2, L/2) (0 for cars not racing), added to ``distance``;
    - ``off_track``: racing and every wheel outside [-width_right(s), width_left(s)]
      (DeepRacer: all four wheels off; partly off is on track);
    - ``reverse_count`` / ``immobile_count``: consecutive racing steps with negative progress
      / with a displacement of at most ``immobile_distance`` metres; ``reversed_`` and
      ``immobilised`` when they reach ``reversed_steps`` / ``immobilised_steps``;
    - ``new_laps``: complete laps since ``lap_origin``, floor((distance - origin) / L), never
      fewer than ``laps``.

    The step count ``steps`` (E,) advances for env copies with a car not done, and their
    clock is ``time = steps * dt`` (no accumulated rounding).

    Returns:
        ``(event, out_of_time)``: whether any car went off track, reversed, was immobilised
        or completed a lap; whether any env copy reached ``time_limit`` or ``max_cycles``.
    """
    position, velocity = car_vectors[0], car_vectors[1]
    yaw, yaw_rate, speed = car_floats[0], car_floats[1], car_floats[3]
    s, d, distance, lap_origin = car_floats[4], car_floats[5], car_floats[6], car_floats[8]
    laps, reverse_count, immobile_count = car_counts[0], car_counts[1], car_counts[2]
    done = car_flags[0]
    dt = rule_scalars[0]
    reversed_steps = rule_scalars[1]
    immobilised_steps = rule_scalars[2]
    immobile_distance = rule_scalars[3]
    wheel_reach = rule_scalars[4]
    moved = scratch[0]
    s_points = scratch[1]
    d_points = scratch[2]
    width_left = fields[tt.WIDTH_LEFT]
    width_right = fields[tt.WIDTH_RIGHT]
    off_track = flags[0]
    reversed_ = flags[1]
    immobilised = flags[2]
    num_envs, num_cars = s.shape
    num_wheels = wheels.shape[0]
    total = num_envs * num_cars
    event = False
    out_of_time = False
    # Pass 1: read the physics state back; queue each racing car's centre for projection, and
    # its wheels too when it is near an edge. Distance to the centre line is 1-Lipschitz, so a
    # wheel within ``wheel_reach`` of the centre lies at most |d| + moved + wheel_reach from
    # the line: on the surface when that is below the track's narrowest half-width.
    queued = total
    for e in range(num_envs):
        t = track_index[e]
        min_half_width = track_scalars[t, tt.MIN_HALF_WIDTH]
        active = False
        for i in range(num_cars):
            active = active or not done[e, i]
        if active:
            steps[e] += 1
            time[e] = steps[e] * dt
        out_of_time = (out_of_time or time[e] >= time_limit - TIME_EPS
                       or steps[e] >= max_cycles)
        for i in range(num_cars):
            k = e * num_cars + i
            x = body_state[k, 0] - env_offset[e, 0]
            y = body_state[k, 1] - env_offset[e, 1]
            moved[k] = math.hypot(x - position[e, i, 0], y - position[e, i, 1])
            position[e, i, 0] = x
            position[e, i, 1] = y
            angle = body_state[k, 2]
            angle = angle - 2.0 * math.pi * math.floor((angle + math.pi) / (2.0 * math.pi))
            yaw[e, i] = angle
            c = math.cos(angle)
            sn = math.sin(angle)
            velocity[e, i, 0] = body_state[k, 3]
            velocity[e, i, 1] = body_state[k, 4]
            yaw_rate[e, i] = body_state[k, 5]
            speed[e, i] = c * body_state[k, 3] + sn * body_state[k, 4]
            points[k, 0] = x
            points[k, 1] = y
            point_track[k] = t
            selected[k] = racing[e, i]
            wheel_first[k] = -1
            if racing[e, i] and abs(d[e, i]) + moved[k] + wheel_reach > min_half_width:
                wheel_first[k] = queued
                for w in range(num_wheels):
                    points[queued, 0] = x + c * wheels[w, 0] - sn * wheels[w, 1]
                    points[queued, 1] = y + sn * wheels[w, 0] + c * wheels[w, 1]
                    point_track[queued] = t
                    selected[queued] = True
                    queued += 1
    for q in range(queued):
        if selected[q]:
            s_points[q], d_points[q] = project_on(track_scalars, point_track[q], proj_start,
                                                  proj_cert, proj_tab, proj_tab_full,
                                                  points[q, 0], points[q, 1])
        else:
            s_points[q] = 0.0
            d_points[q] = 0.0
    # Pass 2: the rules, from the projections.
    for e in range(num_envs):
        t = track_index[e]
        length = track_scalars[t, tt.LENGTH]
        inv_ds = track_scalars[t, tt.INV_DS]
        first = int(track_scalars[t, tt.LUT_FIRST])
        count = int(track_scalars[t, tt.LUT_COUNT])
        min_half_width = track_scalars[t, tt.MIN_HALF_WIDTH]
        for i in range(num_cars):
            k = e * num_cars + i
            if not racing[e, i]:
                step_distance[e, i] = 0.0
                off_track[e, i] = False
                reversed_[e, i] = False
                immobilised[e, i] = False
                reverse_count[e, i] = 0
                immobile_count[e, i] = 0
                new_laps[e, i] = laps[e, i]
                continue
            ds = wrap_arc(s_points[k] - s[e, i], length)
            step_distance[e, i] = ds
            distance[e, i] += ds
            s[e, i] = s_points[k]
            d[e, i] = d_points[k]
            any_on = True
            first_wheel = wheel_first[k]
            if first_wheel >= 0:
                any_on = abs(d_points[k]) + wheel_reach <= min_half_width
                for w in range(first_wheel, first_wheel + num_wheels):
                    if any_on:
                        break
                    sw = s_points[w]
                    dw = d_points[w]
                    any_on = (dw <= lookup_span(width_left, first, count, sw, inv_ds, length)
                              and dw >= -lookup_span(width_right, first, count, sw, inv_ds,
                                                     length))
            off_track[e, i] = not any_on
            reverse_count[e, i] = reverse_count[e, i] + 1 if ds < 0.0 else 0
            immobile_count[e, i] = immobile_count[e, i] + 1 if moved[k] <= immobile_distance else 0
            reversed_[e, i] = reverse_count[e, i] >= reversed_steps
            immobilised[e, i] = immobile_count[e, i] >= immobilised_steps
            lap = int(math.floor((distance[e, i] - lap_origin[e, i]) / length))
            new_laps[e, i] = max(lap, laps[e, i])
            if (not any_on or reversed_[e, i] or immobilised[e, i]
                    or new_laps[e, i] > laps[e, i]):
                event = True
    return event, out_of_time
