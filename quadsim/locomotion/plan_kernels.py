"""The procedural controller's per-frame plan, compiled.

:func:`plan_rows` is one step of the whole plan for N rows (characters) as
one numba kernel: speed and turning (with the clamps reported as flags),
gait choice with hysteresis and transitions along the duty-factor curve,
stride limits, the reach governor, the CPG
(:func:`~quadsim.locomotion.cpg.cpg_step_rows`), the body on its path,
:func:`feet_rows` (stage 5: lift-off and touchdown, swing progress,
touchdown targets on the turning arc, Catmull-Rom swing paths) and
:func:`body_rows` (stage 6: the spine's concave/convex machine and slow
flexion, vaulting drops, height, pitch, girdle sway, tail); it also gives
the legs' stride fractions and, when asked (stage 7), packs each row's plan
for the posing kernel (:func:`~quadsim.locomotion.pose_kernel.pack_plan`'s
layout). A lone :class:`~quadsim.locomotion.controller.ProceduralController`
runs it on one row, :class:`~quadsim.locomotion.batch.BatchController` on
N, so the two agree by construction. The numpy counterparts of stage 5, the
tests' reference, are :func:`quadsim.locomotion.turning.arc_advance` and
:func:`quadsim.locomotion.footpath.swing_position`; of the scheduler,
:class:`quadsim.locomotion.transition.GaitScheduler`.

The row helpers take whole arrays and a row index rather than views of a
row (``keys[n]``): each view made in the loops costs an atomic reference
count, which the threads of :func:`plan_rows_parallel` contend for.

Units are SI (m, s, rad); legs in the order LF, RF, LH, RH.
"""

from __future__ import annotations

import math

import numpy as np
from numba import get_num_threads, njit, prange

from quadsim.locomotion.cpg import TWO_PI, cpg_step_rows
from quadsim.locomotion.footpath import SWING_KNOTS
from quadsim.locomotion.pose_kernel import (BEND_PITCH, BEND_YAW, FEET, FOLD, HEADING, LOOK,
                                            PITCH, ROOT, SWAY, TAIL, TOE)

#: Shortest swing, as a fraction of the stride, worth lifting a foot for.
MIN_SWING = 0.12

_KNOTS = np.ascontiguousarray(SWING_KNOTS, dtype=float)


@njit(cache=True, inline="always")
def _frac(x):
    """``x % 1.0`` (Python's float modulo) as ``x - floor(x)``: the same value
    for every float (the difference is exact, or rounds the same sum as the
    modulo's), without the library ``fmod`` call."""
    return x - math.floor(x)


