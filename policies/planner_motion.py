"""Motion maths of the planner's kernel (:mod:`h2h_racing.policies.planner_kernel`): the
packed parameters, table lookups, the quintic blend, speed profiles and the speed command,
the prediction of other cars along the track, and the speed that follows a car.
"""

from __future__ import annotations

import math

from numba import njit

PREDICT_DT = 0.1
"""Time step of the other cars' predicted travel [s]."""
RUNUP_SPEED = 0.8
"""Share of the car ahead's speed a run-up slows to at least."""
FOLLOW_PREVIEW = 0.6
"""Time over which a car ahead moving sideways counts as in the way when following [s]."""
# Indices into the kernel's packed parameters (``params``).
P_A_LAT, P_A_ACC, P_A_BRK, P_EDGE, P_HALF_LEN, P_HALF_WID, P_LONG_MARGIN, P_LAT_MARGIN, \
    P_CLOSING_MARGIN, P_SWITCH_COST, P_DEV_COST, P_GAIN, P_DT, P_FOLLOW_GAP, P_FOLLOW_TIME, \
    P_FOLLOW_GAIN, P_V_MAX, P_FOLLOW_COST, P_SWITCH_CURVATURE, P_A_LANE, P_SPEED_PREVIEW, \
    P_STEADY_GAP, P_ROOM = range(23)
NUM_PARAMS = 23
STEADY_PACE = 0.7
"""Share of the top speed that a car ahead must have reached lately (``Planner``'s
``TOP_DECAY``) to count as a rival as fast as the planner on the straights, not a slower car
to pass at once."""
PACK_RANGE = 3.0
"""Arc distance within which another car makes a pack: no close following then [m]."""


@njit(cache=True, inline="always")
def _table(table, row, s, inv_ds, length):  # pragma: no cover
    """Periodic linear interpolation of ``table[row]`` (K samples over the lap) at ``s``."""
    s = s - length * math.floor(s / length)
    u = s * inv_ds
    k = int(u)
    count = table.shape[1]
    f = u - k
    k = k % count
    return table[row, k] + f * (table[row, (k + 1) % count] - table[row, k])


@njit(cache=True, inline="always")
def _blend(u):  # pragma: no cover
    """(H0, H1, H0'', H1'') of the quintic Hermite blend at ``u`` (zero past u = 1)."""
    if u >= 1.0:
        return 0.0, 0.0, 0.0, 0.0
    u2 = u * u
    u3 = u2 * u
    return (1.0 - 10.0 * u3 + 15.0 * u2 * u2 - 6.0 * u3 * u2,
            u - 6.0 * u3 + 8.0 * u2 * u2 - 3.0 * u3 * u2,
            -60.0 * u + 180.0 * u2 - 120.0 * u3,
            -36.0 * u + 96.0 * u2 - 60.0 * u3)


@njit(cache=True, inline="always")
def _travel(traj, e, o, t):  # pragma: no cover
    """Distance object ``o`` of copy ``e`` is predicted to travel in ``t`` seconds [m]
    (``traj`` holds it every ``PREDICT_DT``; beyond its end at its last speed)."""
    u = t / PREDICT_DT
    k = int(u)
    last = traj.shape[2] - 1
    if k >= last:
        return traj[e, o, last] + (traj[e, o, last] - traj[e, o, last - 1]) * (u - last)
    return traj[e, o, k] + (u - k) * (traj[e, o, k + 1] - traj[e, o, k])


@njit(cache=True, inline="always")
def _speed_ahead(traj, e, o, gap, at):  # pragma: no cover
    """Speed [m/s] object ``o`` of copy ``e`` is predicted to have when it reaches ``at``
    metres of track ahead of the car (``gap``: how far ahead of the car it is now); 1e9 for
    a point it has passed already.

    A car that follows another at its speed *there*, rather than at its speed *then*, keeps
    at least the gap it has: if the follower's speed at x is the leader's at x + front, both
    take the same time from x to y and from x + front to y + front, so the follower reaches
    each point no sooner than the leader reached the point ``front`` ahead of it, as long as
    it starts behind that. Matched in time instead, a follower 3 m back brakes when the car
    ahead does, 3 m before it needs to, and never closes in under braking."""
    need = at - gap
    if need <= 0.0:
        return 1e9
    last = traj.shape[2] - 1
    for k in range(1, last + 1):
        if traj[e, o, k] >= need:
            return (traj[e, o, k] - traj[e, o, k - 1]) / PREDICT_DT
    return (traj[e, o, last] - traj[e, o, last - 1]) / PREDICT_DT


