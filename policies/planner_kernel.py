"""The planner's compiled step: candidate manoeuvres, their speed profiles, the collision
check against predicted cars, the choice, and the commands, for every env copy at once.

A candidate is a lateral path in the track's Frenet frame: from the car's own offset ``d0``
and slope ``d0' = dd/ds`` it blends onto a precomputed *lane* ``d_l(s)`` (the racing line,
the racing line shifted sideways, a share of the half-width, or a hold of an offset) over a
transition of
``T`` metres, with the quintic Hermite blend of the error ``e = d - d_l``::

    u = (s - s0) / T,   e(u) = e0 H0(u) + e0' T H1(u)   (0 for u >= 1)
    H0 = 1 - 10u^3 + 15u^4 - 6u^5,   H1 = u - 6u^3 + 8u^4 - 3u^5

which matches position and slope at the car and joins the lane with zero error, slope and
curvature. The path's curvature is the lane's plus ``e''(s) = (e0 H0'' + e0' T H1'') / T^2``
(``H0'' = -60u + 180u^2 - 120u^3``, ``H1'' = -36u + 96u^2 - 60u^3``). Its speed profile over
the horizon is the racing line's quasi-steady-state method: the cornering limit
``sqrt(a_lat / |kappa|)`` capped by the lane's own (closed-loop) profile, which already brakes
for corners beyond the horizon, then a backward (braking) and a forward (acceleration, from
the car's speed) pass. Arc position advances at ``ds/dt = v / (1 - kappa_c d)``, so an
inside line gains track.

Every other car (and bot) is predicted along the track (``predict``: its acceleration, up to
the planner's profile scaled by its pace, or that scaled profile itself for a car that keeps to
it) while its lateral span is the interval between its offset now and its offset extrapolated
with its lateral speed for ``LATERAL_PREVIEW`` seconds, or, for a car that drives the racing
line, the line itself (``_span``), held where the candidate draws alongside (a car overlapped
leaves room). A candidate whose body comes within a car length plus a margin along the track
and a car width plus a margin across of a predicted car, at the same time, is not free, unless
the two were already that near and the candidate gets no nearer (beside a car alongside now,
the margin across is ``ALONGSIDE_MARGIN``); so is one that leaves the track. Of the free
ones, the one that reaches the end of the horizon soonest wins (with small costs for ending off
the racing line and for leaving the tracked path, so that ties do not dither). A blocked
candidate is tried again held to the blocking car's speed where it overlaps it sideways, and
failing that, behind it at its speed, at ``P_FOLLOW_COST`` (and ``SIDE_COST`` more when it
closes in on a car beside it); the cheapest wins.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from h2h_racing.policies.planner_motion import (  # noqa: F401  (re-exported for the driver)
    FOLLOW_PREVIEW,
    NUM_PARAMS,
    P_A_ACC,
    P_A_BRK,
    P_A_LANE,
    P_A_LAT,
    P_CLOSING_MARGIN,
    P_DEV_COST,
    P_DT,
    P_EDGE,
    P_FOLLOW_COST,
    P_FOLLOW_GAIN,
    P_FOLLOW_GAP,
    P_FOLLOW_TIME,
    P_GAIN,
    P_HALF_LEN,
    P_HALF_WID,
    P_LAT_MARGIN,
    P_LONG_MARGIN,
    P_ROOM,
    P_SPEED_PREVIEW,
    P_STEADY_GAP,
    P_SWITCH_COST,
    P_SWITCH_CURVATURE,
    P_V_MAX,
    PREDICT_DT,
    RUNUP_SPEED,
    _blend,
    _command,
    _excess,
    _follow_speed,
    _profile,
    _speed_ahead,
    _table,
    _travel,
    predict,
)

BESIDE = 1.0
"""Arc gap within which another car counts as beside the car: the hold lane is looked at [m]."""
SIDE_COST = 1.0
"""Cost of a candidate that closes in on a car beside it [s] (it is taken only when every
other one does too)."""
LATERAL_PREVIEW = 0.4
"""Time over which another car's lateral speed is extrapolated [s]."""
REANCHOR = 0.3
"""Distance from its tracked path beyond which the car starts a new one from where it is [m]."""
MAX_SLOPE = 0.2
"""Steepest lateral slope dd/ds of a transition between lanes (11 degrees)."""
OVER_SPEED = 0.1
"""Speed above a candidate's braking limit at the car that is tolerated [m/s]."""
OVER_WEIGHT = 0.5
"""Metres of track excess that one m/s above the braking limit counts as [s]."""
ALONGSIDE_MARGIN = 0.05
"""Gap kept beside a car that is alongside now (the bodies overlapping along the track),
beyond the two half-widths, where it is smaller than ``lateral_margin`` [m]. With the full
margin (0.1 m) a car alongside that drifted a few centimetres closer blocked every candidate
at once, and the planner braked while level with it, where a car closing the door (`blocker`)
hit it. Tuning tracks, 200 races each (experiments/planner, item 18): behind `blocker` 181
won and 114 crashes caused at 0.1 m, 187 and 80 at 0.05 m, 188 and 75 at 0; last of a 4-car
field 90 and 124, 99 and 87, 100 and 89; behind `racing_line` 86 and 87 won at 0.1 and
0.05 m, in front of `league_racer` 135 and 135, four planners 7 and 6 crashes."""
LINE_RELAX = 1.0
"""Time over which a car that drives the racing line is predicted to close its offset from
it [s]."""