@njit(cache=True)
def feet_rows(theta, theta_prev, duty, final_duty, freq, v, yaw_rate, keys, key_heading,
               foot_offset, trailing, swing_height, half_min, reach_margin, stance, swing_s,
               theta_lo, theta_td, planted, liftoff, feet, fold):
    """Stage 5 of the step for N rows, compiled: lift-off and touchdown, swing
    progress, touchdown targets on the turning arc and swing paths (as
    :meth:`ProceduralController._advance`, leg by leg).

    Parameters
    ----------
    theta, theta_prev : ndarray, shape (N, 4)
        Leg phases after and before this step's CPG update (rad).
    duty, final_duty, freq, v, yaw_rate : ndarray, shape (N,)
        Duty factor now and of the gait being entered, stride frequency (Hz),
        speed (m/s), turn rate (rad/s).
    keys : ndarray, shape (N, 2, 3)
        Hind and fore key points (m); ``key_heading`` (N, 2) their headings (rad).
    foot_offset : ndarray, shape (N, 4, 3)
        Mid-stance foot offsets from the key points (m).
    trailing : ndarray of bool, shape (N, 4)
        Planted feet about to fall out of reach.
    swing_height, half_min : ndarray, shape (N,)
        Swing clearance (m) and the worst leg's half stance sweep (m).
    reach_margin : float
    stance, swing_s, theta_lo, theta_td, planted, liftoff : ndarray
        The feet's state, (N, 4) and (N, 4, 3), updated in place.
    feet : ndarray, shape (N, 4, 3)
        Output: foot positions (m).
    fold : ndarray, shape (N, 4)
        Output: swing fold 0..1.
    """
    for n in range(theta.shape[0]):
        dn = duty[n]
        stance_time = max(dn, min(final_duty[n], 1.0 - MIN_SWING)) / freq[n]
        omega = TWO_PI * freq[n]
        for i in range(4):
            th = theta[n, i]
            if stance[n, i]:
                u = _frac(th / TWO_PI)
                due = dn <= u and u <= 1.0 - MIN_SWING
                if (due or trailing[n, i]) and th - theta_td[n, i] > 1e-9:
                    stance[n, i] = False
                    for c in range(3):
                        liftoff[n, i, c] = planted[n, i, c]
                    cross = TWO_PI * (math.floor(th / TWO_PI) + dn)
                    theta_lo[n, i] = cross if due and cross > theta_prev[n, i] else th
                    td = TWO_PI * (math.floor(th / TWO_PI) + 1.0)
                    if td - th < TWO_PI * MIN_SWING:
                        td += TWO_PI
                    theta_td[n, i] = td
                    swing_s[n, i] = 0.0
            if not stance[n, i]:
                sp = min(max((th - theta_lo[n, i]) / (theta_td[n, i] - theta_lo[n, i]), 0.0),
                         1.0)
                swing_s[n, i] = max(swing_s[n, i], sp)
        lead = min(0.5 * stance_time, reach_margin * half_min[n] / max(v[n], 1e-6))
        for i in range(4):
            fold[n, i] = 0.0
            if stance[n, i]:
                for c in range(3):
                    feet[n, i, c] = planted[n, i, c]
                continue
            g = 1 if i < 2 else 0  # the fore legs follow the fore key point
            tau = max(theta_td[n, i] - theta[n, i], 0.0) / omega + lead
            h = key_heading[n, g]
            dh = yaw_rate[n] * tau
            if abs(dh) < 1e-6:
                dx = v[n] * tau * math.sin(h + 0.5 * dh)
                dz = v[n] * tau * math.cos(h + 0.5 * dh)
            else:
                k = v[n] / yaw_rate[n]
                dx = k * (math.cos(h) - math.cos(h + dh))
                dz = k * (math.sin(h + dh) - math.sin(h))
            kh = h + dh
            cs, sn = math.cos(kh), math.sin(kh)
            ox, oz = foot_offset[n, i, 0], foot_offset[n, i, 2]
            tx = (keys[n, g, 0] + dx) + (cs * ox + sn * oz)
            tz = (keys[n, g, 2] + dz) + (-sn * ox + cs * oz)
            ax, ay, az = liftoff[n, i, 0], liftoff[n, i, 1], liftoff[n, i, 2]
            ddx, ddy, ddz = tx - ax, 0.0 - ay, tz - az
            step_len = math.sqrt(ddx * ddx + ddy * ddy + ddz * ddz)
            hs = swing_height[n]
            height = min(hs, 0.35 * step_len + 0.3 * hs)
            s = swing_s[n, i]
            if s >= 1.0 - 1e-12:  # touchdown
                planted[n, i, 0], planted[n, i, 1], planted[n, i, 2] = tx, 0.0, tz
                feet[n, i, 0], feet[n, i, 1], feet[n, i, 2] = tx, 0.0, tz
                stance[n, i] = True
                continue
            # the Catmull-Rom swing path (footpath.swing_position)
            x = min(max(s, 0.0), 1.0) * 4
            j = min(math.floor(x), 3)
            t = x - j
            t2, t3 = t * t, t * t * t
            for c in range(3):
                ac = liftoff[n, i, c]
                dc = (tx, 0.0, tz)[c] - ac
                up = height if c == 1 else 0.0
                p0 = ac + _KNOTS[j, 0] * dc + _KNOTS[j, 1] * up
                p1 = ac + _KNOTS[j + 1, 0] * dc + _KNOTS[j + 1, 1] * up
                p2 = ac + _KNOTS[j + 2, 0] * dc + _KNOTS[j + 2, 1] * up
                p3 = ac + _KNOTS[j + 3, 0] * dc + _KNOTS[j + 3, 1] * up
                feet[n, i, c] = 0.5 * ((2 * p1) + (-p0 + p2) * t
                                       + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t2
                                       + (-p0 + 3 * p1 - 3 * p2 + p3) * t3)
            fold[n, i] = math.sin(math.pi * s) ** 2