@njit(cache=True)
def predict(obj_gap, obj_speed, obj_cap, obj_ratio, s0, line_v, inv_ds, length, obj_accel,
            traj):  # pragma: no cover
    """Predict how far each object travels along the track, every ``PREDICT_DT`` seconds.

    An object keeps its current acceleration (as the driver estimates it: a car cruising
    slowly is not expected to speed away), up to the planner's racing-line profile scaled by
    its pace ratio (its speed over the profile's where the profile is below top speed,
    estimated by the driver) and at most ``obj_cap``, and brakes as that scaled profile does:
    ``v <- max(min(v + a dt, cap, ratio v_line(s)), 0)``. An object whose acceleration is nan
    keeps to that scaled profile (the driver's ``ON_PROFILE``: a car on the racing line at the
    speed of its profile): ``v <- min(cap, ratio v_line(s))``, braking for a bend to the bend's
    scaled speed rather than extrapolated to a stop.

    Args:
        obj_gap, obj_speed, obj_cap, obj_ratio, obj_accel: (E, J) arc gap ahead of the car
            [m], speed, top speed [m/s], pace ratio and acceleration [m/s^2] (nan: it keeps
            to its scaled profile).
        s0: (E,) the car's arc position [m].
        line_v: Racing-line profile, (1, K) [m/s].
        traj: Out (E, J, K + 1): distance travelled [m] at ``k PREDICT_DT``.
    """
    for e in range(obj_gap.shape[0]):
        for o in range(obj_gap.shape[1]):
            s = s0[e] + obj_gap[e, o]
            v = obj_speed[e, o]
            travelled = 0.0
            traj[e, o, 0] = 0.0
            for k in range(1, traj.shape[2]):
                limit = min(obj_cap[e, o],
                            obj_ratio[e, o] * _table(line_v, 0, s + travelled, inv_ds, length))
                if math.isnan(obj_accel[e, o]):  # on its scaled profile: it keeps to it
                    v_next = limit
                else:
                    v_next = max(min(v + obj_accel[e, o] * PREDICT_DT, limit), 0.0)
                travelled += 0.5 * (v + v_next) * PREDICT_DT
                v = v_next
                traj[e, o, k] = travelled


@njit(cache=True, inline="always")
def _excess(d, s, centre, inv_ds, length, edge):  # pragma: no cover
    """How far offset ``d`` lies beyond the border less ``edge`` at ``s`` [m] (0 inside)."""
    left = _table(centre, 1, s, inv_ds, length) - edge
    right = _table(centre, 2, s, inv_ds, length) - edge
    return max(d - left, -right - d, 0.0)


@njit(cache=True, inline="always")
def _profile(v_lim, vel, step, v_start, a_acc, a_brk, samples):  # pragma: no cover
    """Quasi-steady-state speeds over the horizon: braking pass from its end, then an
    acceleration pass from the car's speed ``v_start`` (written into ``vel``). Returns how
    far ``v_start`` lies above what the braking pass allows at the car [m/s]: a path the car
    is too fast for."""
    vel[samples] = v_lim[samples]
    for i in range(samples - 1, -1, -1):
        vel[i] = min(v_lim[i], math.sqrt(vel[i + 1] * vel[i + 1] + 2.0 * a_brk * step))
    over = max(v_start - vel[0], 0.0)
    vel[0] = v_start
    for i in range(samples):
        vel[i + 1] = min(vel[i + 1], math.sqrt(vel[i] * vel[i] + 2.0 * a_acc * step))
    return over