@njit(cache=True)
def plan(s0, d0, slope0, v0, base_d, base_v, base_k, centre, inv_ds, length, transitions,
         horizon, samples, obj_gap, obj_lo, obj_hi, traj, obj_v, obj_dd, obj_half_len,
         obj_half_wid, obj_valid, obj_err, obj_top, lane_bonus, plan_lane, plan_start,
         plan_error, plan_slope, plan_length, plan_hold, params, reanchor, max_slope, gap_extra,
         look, choice, d_look, v_cmd, report, track_at, track_out):  # pragma: no cover
    """Choose a manoeuvre per env copy and return its look-ahead offset and speed command.

    Args:
        s0, d0, slope0, v0: The car's arc position [m], offset [m], lateral slope dd/ds and
            speed [m/s], each (E,).
        base_d, base_v, base_k: Lane tables, each (NL, K): offset [m], profile speed [m/s]
            and curvature [1/m] of each lane on the uniform grid of ``inv_ds`` (lane 0 is
            the racing line). Lane NL, added here, *holds* an offset: the car's own when it
            is chosen (``plan_hold``), driven parallel to the centre line, at most at the
            racing line's speed: the way to stay beside a car until it is passed.
        centre: Centre-line tables, (3, K): curvature [1/m], left and right half-width [m].
        inv_ds, length: Grid density [1/m] and lap length [m].
        transitions: (E, NT) transition lengths [m].
        horizon: (E,) planning horizon [m of centre line].
        samples: Samples along the horizon.
        obj_*: Other cars and bots, (E, J): arc gap ahead of the car (wrapped) [m], lateral
            span now (lo, hi) [m], speed [m/s], lateral speed [m/s], half length and half
            width [m], whether the slot holds an object, its offset from the racing line
            when it drives that line (nan when it does not: ``_span``) [m], and the top
            speed it reached lately [m/s].
        traj: (E, J, P) each object's predicted travel (``predict``) [m].
        lane_bonus: (E, NL) cost subtracted from each lane's candidates [s] (defence).
        plan_lane, plan_start, plan_error, plan_slope, plan_length: (E,) the path being
            tracked, updated in place: its lane (-1: none yet), and the arc position [m],
            offset error from the lane [m], slope error and length [m] of its transition
            onto the lane, and the offset a hold keeps [m]. It is kept while
            the choice stays (re-anchored at the car when the car is more than
            ``reanchor`` off it), so that the steering tracks a fixed path rather than one
            that restarts at the car every step.
        params: Packed parameters (``P_*``).
        reanchor: (E,) distance from the tracked path beyond which the car starts a new one
            from where it is [m] (``REANCHOR``; larger while the driver steers round a box,
            which takes the car off its path on purpose).
        max_slope: (E,) steepest lateral slope dd/ds of a transition to another lane
            (``MAX_SLOPE``; steeper while the driver defends).
        gap_extra: (E,) gap added to the follow gap [m] (a run-up: the driver drops back
            behind a car it has been stuck behind, to come at it again with speed).
        look: (E,) look-ahead distance of the steering target [m].
        choice: Out (E,): chosen lane, or -1 when following (the tracked path is kept and
            the speed capped behind the car ahead).
        d_look: Out (E,): the tracked path's offset at ``s0 + look`` [m].
        v_cmd: Out (E,): speed command [m/s].
        report: Out (E, NL + 1, NT, 3): each candidate's time to the horizon [s] (behind the
            car it would hit, for one that is not free), the object it would hit (-1: none)
            and how far it leaves the track [m] (for tests and diagnosis; lanes not looked at
            alone hold nan).
        track_at: (E, K) arc distances ahead of the car [m] (within its look-ahead) where
            the tracking controller reads the tracked path.
        track_out: Out (E, K, 3): the tracked path's offset [m], slope dd/ds and curvature
            [1/m] at ``s0 + track_at``.
    """
    num_env = s0.shape[0]
    hold_lane = base_d.shape[0]
    num_lanes = hold_lane + 1
    count = base_d.shape[1]
    lane_d = np.empty((num_lanes, count))
    lane_v = np.empty((num_lanes, count))
    lane_k = np.empty((num_lanes, count))
    lane_d[:hold_lane] = base_d
    lane_v[:hold_lane] = base_v
    lane_k[:hold_lane] = base_k
    num_trans = transitions.shape[1]
    work = np.empty((5, samples + 1))
    held = np.empty((obj_gap.shape[1], 2))
    report[:] = np.nan
    for e in range(num_env):
        step = horizon[e] / samples
        window = (s0[e] - 1.0, s0[e] + horizon[e] + look[e] + 1.0)
        if plan_lane[e] == hold_lane:
            _fill_hold(lane_d, lane_v, lane_k, plan_hold[e], window, centre, inv_ds, params)
        # The path being tracked: its offset and slope here, or the car's own when there is
        # none yet or the car is more than REANCHOR off it.
        ref = d0[e]
        ref_slope = np.nan  # anchored at the car: no slope error (pure pursuit steers it)
        stay = plan_lane[e]
        left = 0.0
        if stay >= 0:
            done = s0[e] - plan_start[e]
            done -= length * math.floor(done / length + 0.5)
            if done >= plan_length[e]:
                plan_error[e] = 0.0  # the transition is over: the path is the lane
                plan_slope[e] = 0.0
            left = plan_length[e] - max(done, 0.0)
            ref = _path(lane_d, stay, plan_start[e], plan_error[e], plan_slope[e],
                        plan_length[e], s0[e], inv_ds, length)
            ref_slope = (_path(lane_d, stay, plan_start[e], plan_error[e], plan_slope[e],
                               plan_length[e], s0[e] + 0.05, inv_ds, length) - ref) / 0.05
            if abs(ref - d0[e]) > reanchor[e]:
                ref = d0[e]
                ref_slope = np.nan
                stay = -1
        # Alone (nothing near within the horizon, no defence) the racing line is the plan:
        # other lanes only look faster over a horizon that ends before their next corner.
        busy = False
        beside = False
        for o in range(obj_gap.shape[1]):
            if obj_valid[e, o] and -1.0 < obj_gap[e, o] < horizon[e] + 1.0:
                busy = True
            if obj_valid[e, o] and abs(obj_gap[e, o]) < BESIDE:
                beside = True
        for lane in range(hold_lane):
            if lane_bonus[e, lane] != 0.0:
                busy = True
        hold = ref
        if stay == hold_lane:
            hold = plan_hold[e]
        else:
            left_w = _table(centre, 1, s0[e], inv_ds, length) - params[P_EDGE]
            right_w = _table(centre, 2, s0[e], inv_ds, length) - params[P_EDGE]
            hold = min(max(ref, -right_w), left_w)
            if beside and busy:  # only then is a new hold looked at
                _fill_hold(lane_d, lane_v, lane_k, hold, window, centre, inv_ds, params)
        base_excess = _excess(ref, s0[e], centre, inv_ds, length, params[P_EDGE])
        best = (1e18, -1, 1.0, 0.0, True)  # cost, lane, transition, first speed, following
        stay_best = best
        nearest = (1e18, 0, 1.0, v0[e])  # excess, lane, transition, first speed
        for lane in range(num_lanes if busy else 1):
            if lane == hold_lane and not beside:
                continue  # a hold is for staying beside a car
            for j in range(num_trans + 1):
                if j == num_trans:  # the tracked path itself, as it goes on
                    if lane != stay or left <= 0.0:
                        continue
                    trans = max(left, 0.3)
                else:
                    trans = transitions[e, j]
                trans = _stretched(lane_d, lane, ref, trans, s0[e], inv_ds, length,
                                   max_slope[e])
                # No change to another lane in a bend (set passes up before it); back to the
                # racing line or a hold is allowed.
                if (lane != stay and stay >= 0 and lane != hold_lane and lane != 0
                        and _bend(centre, s0[e], trans, inv_ds, length)
                        > params[P_SWITCH_CURVATURE]):
                    continue
                cost, v1, hit, excess = _candidate(
                    lane, trans, ref, ref_slope, s0[e], v0[e], step, samples, e, lane_d,
                    lane_v, lane_k, centre, inv_ds, length, horizon[e], obj_gap, obj_lo,
                    obj_hi, traj, obj_dd, obj_half_len, obj_half_wid, obj_valid, obj_err,
                    params, work, held)
                if j < num_trans:
                    report[e, lane, j, 0] = cost
                    report[e, lane, j, 1] = hit
                    report[e, lane, j, 2] = excess
                if excess < nearest[0] - 1e-9:
                    nearest = (excess, lane, trans, v1)
                if excess > base_excess + 0.01:
                    continue
                if lane < hold_lane:
                    cost -= lane_bonus[e, lane]
                if cost < best[0]:
                    best = (cost, lane, trans, v1, hit >= 0)
                if lane == stay and cost < stay_best[0]:
                    stay_best = (cost, lane, trans, v1, hit >= 0)
        # Keep the tracked path unless another is better by the switch cost.
        if stay >= 0 and stay_best[1] >= 0 and best[0] + params[P_SWITCH_COST] >= stay_best[0]:
            best = stay_best
        _, lane, trans, v1, following = best
        if lane < 0:  # nothing stays on the track: the candidate nearest it
            _, lane, trans, v1 = nearest
            following = True
        choice[e] = -1 if following else lane
        if following:
            v1 = min(v1, _follow_speed(e, s0, d0, v0, obj_gap, obj_lo, obj_hi, obj_v,
                                       obj_dd, obj_half_len, obj_half_wid, obj_valid,
                                       obj_top, centre, inv_ds, length, params,
                                       gap_extra[e]))
        if lane != stay:  # a new path (stay is -1 when there is none to keep)
            lane_here = _table(lane_d, lane, s0[e], inv_ds, length)
            plan_error[e] = ref - lane_here
            plan_slope[e] = 0.0
            if not math.isnan(ref_slope):
                plan_slope[e] = ref_slope - (_table(lane_d, lane, s0[e] + 0.05, inv_ds,
                                                    length) - lane_here) / 0.05
            plan_start[e] = s0[e]
            plan_length[e] = trans
            plan_lane[e] = lane
            plan_hold[e] = hold
        d_look[e] = _path(lane_d, plan_lane[e], plan_start[e], plan_error[e], plan_slope[e],
                          plan_length[e], s0[e] + look[e], inv_ds, length)
        for k in range(track_at.shape[1]):
            _geometry(lane_d, lane_k, centre, plan_lane[e], plan_start[e], plan_error[e],
                      plan_slope[e], plan_length[e], s0[e] + track_at[e, k], inv_ds, length,
                      track_out[e, k])
        v_cmd[e] = _command(v0[e], v1, step, params)