@njit(cache=True)
def body_rows(stance, u, duty, freq, v, bend, theta_s, keys, key_heading, foot_offset, feet,
               sweep_cols, drops, flexed, extended, slow_scale, spine_amp, bound, drop, h,
               pelvis_height, body_length, n_tail, reach_margin, max_sway, dt, a_smooth,
               a_drop, a_tail, spine_angle, spine_smooth, drops_now, height, tail, pitch, sway):
    """Stage 6 of the step for N rows, compiled: the spine's concave/convex
    machine and slow flexion, the bob and vaulting drops, body height and
    pitch, girdle sway and the lagging tail (as
    :meth:`ProceduralController._advance`).

    ``stance`` (N, 4) bool, ``u`` (N, 4) stride fractions, ``keys`` (N, 2, 3)
    (m), ``key_heading`` (N, 2) (rad), ``foot_offset`` and ``feet`` (N, 4, 3)
    (m), ``sweep_cols`` (N, 4, D) half sweeps (m) at the body ``drops`` (D,);
    the other per-row inputs have shape (N,). ``a_smooth``, ``a_drop`` and
    ``a_tail`` are the step's smoothing factors ``1 - exp(-dt / tau)``.
    ``spine_angle``, ``spine_smooth``, ``height`` (N,), ``drops_now`` (N, 2)
    and ``tail`` (N, T_max, 2) are updated in place; ``pitch`` (N,) and
    ``sway`` (N, 2) (hind, fore) are outputs (rad).
    """
    D = drops.shape[0]
    need = np.empty(4)
    lx = np.empty(4)
    lz = np.empty(4)
    for n in range(stance.shape[0]):
        # the concave/convex machine: flexed while no hind foot is down
        tgt = extended[n] if (stance[n, 2] or stance[n, 3]) else flexed[n]
        rate = 5.0 * abs(flexed[n] - extended[n]) * freq[n]
        spine_angle[n] += min(max(tgt - spine_angle[n], -rate * dt), rate * dt)
        slow = slow_scale[n] * spine_amp[n] * math.sin(theta_s[n])
        raw = bound[n] * spine_angle[n] + (1.0 - bound[n]) * slow
        spine_smooth[n] += (raw - spine_smooth[n]) * a_smooth
        sdut = max(duty[n], 1e-3)
        support = 0.0
        for i in range(4):
            if stance[n, i]:
                support += math.sin(math.pi * min(max(u[n, i] / sdut, 0.0), 1.0))
        bob = 0.6 * drop[n] * h[n] * (0.5 - support / 4)
        # vaulting: each girdle drops as far as its planted feet need (the
        # girdles' headings' cosines and sines taken once)
        c1, s1 = math.cos(key_heading[n, 1]), math.sin(key_heading[n, 1])
        c0, s0 = math.cos(key_heading[n, 0]), math.sin(key_heading[n, 0])
        for i in range(4):
            g = 1 if i < 2 else 0
            c, sn = (c1, s1) if g else (c0, s0)
            along = _ahead_of_mid(keys, foot_offset, feet, n, i, c0, s0, c1, s1)
            need[i] = 0.0
            if stance[n, i]:  # np.interp(x, sweep_cols[n, i], drops)
                x = abs(along) / reach_margin
                j = -1
                for k in range(D):
                    if sweep_cols[n, i, k] <= x:
                        j += 1
                if j < 0:
                    need[i] = drops[0]
                elif j >= D - 1:
                    need[i] = drops[D - 1]
                else:
                    x0 = sweep_cols[n, i, j]
                    need[i] = (drops[j + 1] - drops[j]) / (sweep_cols[n, i, j + 1] - x0) \
                        * (x - x0) + drops[j]
            # the foot in its girdle's frame, for the sway: turned by -heading,
            # whose cosine is c and sine -sn
            fx, fz = feet[n, i, 0] - keys[n, g, 0], feet[n, i, 2] - keys[n, g, 2]
            lx[i] = c * fx - sn * fz
            lz[i] = sn * fx + c * fz
        dh = max(drop[n], max(need[2], need[3]))
        df = max(drop[n], max(need[0], need[1]))
        drops_now[n, 0] += (dh - drops_now[n, 0]) * a_drop
        drops_now[n, 1] += (df - drops_now[n, 1]) * a_drop
        target_h = pelvis_height[n] * (1.0 - drops_now[n, 0]) + bob
        height[n] += (target_h - height[n]) * a_drop
        pitch[n] = math.atan2((drops_now[n, 1] - drops_now[n, 0]) * pelvis_height[n],
                              body_length[n])
        # girdle sway from where the left and right feet are
        for g, (left, right) in enumerate(((2, 3), (0, 1))):  # hind, fore
            width = max(abs(lx[left] - lx[right]), 1e-3)
            sway[n, g] = min(max(0.1 * math.atan2(lz[left] - lz[right], width), -max_sway),
                             max_sway)
        # tail: each joint follows the one before with a lag
        p0 = (0.6 * spine_smooth[n] - 0.02 * v[n]) / n_tail[n]
        p1 = (-0.8 * bend[n] - 0.5 * sway[n, 0]) / n_tail[n]
        for k in range(tail.shape[1]):
            t0, t1 = tail[n, k, 0], tail[n, k, 1]
            tail[n, k, 0] = t0 + a_tail * (p0 - t0)
            tail[n, k, 1] = t1 + a_tail * (p1 - t1)
            p0, p1 = t0, t1


# ---------------------------------------------------------------- the whole plan
# rows of the per-row constants ``consts`` (NC, N)
C_H, C_PELVIS, C_HIND_Z, C_BODY, C_STAND_V, C_MAX_V, C_MAX_TURN, C_FLEXED, C_EXTENDED, \
    C_RMIN, C_SLOW, C_WALK_TOP, C_NTAIL, C_HYST, C_NAUTO = range(15)
NC = 15
# entries of the step's scalars ``sc``
S_DT, S_ACC, S_REACH, S_VAULT, S_MAX_BEND, S_MAX_SWAY, S_A_TURN, S_A_BEND, S_A_SMOOTH, \
    S_A_DROP, S_A_TAIL, S_MU, S_GAIN, S_COUPLING, S_SPINE_COUPLING = range(15)
NS = 15
# columns of a parameter row (the blendable GaitParams)
P_DUTY, P_PH0, P_COEF, P_MINV, P_SWING, P_DROP, P_BOUND, P_SPAMP = 0, 1, 5, 6, 7, 8, 9, 10
NP_ = 11