@njit(cache=True, inline="always")
def _command(v, v_next, step, params):  # pragma: no cover
    """Speed command that makes the speed controller ``a = gain (v_cmd - v)`` deliver the
    acceleration ``(v_next^2 - v^2) / (2 step)`` of the profile's first step."""
    accel = (v_next * v_next - v * v) / (2.0 * step)
    command = v + accel / params[P_GAIN]
    if v_next < v:
        # Braking: at least to the speed wanted (the controller's a = gain (v_cmd - v)), or
        # a car slowing to a stop would creep, its (v_next^2 - v^2) / 2 step vanishing.
        command = min(command, v_next)
    return min(max(command, 0.0), params[P_V_MAX])


@njit(cache=True)
def _follow_speed(e, s0, d0, v0, obj_gap, obj_lo, obj_hi, obj_v, obj_dd, obj_half_len,
                  obj_half_wid, obj_valid, obj_top, centre, inv_ds, length, params,
                  extra):  # pragma: no cover
    """Speed that holds a gap of ``follow_gap + follow_time v + extra`` to the nearest object ahead
    that overlaps the car laterally now or within ``FOLLOW_PREVIEW`` at its lateral speed (a
    large number when there is none) [m/s]. Behind a lone car (no other within
    ``PACK_RANGE``) that is as fast on the straights (its recent top speed above
    ``STEADY_PACE`` of ``P_V_MAX``) the gap is at most ``P_STEADY_GAP``: close enough to be
    alongside when it brakes earlier for a bend."""
    lead_v = 1e9
    lead_gap = 1e9
    lead = -1
    near = 0
    for o in range(obj_gap.shape[1]):
        if not obj_valid[e, o]:
            continue
        if abs(obj_gap[e, o]) < PACK_RANGE:
            near += 1
        if obj_gap[e, o] <= 0.0:
            continue
        moved = obj_dd[e, o] * FOLLOW_PREVIEW
        lo = min(obj_lo[e, o], obj_lo[e, o] + moved)
        hi = max(obj_hi[e, o], obj_hi[e, o] + moved)
        apart = max(lo - d0[e], d0[e] - hi, 0.0)
        if apart > params[P_HALF_WID] + obj_half_wid[e, o] + params[P_LAT_MARGIN]:
            continue
        # The bumper gap in metres driven: an arc gap of the centre line shrinks by
        # (1 - kappa d) at the cars' mean offset d (on the inside of a bend).
        bend = _table(centre, 0, s0[e] + 0.5 * obj_gap[e, o], inv_ds, length)
        mean_d = 0.5 * (d0[e] + 0.5 * (obj_lo[e, o] + obj_hi[e, o]))
        gap = (obj_gap[e, o] * max(1.0 - bend * mean_d, 0.2) - params[P_HALF_LEN]
               - obj_half_len[e, o])
        if gap < lead_gap:
            lead_gap = gap
            lead_v = obj_v[e, o]
            lead = o
    if lead_gap > 1e8:
        return 1e9
    wanted = params[P_FOLLOW_GAP] + params[P_FOLLOW_TIME] * v0[e]
    if near <= 1 and obj_top[e, lead] > STEADY_PACE * params[P_V_MAX]:
        wanted = min(wanted, params[P_STEADY_GAP])
    wanted += extra
    # The gap is along the centre line, where a car at offset d moves at v / (1 - kappa d):
    # on the inside of a bend the follower gains on a car outside it at the same speed. So
    # the car ahead's arc rate is matched, then turned back into a speed at the car's offset.
    s_lead = s0[e] + obj_gap[e, lead]
    rate = lead_v / max(1.0 - _table(centre, 0, s_lead, inv_ds, length)
                        * 0.5 * (obj_lo[e, lead] + obj_hi[e, lead]), 0.2)
    own = max(1.0 - _table(centre, 0, s0[e], inv_ds, length) * d0[e], 0.2)
    speed = max((rate + params[P_FOLLOW_GAIN] * (lead_gap - wanted)) * own, 0.0)
    if extra > 0.0 and lead_gap > params[P_FOLLOW_GAP]:
        # A run-up opens the gap gently, at RUNUP_SPEED of the car ahead's speed.
        speed = max(speed, RUNUP_SPEED * rate * own)
    return speed