@njit(cache=True)
def _candidate(lane, trans, ref, ref_slope, s_start, v_start, step, samples, e, lane_d, lane_v,
               lane_k, centre, inv_ds, length, horizon, obj_gap, obj_lo, obj_hi, traj, obj_dd,
               obj_half_len, obj_half_wid, obj_valid, obj_err, params, work,
               held):  # pragma: no cover
    """Evaluate one candidate: the blend from (``ref``, ``ref_slope``) onto ``lane`` over
    ``trans`` metres (``_stretched``). Returns its cost [s] (time to the horizon, plus the
    follow cost when it must slow behind a car, plus the cost of ending off the racing line),
    its speed at the
    first sample [m/s], the object it would hit (-1: none) and how far it leaves the track
    [m]. ``work`` is scratch space, (5, samples + 1)."""
    v_lim, vel, dpath, times = work[0], work[1], work[2], work[3]
    lane_start = _table(lane_d, lane, s_start, inv_ds, length)
    e0 = ref - lane_start
    e1 = 0.0
    if not math.isnan(ref_slope):
        e1 = ref_slope - (_table(lane_d, lane, s_start + 0.05, inv_ds, length)
                          - lane_start) / 0.05
    excess = 0.0
    for i in range(samples + 1):
        s = s_start + i * step
        h0, h1, h0pp, h1pp = _blend(i * step / trans)
        d = _table(lane_d, lane, s, inv_ds, length) + e0 * h0 + e1 * trans * h1
        excess = max(excess, _excess(d, s, centre, inv_ds, length, params[P_EDGE]))
        dpath[i] = d
        # Heading turned per metre of centre line: the lane's (its curvature times its
        # stretch 1 - kappa_c d_lane) plus the blend's e''; the path's curvature is that over
        # its own stretch 1 - kappa_c d.
        kc = _table(centre, 0, s, inv_ds, length)
        lane_here = _table(lane_d, lane, s, inv_ds, length)
        turn = (_table(lane_k, lane, s, inv_ds, length) * max(1.0 - kc * lane_here, 0.2)
                + (e0 * h0pp + e1 * trans * h1pp) / (trans * trans))
        kappa = turn / max(1.0 - kc * d, 0.2)
        v_lim[i] = min(_table(lane_v, lane, s, inv_ds, length),
                       math.sqrt(params[P_A_LAT] / max(abs(kappa), 1e-6)))
    over = _profile(v_lim, vel, step, v_start, params[P_A_ACC], params[P_A_BRK], samples)
    # A path the car is already too fast for counts as leaving the track: it would slide.
    excess = max(excess, OVER_WEIGHT * max(over - OVER_SPEED, 0.0))
    t, hit, beside = _run(dpath, vel, times, step, s_start, e, centre, inv_ds, length, obj_gap,
                          obj_lo, obj_hi, traj, obj_dd, obj_half_len, obj_half_wid, obj_valid,
                          obj_err, lane_d, params, held, True)
    if hit >= 0:
        # First try the same path held, only where it overlaps that car sideways, to the speed
        # the car will have a car length further on (where it will be, not when:
        # _speed_ahead): move across behind it, then go (a pass from right behind a car).
        limit = work[4]
        front = params[P_HALF_LEN] + obj_half_len[e, hit] + params[P_LONG_MARGIN]
        for i in range(samples + 1):
            limit[i] = v_lim[i]
            lo, hi = _span(e, hit, times[i], s_start + obj_gap[e, hit]
                           + _travel(traj, e, hit, times[i]), obj_lo, obj_hi, obj_dd, obj_err,
                           lane_d, inv_ds, length)
            apart = max(lo - dpath[i], dpath[i] - hi, 0.0)
            if apart < params[P_HALF_WID] + obj_half_wid[e, hit] + params[P_LAT_MARGIN]:
                v_lim[i] = min(v_lim[i], _speed_ahead(traj, e, hit, obj_gap[e, hit],
                                                      i * step + front))
        _profile(v_lim, vel, step, v_start, params[P_A_ACC], params[P_A_BRK], samples)
        t, again, beside = _run(dpath, vel, times, step, s_start, e, centre, inv_ds, length,
                                obj_gap, obj_lo, obj_hi, traj, obj_dd, obj_half_len,
                                obj_half_wid, obj_valid, obj_err, lane_d, params, held, True)
        if again < 0:
            hit = -1
        else:
            # The same path behind the car it would hit, at the speed it will have there.
            for i in range(samples + 1):
                v_lim[i] = min(limit[i], _speed_ahead(traj, e, hit, obj_gap[e, hit],
                                                      i * step + front))
            _profile(v_lim, vel, step, v_start, params[P_A_ACC], params[P_A_BRK], samples)
            t, _, _ = _run(dpath, vel, times, step, s_start, e, centre, inv_ds, length,
                           obj_gap, obj_lo, obj_hi, traj, obj_dd, obj_half_len, obj_half_wid,
                           obj_valid, obj_err, lane_d, params, held, False)
            # Slowing down does not mend a path that closes in on a car beside it.
            t += params[P_FOLLOW_COST] + (SIDE_COST if beside else 0.0)
    line_end = _table(lane_d, 0, s_start + horizon, inv_ds, length)
    t += params[P_DEV_COST] * abs(dpath[samples] - line_end)
    # The speed asked for: the lowest of the profile over the next P_SPEED_PREVIEW seconds
    # (as racing_line's), so that the car is at a bend's speed before the bend rather than
    # braking into it at the limit, where the tracking has no grip to spare.
    first = vel[1]
    for i in range(2, samples + 1):
        if times[i] > params[P_SPEED_PREVIEW]:
            break
        first = min(first, vel[i])
    return t, first, hit, excess