@njit(cache=True)
def _interp_knot(x, xp):
    """Where ``numpy.interp(x, xp, fp)`` reads ``fp`` for one ``x``: ``(j, 0)``
    for ``fp[j]`` itself, ``(j, 1)`` for the line from knot ``j`` to ``j + 1``
    (its search and special cases, for :func:`_interp1` and its row forms)."""
    n = xp.shape[0]
    if x > xp[n - 1]:
        return n - 1, 0
    if x < xp[0]:
        return 0, 0
    if x == xp[n - 1]:
        return n - 1, 0
    j = 0
    while j + 1 < n and xp[j + 1] <= x:
        j += 1
    if j >= n - 1:
        return n - 1, 0
    if xp[j] == x:
        return j, 0
    return j, 1


@njit(cache=True)
def _interp1(x, xp, fp):
    """``numpy.interp(x, xp, fp)`` for one ``x`` (the formula and order of
    operations of ``numpy.interp``)."""
    j, line = _interp_knot(x, xp)
    if not line:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[j]


@njit(cache=True)
def _interp_row(x, xp, fp, n):
    """:func:`_interp1` of ``x`` on row ``n`` of ``fp`` (N, D)."""
    j, line = _interp_knot(x, xp)
    if not line:
        return fp[n, j]
    slope = (fp[n, j + 1] - fp[n, j]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[n, j]


@njit(cache=True)
def _interp_col(x, xp, fp, n, i):
    """:func:`_interp1` of ``x`` on ``fp[n, :, i]`` (``fp`` (N, D, C))."""
    j, line = _interp_knot(x, xp)
    if not line:
        return fp[n, j, i]
    slope = (fp[n, j + 1, i] - fp[n, j, i]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[n, j, i]


@njit(cache=True)
def _target_row(table, law, k, g, speed, out, m):
    """GaitParams.of(gait ``g`` of kind ``k``, speed) into row ``m`` of ``out`` (M, NP)."""
    for c in range(out.shape[1]):
        out[m, c] = table[k, g, c]
    lo, hi, d0, d1 = law[k, g, 0], law[k, g, 1], law[k, g, 2], law[k, g, 3]
    s = min(max((speed - lo) / (hi - lo), 0.0), 1.0)
    out[m, P_DUTY] = d0 + s * (d1 - d0)


@njit(cache=True)
def _scheduled_row(table, law, k, cur, in_tr, elapsed, duration, source, n, speed, out, m):
    """GaitScheduler.params(speed) of row ``n`` (its transition's ``source[n]``)
    into row ``m`` of ``out``."""
    _target_row(table, law, k, cur, speed, out, m)
    if in_tr:
        s = min(elapsed / duration, 1.0) ** 2
        for c in range(out.shape[1]):
            if c >= P_PH0 and c < P_PH0 + 4:
                a = source[n, c]
                dpsi = _frac(out[m, c] - a + 0.5) - 0.5
                out[m, c] = _frac(a + s * dpsi)
            else:
                a = source[n, c]
                out[m, c] = a + s * (out[m, c] - a)


@njit(cache=True)
def _keys_row(root_xz, heading, bend, hind_z, body_length, keys, kh, n):
    """Row ``n``'s hind and fore key points ``keys[n]`` (m) and their headings
    ``kh[n]`` (rad), from the pelvis on the ground ``root_xz[n]``."""
    fh = heading + 0.5 * bend
    hx = root_xz[n, 0] + math.sin(heading) * hind_z
    hy = root_xz[n, 1] + 0.0
    hz = root_xz[n, 2] + math.cos(heading) * hind_z
    keys[n, 0, 0], keys[n, 0, 1], keys[n, 0, 2] = hx, hy, hz
    keys[n, 1, 0] = hx + math.sin(fh) * body_length
    keys[n, 1, 1] = hy + 0.0
    keys[n, 1, 2] = hz + math.cos(fh) * body_length
    kh[n, 0] = heading
    kh[n, 1] = heading + bend


@njit(cache=True)
def _room_row(keys, kh, offset, planted, base, room, n):
    """Trailing room (m) of each foot of row ``n``: ``base`` plus how far its
    planted point is ahead of its mid-stance point along the girdle's
    forward vector (each girdle's cosine and sine taken once)."""
    c1, s1 = math.cos(kh[n, 1]), math.sin(kh[n, 1])
    c0, s0 = math.cos(kh[n, 0]), math.sin(kh[n, 0])
    for i in range(4):
        room[i] = base + _ahead_of_mid(keys, offset, planted, n, i, c0, s0, c1, s1)


@njit(cache=True)
def _ahead_of_mid(keys, offset, points, n, i, c0, s0, c1, s1):
    """How far (m) ``points[n, i]`` lies ahead of foot ``i``'s mid-stance point
    (its girdle's key plus the foot's offset turned to the girdle's heading),
    along the girdle's forward vector; ``c0, s0`` / ``c1, s1`` are the cosine
    and sine of the hind / fore girdle's heading."""
    g = 1 if i < 2 else 0
    c, sn = (c1, s1) if g else (c0, s0)
    ox, oy, oz = offset[n, i, 0], offset[n, i, 1], offset[n, i, 2]
    mx = c * ox + sn * oz + keys[n, g, 0]
    my = oy + keys[n, g, 1]
    mz = -sn * ox + c * oz + keys[n, g, 2]
    return (points[n, i, 0] - mx) * sn + (points[n, i, 1] - my) * 0.0 \
        + (points[n, i, 2] - mz) * c


@njit(cache=True)
def _stride_length(minv, coef, speed, h):
    """Stride length (m) at ``speed`` for the parameters' least speed ``minv``
    and stride coefficient ``coef``, leg length ``h`` (m)."""
    vc = max(max(speed, minv), 1e-3)
    lam = h * coef * (vc * vc / (9.81 * h)) ** 0.3
    return lam * speed / vc if speed < vc else lam


@njit(cache=True)
def plan_rows(v_cmd_in, turn, head, gait, kind, consts, sc, substeps, table, law, auto,
              bounds, auto_pos, drops, half_sweep, sweep_min, sweep_cols, foot_offset,
              speed, yaw_rate, heading, root_xz, bend, theta, r, theta_s, r_s, freq,
              current, source_name, source, in_transition, elapsed, duration, params,
              stance, swing_s, theta_lo, theta_td, planted, liftoff, spine_angle,
              spine_smooth, drops_now, height, tail, feet, fold, pitch, sway, flags, aux,
              phase, packed):
    """One step of the whole plan for N rows (characters), compiled: speed and
    turning, gait choice and transitions, stride limits, the reach governor,
    the CPG (:func:`~quadsim.locomotion.cpg.cpg_step_rows`), the body on its
    path, the feet (:func:`feet_rows`) and the body stage (:func:`body_rows`),
    as :class:`~quadsim.locomotion.controller.ProceduralController` (one row)
    and :class:`~quadsim.locomotion.batch.BatchController` (N rows) step.

    Commands (N,): ``v_cmd_in`` speed, ``turn`` turn rate, ``head`` heading
    to steer to (NaN: use the turn rate), ``gait`` requested gait id (-1:
    automatic). The state arrays are updated in place; ``feet``, ``fold``,
    ``pitch``, ``sway`` are outputs, ``flags`` (N, 3) bool marks the clamps
    (gait speed, top speed, turn rate) and ``aux`` (N, 2) holds the speed and
    the largest turn rate the turn clamp used, for the warnings. ``phase``
    (N, 4) receives the legs' stride fractions; ``packed`` (N, F), unless it
    has no columns, each row's plan packed for the posing
    (:func:`~quadsim.locomotion.pose_kernel.pack_plan`'s layout, with
    ``(F - TAIL) // 2`` tail joints, at most the state's).
    """
    N = theta.shape[0]
    dt = sc[S_DT]
    stand = table.shape[1] - 1
    reach_margin, vault = sc[S_REACH], sc[S_VAULT]
    v_before = np.empty(N)
    omega = np.empty(N)
    psi = np.empty((N, 4))
    keys = np.empty((N, 2, 3))
    kh = np.empty((N, 2))
    room = np.empty(4)
    tgt = np.empty((1, params.shape[1]))
    for n in range(N):
        k = kind[n]
        h = consts[C_H, n]
        # 1. speed and turning
        vc = v_cmd_in[n]
        halt = vc <= 1e-9
        g = gait[n]
        flags[n, 0] = False
        flags[n, 1] = False
        flags[n, 2] = False
        if g >= 0:
            cap = 1.15 * law[k, g, 1]
            if vc > cap:
                flags[n, 0] = True
                vc = cap
        if vc > consts[C_MAX_V, n]:
            flags[n, 1] = True
            vc = consts[C_MAX_V, n]
        cur = current[n]
        if cur == stand or (in_transition[n] and source_name[n] == stand):
            progress = min(elapsed[n] / duration[n], 1.0) if in_transition[n] else 0.0
            vc = min(vc, max(progress, 0.0) ** 2 * consts[C_WALK_TOP, n])
        # the reach governor: no planted foot out of reach before it lifts
        _keys_row(root_xz, heading[n], bend[n], consts[C_HIND_Z, n], consts[C_BODY, n],
                  keys, kh, n)
        pd = params[n, P_DROP] + vault
        dmax = max(drops_now[n, 0], drops_now[n, 1])
        base = _interp_row(max(pd, dmax), drops, sweep_min, n)
        _room_row(keys, kh, foot_offset, planted, base, room, n)
        duty = params[n, P_DUTY]
        gov = math.inf
        for i in range(4):
            if not stance[n, i]:
                continue
            u = _frac(theta[n, i] / TWO_PI)
            lifts = u < duty and 1.0 - MIN_SWING >= duty
            t_lo = (duty - u if lifts else 1.0 - u + min(duty, 1.0 - MIN_SWING)) / freq[n]
            den = max(t_lo, dt)
            num = max(room[i], 0.0)
            if den == 0.0:
                if num == 0.0:
                    gov = math.nan
                    break
                continue
            gov = min(gov, num / den)
        if gov < vc:
            vc = gov
        acc = sc[S_ACC] * dt
        dv = min(max(vc - speed[n], -acc), acc)
        v_before[n] = speed[n]
        v = max(speed[n] + dv, 0.0)
        speed[n] = v
        fast = max(v, vc)
        max_rate = min(consts[C_MAX_TURN, n], max(fast, 0.1 * h) / consts[C_RMIN, n])
        aux[n, 0] = fast
        aux[n, 1] = max_rate
        if not math.isnan(head[n]):
            err = (head[n] - heading[n] + math.pi) % TWO_PI - math.pi
            rate = min(max(2.0 * err, -max_rate), max_rate)
        else:
            rate = turn[n]
            if abs(rate) > max_rate:
                flags[n, 2] = True
                rate = math.copysign(max_rate, rate)
        yaw_rate[n] += (rate - yaw_rate[n]) * sc[S_A_TURN]

        # 2. gait: the automatic choice with hysteresis
        na = int(consts[C_NAUTO, n])
        kpos = auto_pos[k, cur]
        choice = -1
        if kpos >= 0:
            hy = consts[C_HYST, n]
            lo = bounds[n, kpos - 1] * (1 - hy) if kpos > 0 else -math.inf
            hi = bounds[n, kpos] * (1 + hy) if kpos < na - 1 else math.inf
            if lo <= v and v <= hi:
                choice = cur
        if choice < 0:
            idx = 0
            for j in range(na - 1):
                if bounds[n, j] <= v:
                    idx += 1
            choice = auto[n, idx]
        if g >= 0:
            wanted = g
            if v > 1.15 * law[k, g, 1]:
                wanted = choice
        elif halt and v <= consts[C_STAND_V, n]:
            wanted = stand
        else:
            wanted = choice
        quick = cur == stand
        period = 1.0 / max(freq[n], 1e-3)
        if in_transition[n]:
            elapsed[n] += dt
            if elapsed[n] >= duration[n]:
                in_transition[n] = False
        if wanted != cur:
            _scheduled_row(table, law, k, cur, in_transition[n], elapsed[n], duration[n],
                           source, n, v, tgt, 0)
            for c in range(tgt.shape[1]):
                source[n, c] = tgt[0, c]
            source_name[n] = cur
            current[n] = wanted
            in_transition[n] = True
            elapsed[n] = 0.0
            duration[n] = 0.6 if quick else min(max(1.5 * period, 0.5), 2.0)
        _scheduled_row(table, law, k, current[n], in_transition[n], elapsed[n], duration[n],
                       source, n, v, params, n)
        # stride limits: every leg's sweep at this drop
        pd = params[n, P_DROP] + vault
        half = math.inf
        for i in range(4):
            half = min(half, _interp_col(pd, drops, half_sweep, n, i))
        margin = reach_margin - 0.05 * params[n, P_BOUND]
        limit = 2.0 * margin * half / max(params[n, P_DUTY], 1e-3)
        minv, coef = params[n, P_MINV], params[n, P_COEF]
        lam = min(_stride_length(minv, coef, v, h), limit)
        lam_min = min(_stride_length(minv, coef, minv, h), limit)
        if v > 1e-6:
            freq[n] = max(v / lam, minv / lam_min)
        else:
            freq[n] = minv / lam_min
        omega[n] = TWO_PI * freq[n]
        for i in range(4):
            psi[n, i] = params[n, P_PH0 + i]

    # 3. CPG
    theta_prev = theta.copy()
    th, rr, ts, rs = cpg_step_rows(theta, r, theta_s, r_s, omega, psi, dt, sc[S_MU],
                                   sc[S_GAIN], sc[S_COUPLING], sc[S_SPINE_COUPLING], substeps)
    for n in range(N):
        for i in range(4):
            theta[n, i] = max(th[n, i], theta_prev[n, i])
            r[n, i] = rr[n, i]
        theta_s[n] = ts[n]
        r_s[n] = rs[n]

    # 4. body on its path; stage 5's inputs
    final = np.empty(N)
    trailing = np.empty((N, 4), dtype=np.bool_)
    half_min = np.empty(N)
    duty_a = np.empty(N)
    swing_a = np.empty(N)
    spamp_a = np.empty(N)
    bound_a = np.empty(N)
    drop_a = np.empty(N)
    for n in range(N):
        h = consts[C_H, n]
        v = speed[n]
        heading[n] = heading[n] + yaw_rate[n] * dt
        kk = 0.5 * (v_before[n] + v) * dt
        mh = heading[n] - 0.5 * yaw_rate[n] * dt
        root_xz[n, 0] = root_xz[n, 0] + kk * math.sin(mh)
        root_xz[n, 1] = root_xz[n, 1] + kk * 0.0
        root_xz[n, 2] = root_xz[n, 2] + kk * math.cos(mh)
        mb = sc[S_MAX_BEND]
        bt = min(max(yaw_rate[n] * consts[C_BODY, n] / max(v, 0.3 * h), -mb), mb)
        bend[n] += (bt - bend[n]) * sc[S_A_BEND]
        _keys_row(root_xz, heading[n], bend[n], consts[C_HIND_Z, n], consts[C_BODY, n],
                  keys, kh, n)
        _target_row(table, law, kind[n], current[n], v, tgt, 0)
        final[n] = tgt[0, P_DUTY]
        pd = params[n, P_DROP] + vault
        dmax = max(drops_now[n, 0], drops_now[n, 1])
        base = _interp_row(max(pd, dmax), drops, sweep_min, n)
        _room_row(keys, kh, foot_offset, planted, base, room, n)
        reach = v * dt
        for i in range(4):
            trailing[n, i] = room[i] < reach
        half_min[n] = _interp_row(pd, drops, sweep_min, n)
        duty_a[n] = params[n, P_DUTY]
        swing_a[n] = params[n, P_SWING]
        spamp_a[n] = params[n, P_SPAMP]
        bound_a[n] = params[n, P_BOUND]
        drop_a[n] = params[n, P_DROP]

    # 5. feet
    feet_rows(theta, theta_prev, duty_a, final, freq, speed, yaw_rate, keys, kh, foot_offset,
              trailing, swing_a, half_min, reach_margin, stance, swing_s, theta_lo, theta_td,
              planted, liftoff, feet, fold)
    # 6. spine, height, tail
    for n in range(N):
        for i in range(4):
            phase[n, i] = _frac(theta[n, i] / TWO_PI)
    body_rows(stance, phase, duty_a, freq, speed, bend, theta_s, keys, kh, foot_offset, feet,
              sweep_cols, drops, consts[C_FLEXED], consts[C_EXTENDED], consts[C_SLOW],
              spamp_a, bound_a, drop_a, consts[C_H], consts[C_PELVIS], consts[C_BODY],
              consts[C_NTAIL], reach_margin, sc[S_MAX_SWAY], dt, sc[S_A_SMOOTH],
              sc[S_A_DROP], sc[S_A_TAIL], spine_angle, spine_smooth, drops_now, height, tail,
              pitch, sway)
    # 7. the plans packed for the posing (as pack_plan packs the frame's plan)
    if packed.shape[1]:
        n_tail = min((packed.shape[1] - TAIL) // 2, tail.shape[1])
        for n in range(N):
            packed[n, ROOT] = root_xz[n, 0]
            packed[n, ROOT + 1] = height[n]
            packed[n, ROOT + 2] = root_xz[n, 2]
            packed[n, HEADING] = heading[n]
            packed[n, PITCH] = pitch[n]
            packed[n, SWAY] = sway[n, 0]
            packed[n, SWAY + 1] = sway[n, 1]
            packed[n, BEND_YAW] = bend[n]
            packed[n, BEND_PITCH] = spine_smooth[n]
            for i in range(4):
                for c in range(3):
                    packed[n, FEET + 3 * i + c] = feet[n, i, c]
                packed[n, FOLD + i] = fold[n, i]
                packed[n, TOE + i] = 0.5 * fold[n, i]
            packed[n, LOOK] = 0.5 * bend[n]
            for k in range(n_tail):
                packed[n, TAIL + 2 * k] = tail[n, k, 0]
                packed[n, TAIL + 2 * k + 1] = tail[n, k, 1]


@njit(cache=True, parallel=True)
def plan_rows_parallel(n_blocks, v_cmd_in, turn, head, gait, kind, consts, sc, substeps, table, law,
                       auto, bounds, auto_pos, drops, half_sweep, sweep_min, sweep_cols,
                       foot_offset, speed, yaw_rate, heading, root_xz, bend, theta, r, theta_s,
                       r_s, freq, current, source_name, source, in_transition, elapsed,
                       duration, params, stance, swing_s, theta_lo, theta_td, planted,
                       liftoff, spine_angle, spine_smooth, drops_now, height, tail, feet, fold,
                       pitch, sway, flags, aux, phase, packed):
    """:func:`plan_rows` with the rows split into one block per thread.

    Rows are independent (no reduction over rows; each block's
    :func:`plan_rows` has its own scratch arrays), so the result is the same
    as :func:`plan_rows`' whatever the number of threads. ``n_blocks`` is
    the number of blocks, one a thread (:func:`numba.get_num_threads`,
    passed in rather than read in the kernel, which could not then be cached
    on disk); the other parameters are :func:`plan_rows`'.
    Sliced per block: the commands, ``kind``, ``consts`` along its second
    (row) axis, the per-row constants ``auto``, ``bounds``, ``half_sweep``,
    ``sweep_min``, ``sweep_cols``, ``foot_offset``, every state array and
    the outputs; shared: ``sc``, ``substeps`` and the per-kind tables
    ``table``, ``law``, ``auto_pos`` (indexed by ``kind``) and ``drops``.
    """
    N = theta.shape[0]
    size = (N + n_blocks - 1) // n_blocks
    for b in prange(n_blocks):
        a = b * size
        e = min(N, a + size)
        if a < e:
            plan_rows(v_cmd_in[a:e], turn[a:e], head[a:e], gait[a:e], kind[a:e],
                      consts[:, a:e], sc, substeps, table, law, auto[a:e], bounds[a:e],
                      auto_pos, drops, half_sweep[a:e], sweep_min[a:e], sweep_cols[a:e],
                      foot_offset[a:e], speed[a:e], yaw_rate[a:e], heading[a:e],
                      root_xz[a:e], bend[a:e], theta[a:e], r[a:e], theta_s[a:e], r_s[a:e],
                      freq[a:e], current[a:e], source_name[a:e], source[a:e],
                      in_transition[a:e], elapsed[a:e], duration[a:e], params[a:e],
                      stance[a:e], swing_s[a:e], theta_lo[a:e], theta_td[a:e],
                      planted[a:e], liftoff[a:e], spine_angle[a:e], spine_smooth[a:e],
                      drops_now[a:e], height[a:e], tail[a:e], feet[a:e], fold[a:e],
                      pitch[a:e], sway[a:e], flags[a:e], aux[a:e], phase[a:e], packed[a:e])


#: The per-row state :func:`plan_rows` updates, in its argument order.
STATE_FIELDS = ("speed", "yaw_rate", "heading", "root_xz", "bend", "theta", "r", "theta_s",
                "r_s", "freq", "current", "source_name", "source", "in_transition", "elapsed",
                "duration", "params", "stance", "swing_s", "theta_lo", "theta_td", "planted",
                "liftoff", "spine_angle", "spine_smooth", "drops_now", "height", "tail")


def step_scalars(settings, dt: float) -> np.ndarray:
    """The step's scalars ``sc`` of :func:`plan_rows` for ``settings`` and ``dt``."""
    sc = np.zeros(NS)
    c = settings.cpg
    sc[S_DT] = dt
    sc[S_ACC] = settings.acceleration
    sc[S_REACH] = settings.reach_margin
    sc[S_VAULT] = settings.vault
    sc[S_MAX_BEND] = settings.max_bend
    sc[S_MAX_SWAY] = settings.max_sway
    sc[S_A_TURN] = 1.0 - math.exp(-dt / settings.turn_response)
    sc[S_A_BEND] = 1.0 - math.exp(-dt / 0.2)
    sc[S_A_SMOOTH] = 1.0 - math.exp(-dt / 0.03)
    sc[S_A_DROP] = 1.0 - math.exp(-dt / 0.04)
    sc[S_A_TAIL] = 1.0 - math.exp(-dt / settings.tail_lag)
    sc[S_MU], sc[S_GAIN] = c.mu, c.gain
    sc[S_COUPLING], sc[S_SPINE_COUPLING] = c.coupling, c.spine_coupling
    return sc


def run_plan(k, s, v_cmd, turn, head, gait, sc, substeps, parallel: bool = False,
             phase=None, packed=None):
    """:func:`plan_rows` on the constants ``k`` and the state ``s`` (objects with
    the arrays as attributes); :func:`plan_rows_parallel` (the same result,
    on every thread) if ``parallel``. Returns feet (N, 4, 3), fold (N, 4),
    pitch (N,), sway (N, 2), flags (N, 3) and aux (N, 2); ``phase`` (N, 4)
    and ``packed`` (N, F), if given, receive the stride fractions and the
    packed plans (see :func:`plan_rows`)."""
    n = s.theta.shape[0]
    feet = np.empty((n, 4, 3))
    fold = np.empty((n, 4))
    pitch = np.empty(n)
    sway = np.empty((n, 2))
    flags = np.empty((n, 3), dtype=np.bool_)
    aux = np.empty((n, 2))
    if phase is None:
        phase = np.empty((n, 4))
    if packed is None:
        packed = np.empty((n, 0))
    lead = (get_num_threads(),) if parallel else ()
    kernel = plan_rows_parallel if parallel else plan_rows
    kernel(*lead, v_cmd, turn, head, gait, k.kind, k.consts, sc, substeps, k.table, k.law,
           k.auto, k.bounds, k.auto_pos, k.drops, k.half_sweep, k.sweep_min, k.sweep_cols,
           k.foot_offset, s.speed, s.yaw_rate, s.heading, s.root_xz, s.bend, s.theta, s.r,
           s.theta_s, s.r_s, s.freq, s.current, s.source_name, s.source, s.in_transition,
           s.elapsed, s.duration, s.params, s.stance, s.swing_s, s.theta_lo, s.theta_td,
           s.planted, s.liftoff, s.spine_angle, s.spine_smooth, s.drops_now, s.height,
           s.tail, feet, fold, pitch, sway, flags, aux, phase, packed)
    return feet, fold, pitch, sway, flags, aux
