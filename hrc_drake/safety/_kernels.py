"""Compiled kernels (numba) of the ISO/TS 15066 safety rules (`safety.ssm`, `safety.rules`,
`safety.regions`): the screen of the (robot capsule, body region) pairs against S_p, their
closest points and approach speeds, which rule governs them (collaborative zones, clamping
against the fixed boxes), S_p of eq. (1)-(2) and its permissible speed, and the speed override
of the SSM pairs. The safety controller and the contact monitor run them at 30 Hz, each call on
a few dozen pairs, where numpy spent its time on some eighty calls' argument handling.

The numpy forms stay the reference (`SafetyRules(..., compiled=False)`), tested equal pair for
pair (tests/safety/test_compiled_rules.py); the order of every floating-point operation is
theirs. Compiled when first called, cached on disk (`hrc_drake.kernels`, group "safety").

A separation parameter set is the array (T_r, a, C, Z_r, v_h, P) of `SeparationParameters`; its
pieces (P, 4) are (K, constant, v_low, v_high) of `SeparationParameters._pieces`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from hrc_drake import kernels
from hrc_drake.kernels import _arrays, _capsule_clearances, _closest_on_segments

_FAST, _SLOW, _SWITCH = 2.0, 1.6, 0.5  # ISO 13855 (safety.ssm)


@njit(cache=True, inline="always")
def _norm3(x, y, z):
    return math.sqrt(x * x + y * y + z * z)


@njit(cache=True)
def _protective_separation(speed, params, z_d, covered_time):
    """S_p (m) of eq. (1)-(2) for one robot point approaching at `speed` (`ssm.protective_separation`)."""
    t_r, a, intrusion, uncertainty, human_speed = params[0], params[1], params[2], params[3], params[4]
    speed = max(speed, 0.0)
    s_s = speed * speed / (2.0 * a)
    t_s = speed / a
    time = t_r + t_s
    if covered_time > 0:
        human = (human_speed if human_speed > 0 else _FAST) * max(time - covered_time, 0.0)
    elif human_speed > 0:
        human = human_speed * time
    else:
        fast = _FAST * time
        human = fast if fast <= _SWITCH else max(_SLOW * time, _SWITCH)
    return human + speed * (t_r + params[5]) + s_s + intrusion + z_d + uncertainty


@njit(cache=True, inline="always")
def _path_stop(params, speed, fastest):
    """`params` with the deceleration a point approaching at `speed` has when the controller brakes
    the whole path at a on its fastest point (`fastest`, both at full path speed): a v / V, so
    that T_s = V / a and S_s = v V / (2a) (`ssm.path_stop_deceleration`)."""
    out = params.copy()
    if fastest > speed and speed > 0.0:
        out[1] = params[1] * speed / fastest
    return out


@njit(cache=True)
def _pieces(params, covered_time):
    """(K, constant, v_low, v_high) of each piece of S_h(T_r + v / a) (`SeparationParameters._pieces`)."""
    t_r, a, human_speed = params[0], params[1], params[4]
    if covered_time > 0:
        speed = human_speed if human_speed > 0 else _FAST
        switch = max(a * (covered_time - t_r), 0.0)
        out = np.empty((2, 4))
        out[0, 0], out[0, 1], out[0, 2], out[0, 3] = 0.0, 0.0, 0.0, switch
        out[1, 0], out[1, 1], out[1, 2], out[1, 3] = speed, -speed * covered_time, switch, np.inf
        return out
    if human_speed > 0:
        out = np.empty((1, 4))
        out[0, 0], out[0, 1], out[0, 2], out[0, 3] = human_speed, 0.0, 0.0, np.inf
        return out
    fast_end = max(a * (_SWITCH / _FAST - t_r), 0.0)
    slow_start = max(a * (_SWITCH / _SLOW - t_r), 0.0)
    out = np.empty((3, 4))
    out[0, 0], out[0, 1], out[0, 2], out[0, 3] = _FAST, 0.0, 0.0, fast_end
    out[1, 0], out[1, 1], out[1, 2], out[1, 3] = 0.0, _SWITCH, fast_end, slow_start
    out[2, 0], out[2, 1], out[2, 2], out[2, 3] = _SLOW, 0.0, slow_start, np.inf
    return out


@njit(cache=True)
def _permissible_speed(distance, params, pieces, z_d):
    """The largest v_r with S_p(v_r) <= distance, per ISO 13855 piece (`ssm.permissible_speed`)."""
    t_r, a = params[0], params[1]
    d = distance - (params[2] + params[3] + z_d)
    best = 0.0
    for p in range(pieces.shape[0]):
        k, constant, low, high = pieces[p, 0], pieces[p, 1], pieces[p, 2], pieces[p, 3]
        if high <= low:
            continue
        b = k / a + t_r + params[5]
        c = k * t_r + constant - d
        root = a * (math.sqrt(max(b * b - 2.0 * c / a, 0.0)) - b)
        if root >= low - 1e-12 and root <= high + 1e-12 and c <= 0:
            best = max(best, root)
    if math.isinf(d) and d > 0:
        return math.inf
    return best


@njit(cache=True, inline="always")
def _reach(v_start, v_end, i, limbs, body, covered_time, fastest):
    """S_p at the fastest end point of robot capsule i (a link segment's fastest points), the larger
    of the limbs' and the body's, with the path's stop (`_path_stop`)."""
    v_max = max(_norm3(v_start[i, 0], v_start[i, 1], v_start[i, 2]),
                _norm3(v_end[i, 0], v_end[i, 1], v_end[i, 2]))
    return max(_protective_separation(v_max, _path_stop(limbs, v_max, fastest), 0.0, covered_time),
               _protective_separation(v_max, _path_stop(body, v_max, fastest), 0.0, covered_time))


@njit(cache=True, inline="always")
def _pairs_of(mask):
    """The (k, r) indices of the true entries of a (K, R) mask, row-major (as np.nonzero)."""
    count = 0
    for i in range(mask.shape[0]):
        for j in range(mask.shape[1]):
            if mask[i, j]:
                count += 1
    k = np.empty(count, dtype=np.int64)
    r = np.empty(count, dtype=np.int64)
    n = 0
    for i in range(mask.shape[0]):
        for j in range(mask.shape[1]):
            if mask[i, j]:
                k[n], r[n] = i, j
                n += 1
    return k, r


@njit(cache=True)
def _screen(r_start, r_end, r_radius, v_start, v_end, h_start, h_end, h_radius, z_d, limbs, body,
            covered_time, fastest):
    """Clearances (K, R) and the candidate pairs (k, r), row-major: nearer than S_p at the capsule's
    fastest end point plus the region's Z_d (`SafetyRules.screen`)."""
    distance = _capsule_clearances(r_start, r_end, r_radius, h_start, h_end, h_radius)
    near = np.empty(distance.shape, dtype=np.bool_)
    for i in range(distance.shape[0]):
        reach = _reach(v_start, v_end, i, limbs, body, covered_time, fastest)
        for j in range(distance.shape[1]):
            near[i, j] = distance[i, j] < reach + z_d[j]
    k, r = _pairs_of(near)
    return distance, k, r


@njit(cache=True)
def _pair_geometry(r_start, r_end, r_radius, v_start, v_end, h_start, h_end, k, r):
    """Closest points of the pairs (k, r) (`rules.pair_geometry`): t (N,), the robot's surface point,
    the body point, the unit direction robot -> body, the robot point's velocity (N, 3 each) and
    its approach speed (N,)."""
    size = k.shape[0]
    t_out = np.empty(size)
    surface = np.empty((size, 3))
    on_body = np.empty((size, 3))
    direction = np.empty((size, 3))
    velocity = np.empty((size, 3))
    approach = np.empty(size)
    for n in range(size):
        i, j = k[n], r[n]
        d1x, d1y, d1z = r_end[i, 0] - r_start[i, 0], r_end[i, 1] - r_start[i, 1], r_end[i, 2] - r_start[i, 2]
        d2x, d2y, d2z = h_end[j, 0] - h_start[j, 0], h_end[j, 1] - h_start[j, 1], h_end[j, 2] - h_start[j, 2]
        rx, ry = r_start[i, 0] - h_start[j, 0], r_start[i, 1] - h_start[j, 1]
        rz = r_start[i, 2] - h_start[j, 2]
        s, t = _closest_on_segments(d1x * d1x + d1y * d1y + d1z * d1z, d1x * d2x + d1y * d2y + d1z * d2z,
                                    d1x * rx + d1y * ry + d1z * rz, d2x * d2x + d2y * d2y + d2z * d2z,
                                    d2x * rx + d2y * ry + d2z * rz)
        t_out[n] = t
        robot_x = r_start[i, 0] + s * (r_end[i, 0] - r_start[i, 0])
        robot_y = r_start[i, 1] + s * (r_end[i, 1] - r_start[i, 1])
        robot_z = r_start[i, 2] + s * (r_end[i, 2] - r_start[i, 2])
        for c in range(3):
            on_body[n, c] = h_start[j, c] + t * (h_end[j, c] - h_start[j, c])
            velocity[n, c] = v_start[i, c] + s * (v_end[i, c] - v_start[i, c])
        gx, gy, gz = on_body[n, 0] - robot_x, on_body[n, 1] - robot_y, on_body[n, 2] - robot_z
        norm = _norm3(gx, gy, gz)
        if norm > 1e-9:
            scale = max(norm, 1e-12)
            direction[n, 0], direction[n, 1], direction[n, 2] = gx / scale, gy / scale, gz / scale
        else:  # axes that cross (deep contact): along the robot point's own motion
            scale = max(_norm3(velocity[n, 0], velocity[n, 1], velocity[n, 2]), 1e-12)
            for c in range(3):
                direction[n, c] = velocity[n, c] / scale
        approach[n] = (velocity[n, 0] * direction[n, 0] + velocity[n, 1] * direction[n, 1]
                       + velocity[n, 2] * direction[n, 2])
        surface[n, 0] = robot_x + r_radius[i] * direction[n, 0]
        surface[n, 1] = robot_y + r_radius[i] * direction[n, 1]
        surface[n, 2] = robot_z + r_radius[i] * direction[n, 2]
    return t_out, surface, on_body, direction, velocity, approach


@njit(cache=True, inline="always")
def _box_distance(x, y, z, lower, upper, b):
    """Distance from the point (x, y, z) to box b (0 inside)."""
    gx = max(lower[b, 0] - x, 0.0) + max(x - upper[b, 0], 0.0)
    gy = max(lower[b, 1] - y, 0.0) + max(y - upper[b, 1], 0.0)
    gz = max(lower[b, 2] - z, 0.0) + max(z - upper[b, 2], 0.0)
    return math.sqrt(gx * gx + gy * gy + gz * gz)


@njit(cache=True, inline="always")
def _clamped_one(point, direction, radius, margin, lower, upper):
    """Whether a part, a ball of `radius` at `point` pushed along `direction`, is clamped: moved
    `margin` on, it comes nearer a fixed box within its radius, or it is in one (`regions.clamped`)."""
    x, y, z = point[0], point[1], point[2]
    mx, my, mz = x + margin * direction[0], y + margin * direction[1], z + margin * direction[2]
    for b in range(lower.shape[0]):
        now = _box_distance(x, y, z, lower, upper, b)
        then = _box_distance(mx, my, mz, lower, upper, b)
        if then < radius and (then < now - 1e-9 or now <= 0.0):
            return True
    return False


@njit(cache=True)
def _near_surfaces(start, end, radius, z_d, lower, upper, margin, samples):
    """(R,) `regions.near_surfaces` (its reference): Z_d > 0 and the axis, sampled at `samples`
    points less half their spacing (a lower bound), within radius + Z_d + margin of a box."""
    count = radius.shape[0]
    near = np.zeros(count, dtype=np.bool_)
    for i in range(count):
        if not z_d[i] > 0.0:
            continue
        ax, ay, az = end[i, 0] - start[i, 0], end[i, 1] - start[i, 1], end[i, 2] - start[i, 2]
        reach = radius[i] + z_d[i] + margin + 0.5 * _norm3(ax, ay, az) / (samples - 1)
        for s in range(samples):
            t = s / (samples - 1)
            x, y, z = start[i, 0] + t * ax, start[i, 1] + t * ay, start[i, 2] + t * az
            for b in range(lower.shape[0]):
                if _box_distance(x, y, z, lower, upper, b) < reach:
                    near[i] = True
                    break
            if near[i]:
                break
    return near


@njit(cache=True, inline="always")
def _point_to_segment(x, y, z, start, end, j):
    """Distance from the point (x, y, z) to the segment j of (start, end)."""
    ax, ay, az = end[j, 0] - start[j, 0], end[j, 1] - start[j, 1], end[j, 2] - start[j, 2]
    length2 = ax * ax + ay * ay + az * az
    t = 0.0
    if length2 > 0.0:
        along = (x - start[j, 0]) * ax + (y - start[j, 1]) * ay + (z - start[j, 2]) * az
        t = min(max(along / length2, 0.0), 1.0)
    return _norm3(x - start[j, 0] - t * ax, y - start[j, 1] - t * ay, z - start[j, 2] - t * az)


@njit(cache=True, inline="always")
def _clamped_by_capsule(point, direction, radius, margin, k, r_start, r_end, r_radius):
    """Whether a part, a ball of `radius` at `point` pushed along `direction` by robot capsule k,
    moved `margin` on, reaches into another robot capsule and comes nearer it (the judge's
    `Judge.clamped_against`; `regions.clamped_by_capsules`)."""
    x, y, z = point[0], point[1], point[2]
    mx, my, mz = x + margin * direction[0], y + margin * direction[1], z + margin * direction[2]
    for j in range(r_radius.shape[0]):
        if j == k:
            continue
        now = _point_to_segment(x, y, z, r_start, r_end, j) - r_radius[j]
        then = _point_to_segment(mx, my, mz, r_start, r_end, j) - r_radius[j]
        if then < radius and then < now - 1e-9:
            return True
    return False


@njit(cache=True)
def _governed_by_pfl(r, pfl_region, hybrid, zone_centers, zone_radii, surface, on_body, direction,
                     region_radius, pair_near, use_clamping, lower, upper, margin, k, r_start, r_end,
                     r_radius):
    """(zone PFL (N,), governed (N,)): the pairs whose region PFL governs in a collaborative zone
    (hybrid: where the middle of the closest points lies in one), and of those the ones whose
    part nothing clamps: neither near something that clamps it whatever the push (pair_near (N,),
    `SafetyRules.near_pairs`) nor pushed onto a fixed box or into another robot capsule of (r_start,
    r_end, r_radius) than the pair's k (`SafetyRules.governed_by_pfl`)."""
    size = r.shape[0]
    zone = np.empty(size, dtype=np.bool_)
    governed = np.empty(size, dtype=np.bool_)
    for n in range(size):
        pfl = pfl_region[r[n]]
        if pfl and hybrid:
            pfl = False
            for z in range(zone_radii.shape[0]):
                gx = 0.5 * (surface[n, 0] + on_body[n, 0]) - zone_centers[z, 0]
                gy = 0.5 * (surface[n, 1] + on_body[n, 1]) - zone_centers[z, 1]
                gz = 0.5 * (surface[n, 2] + on_body[n, 2]) - zone_centers[z, 2]
                if _norm3(gx, gy, gz) <= zone_radii[z]:
                    pfl = True
                    break
        zone[n] = pfl
        if pfl and use_clamping:
            radius = region_radius[r[n]]
            pfl = not (pair_near[n]
                       or _clamped_one(on_body[n], direction[n], radius, margin, lower, upper)
                       or _clamped_by_capsule(on_body[n], direction[n], radius, margin, k[n], r_start, r_end,
                                              r_radius))
        governed[n] = pfl
    return zone, governed


@njit(cache=True)
def _hold_clamps(k, r, governed, clamped, clamped_until, now, hold):
    """A clamped pair counts as clamped until now + hold; a governed pair still in its hold is clamped
    (`SafetyRules.override`, `clamp_hold`): governed and clamped (N,) and clamped_until (K, R) in place."""
    for n in range(k.shape[0]):
        if clamped[n]:
            clamped_until[k[n], r[n]] = now + hold
    for n in range(k.shape[0]):
        if governed[n] and clamped_until[k[n], r[n]] > now:
            governed[n] = False
            clamped[n] = True


@njit(cache=True)
def _separations(r, speed, body_region, limbs, body, z_d, covered_time, full_speed, fastest):
    """S_p (N,) of each pair at `speed` (N,), head and torso at their own v_h, the path braked on its
    fastest point (`full_speed` (N,) and `fastest` at full path speed; `SafetyRules.separations`)."""
    out = np.empty(r.shape[0])
    for n in range(r.shape[0]):
        params = _path_stop(body if body_region[r[n]] else limbs, full_speed[n], fastest)
        out[n] = _protective_separation(speed[n], params, z_d[n], covered_time)
    return out


@njit(cache=True)
def _ssm_scales(r, distance, approach, governed, clamped, z_d, body_region, limbs, body, covered_time,
                fastest, moving_speed, pfl_floor, clamped_scale):
    """The override of every pair by SSM (PFL pairs start from it), and the PFL pairs that still need
    their robot mass (`SafetyRules.override` up to the masses): (scale (N,), needs mass (N,)).
    clamped_scale (N,): a clamped pair's override where >= 0 (the compression budget), else SSM's."""
    size = r.shape[0]
    scale = np.empty(size)
    moving = np.empty(size, dtype=np.bool_)
    any_pfl = False
    for n in range(size):
        moving[n] = approach[n] > (1e-9 if clamped[n] else moving_speed)
        if clamped[n] and clamped_scale[n] >= 0.0:
            scale[n] = clamped_scale[n]
        elif moving[n]:
            j = r[n]
            params = _path_stop(body if body_region[j] else limbs, approach[n], fastest)
            v_ssm = _permissible_speed(distance[n], params, _pieces(params, covered_time), z_d[j])
            scale[n] = min(v_ssm / max(approach[n], 1e-12), 1.0)
        else:
            scale[n] = 1.0
        if governed[n] and moving[n] and scale[n] < 1.0:
            any_pfl = True
    needs_mass = np.zeros(size, dtype=np.bool_)
    if not any_pfl:
        return scale, needs_mass
    ssm_min = 1.0
    for n in range(size):
        if not governed[n]:
            ssm_min = min(ssm_min, scale[n])
    for n in range(size):
        if not governed[n]:
            continue
        floor = pfl_floor[r[n]]
        pfl = moving[n] and scale[n] < 1.0 and approach[n] > floor
        if approach[n] <= floor:
            scale[n] = 1.0
        if pfl:
            # a PFL pair's override is at least max(SSM's, floor / approach): one whose bound is
            # no smaller than the smallest override of the SSM pairs cannot set the minimum
            bound = max(scale[n], floor / max(approach[n], 1e-12))
            if bound >= ssm_min:
                scale[n] = min(bound, 1.0)
            else:
                needs_mass[n] = True
    return scale, needs_mass


def screen(robot, robot_velocity, regions, z_d, limbs, body, covered_time, fastest):
    """`_screen` on any array-likes: (distance (K, R), k, r)."""
    return _screen(*_arrays(*robot, *robot_velocity, *regions, z_d), limbs, body, float(covered_time),
                   float(fastest))


def pair_geometry(robot, robot_velocity, regions, k, r):
    """`_pair_geometry` on any array-likes (k, r int64 arrays)."""
    return _pair_geometry(*_arrays(*robot, *robot_velocity, regions[0], regions[1]), k, r)


def _warm_up_steps() -> list:
    """Calls that compile (or load) every kernel here on tiny inputs, each on its own
    (`kernels.warm_up`): one robot capsule, one body region, one pair."""
    one, params = np.zeros((1, 3)), np.array([0.1, 5.0, 0.05, 0.01, 0.0, 0.0])
    capsules = (one, one + 1.0, np.ones(1))
    pair, approach = np.zeros(1, dtype=np.int64), np.zeros(1)
    flags = np.ones(1, dtype=np.bool_)
    return [
        lambda: screen(capsules, (one, one), capsules, np.zeros(1), params, params, 0.0, 1.0),
        lambda: pair_geometry(capsules, (one, one), capsules, pair, pair),
        lambda: _governed_by_pfl(pair, flags, True, one, np.ones(1), one, one, one, np.ones(1), ~flags, True,
                                 one, one + 1.0, 0.02, pair, one, one, np.ones(1)),
        lambda: _near_surfaces(one, one, np.ones(1), np.ones(1), one, one + 1.0, 0.02, 17),
        lambda: _hold_clamps(pair, pair, flags.copy(), ~flags, np.zeros((1, 1)), 0.0, 0.5),
        lambda: _separations(pair, approach, flags, params, params, np.zeros(1), 0.0, approach, 1.0),
        lambda: _ssm_scales(pair, np.zeros(1), approach, flags.copy(), ~flags, np.zeros(1), flags, params,
                            params, 0.0, 1.0, 0.01, np.ones(1), -np.ones(1)),
        lambda: _pieces(params, 0.0),
    ]


kernels.register_group(globals(), kernels)