@njit(cache=True, inline="always")
def _stretched(lane_d, lane, ref, trans, s, inv_ds, length, slope):  # pragma: no cover
    """A transition of ``trans`` metres from offset ``ref`` onto ``lane`` at ``s``, made
    longer where needed: a lateral move of e0 over T metres has a largest slope of
    1.875 e0 / T, kept under ``slope`` so that the car's heading stays near the track's."""
    return max(trans, 1.875 * abs(ref - _table(lane_d, lane, s, inv_ds, length)) / slope)


@njit(cache=True, inline="always")
def _path(lane_d, lane, start, error, slope, trans, s, inv_ds, length):  # pragma: no cover
    """Offset [m] at ``s`` of the path that leaves ``lane`` by ``error`` with the slope
    error ``slope`` at ``start`` and blends onto it over ``trans`` metres."""
    ahead = s - start
    ahead -= length * math.floor(ahead / length + 0.5)
    h0, h1, _, _ = _blend(max(ahead, 0.0) / trans)
    return _table(lane_d, lane, s, inv_ds, length) + error * h0 + slope * trans * h1


@njit(cache=True, inline="always")
def _geometry(lane_d, lane_k, centre, lane, start, error, slope, trans, s, inv_ds, length,
              out):  # pragma: no cover
    """Write the offset [m], slope dd/ds and curvature [1/m] at ``s`` of the path ``_path``
    describes into ``out`` (3,); the curvature as ``_candidate`` computes it."""
    d = _path(lane_d, lane, start, error, slope, trans, s, inv_ds, length)
    out[0] = d
    out[1] = (_path(lane_d, lane, start, error, slope, trans, s + 0.05, inv_ds, length)
              - _path(lane_d, lane, start, error, slope, trans, s - 0.05, inv_ds, length)) / 0.1
    ahead = s - start
    ahead -= length * math.floor(ahead / length + 0.5)
    _, _, h0pp, h1pp = _blend(max(ahead, 0.0) / trans)
    kc = _table(centre, 0, s, inv_ds, length)
    lane_here = _table(lane_d, lane, s, inv_ds, length)
    turn = (_table(lane_k, lane, s, inv_ds, length) * max(1.0 - kc * lane_here, 0.2)
            + (error * h0pp + slope * trans * h1pp) / (trans * trans))
    out[2] = turn / max(1.0 - kc * d, 0.2)


@njit(cache=True)
def _run(dpath, vel, times, step, s_start, e, centre, inv_ds, length, obj_gap, obj_lo, obj_hi,
         traj, obj_dd, obj_half_len, obj_half_wid, obj_valid, obj_err, lane_d, params, held,
         check):  # pragma: no cover
    """Drive a candidate (offsets ``dpath``, speeds ``vel`` at its samples; the time at each
    sample is written into ``times``): return the time to its end [s], the first object it
    comes too near (-1: none; not looked for without ``check``) and whether it comes too
    near beside it (the bodies overlapping along the track: closing in sideways)."""
    count = dpath.shape[0] - 1
    t = 0.0
    times[0] = 0.0
    held[:] = np.nan
    for i in range(count + 1):
        if i > 0:
            kc = _table(centre, 0, s_start + (i - 0.5) * step, inv_ds, length)
            stretch = max(1.0 - kc * 0.5 * (dpath[i] + dpath[i - 1]), 0.2)
            t += step * stretch / max(0.5 * (vel[i] + vel[i - 1]), 0.05)
            times[i] = t
        if not check:
            continue
        for o in range(obj_gap.shape[1]):
            if not obj_valid[e, o]:
                continue
            gap = obj_gap[e, o] + _travel(traj, e, o, t) - i * step
            other_v = (_travel(traj, e, o, t + 0.05) - _travel(traj, e, o, t)) / 0.05
            closing = max(vel[i] - other_v, 0.0)
            front = (params[P_HALF_LEN] + obj_half_len[e, o] + params[P_LONG_MARGIN]
                     + params[P_CLOSING_MARGIN] * closing)
            back = params[P_HALF_LEN] + obj_half_len[e, o]
            # A car on its line holds its offset from where this one draws within ROOM of
            # overlapping it: it leaves room, as a car beside now is expected to (the
            # driver's _objects).
            if (math.isnan(held[o, 0]) and not math.isnan(obj_err[e, o])
                    and abs(gap) < back + params[P_ROOM]):
                held[o, 0], held[o, 1] = _span(e, o, t, s_start + i * step + gap, obj_lo,
                                               obj_hi, obj_dd, obj_err, lane_d, inv_ds, length)
            if gap >= front or gap <= -back:
                continue
            if math.isnan(held[o, 0]):
                lo, hi = _span(e, o, t, s_start + i * step + gap, obj_lo, obj_hi, obj_dd,
                               obj_err, lane_d, inv_ds, length)
            else:
                lo, hi = held[o, 0], held[o, 1]
            apart = max(lo - dpath[i], dpath[i] - hi, 0.0)
            margin = params[P_LAT_MARGIN]
            if abs(obj_gap[e, o]) < back:
                # Alongside now: racing side by side, the gap kept is a smaller one.
                margin = min(margin, ALONGSIDE_MARGIN)
            if apart >= params[P_HALF_WID] + obj_half_wid[e, o] + margin:
                continue
            # Already too near at the start (right behind it, side by side off the grid, or
            # after a bump): a path that gets no nearer, across or along, is no conflict, so
            # that the ways out of it are not all discarded with the ways into it.
            if i == 0:
                continue
            apart0 = max(obj_lo[e, o] - dpath[0], dpath[0] - obj_hi[e, o], 0.0)
            gap0 = obj_gap[e, o]
            near0 = (-back < gap0 < front
                     and apart0 < params[P_HALF_WID] + obj_half_wid[e, o] + params[P_LAT_MARGIN])
            if near0 and apart >= apart0 - 0.01 and abs(gap) >= abs(gap0) - 0.01:
                continue
            _finish_times(dpath, vel, times, step, s_start, centre, inv_ds, length, i, t)
            return t, o, gap < back
    return t, -1, False


@njit(cache=True, inline="always")
def _span(e, o, t, s_obj, obj_lo, obj_hi, obj_dd, obj_err, lane_d, inv_ds,
          length):  # pragma: no cover
    """Lateral span (lo, hi) [m] of object ``o`` predicted ``t`` seconds on, where it is at
    arc position ``s_obj``: a car that drives the racing line (``obj_err`` its offset from
    it, nan for one that does not) on the line, its offset from it closing over
    ``LINE_RELAX``; any other one over its offset now and that extrapolated at its lateral
    speed for up to ``LATERAL_PREVIEW``."""
    err = obj_err[e, o]
    if not math.isnan(err):
        d = _table(lane_d, 0, s_obj, inv_ds, length) + err * max(1.0 - t / LINE_RELAX, 0.0)
        return d, d
    moved = obj_dd[e, o] * min(t, LATERAL_PREVIEW)
    return min(obj_lo[e, o], obj_lo[e, o] + moved), max(obj_hi[e, o], obj_hi[e, o] + moved)


@njit(cache=True)
def _finish_times(dpath, vel, times, step, s_start, centre, inv_ds, length, i,
                  t):  # pragma: no cover
    """Write the times of samples ``i + 1`` on (``_run`` stopped at sample ``i``, time ``t``),
    which a follow variant reads."""
    for k in range(i + 1, dpath.shape[0]):
        kc = _table(centre, 0, s_start + (k - 0.5) * step, inv_ds, length)
        stretch = max(1.0 - kc * 0.5 * (dpath[k] + dpath[k - 1]), 0.2)
        t += step * stretch / max(0.5 * (vel[k] + vel[k - 1]), 0.05)
        times[k] = t


@njit(cache=True)
def _fill_hold(lane_d, lane_v, lane_k, hold, window, centre, inv_ds, params):  # pragma: no cover
    """Write the hold lane (the last row) at offset ``hold`` over the arc range ``window``:
    parallel to the centre line (curvature ``kappa_c / (1 - kappa_c d)``), at the cornering
    speed of ``P_A_LANE`` and at most the racing line's profile speed."""
    count = lane_d.shape[1]
    row = lane_d.shape[0] - 1
    first = int(math.floor(window[0] * inv_ds))
    last = int(math.ceil(window[1] * inv_ds)) + 1
    for k in range(first, last + 1):
        i = k % count
        kappa = centre[0, i] / max(1.0 - centre[0, i] * hold, 0.2)
        lane_d[row, i] = hold
        lane_k[row, i] = kappa
        lane_v[row, i] = min(lane_v[0, i], math.sqrt(params[P_A_LANE] / max(abs(kappa), 1e-6)))


@njit(cache=True)
def _bend(centre, s_start, distance, inv_ds, length):  # pragma: no cover
    """Largest centre-line curvature over ``[s_start, s_start + distance]`` [1/m]."""
    largest = 0.0
    count = int(distance / 0.1) + 1
    for i in range(count + 1):
        largest = max(largest, abs(_table(centre, 0, s_start + distance * i / count, inv_ds,
                                          length)))
    return largest


