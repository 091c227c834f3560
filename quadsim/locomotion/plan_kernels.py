"""Compiled per-character stages of the procedural controller's plan.

:func:`feet_rows` (stage 5: lift-off and touchdown, swing progress,
touchdown targets on the turning arc, Catmull-Rom swing paths) and
:func:`body_rows` (stage 6: the spine's concave/convex machine and slow
flexion, vaulting drops, height, pitch, girdle sway, tail) as numba kernels
looping over rows of characters. :func:`feet_rows` serves both a lone
:class:`~quadsim.locomotion.controller.ProceduralController` (one row) and
:class:`~quadsim.locomotion.batch.BatchController` (N rows), so the two agree
by construction; the lone controller writes stage 6 in plain floats, the
batch uses :func:`body_rows` (tests hold the two to 1e-9). Their numpy
counterparts, the tests' reference, are
:func:`quadsim.locomotion.turning.arc_advance` and
:func:`quadsim.locomotion.footpath.swing_position`.

Units are SI (m, s, rad); legs in the order LF, RF, LH, RH.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from quadsim.locomotion.cpg import TWO_PI
from quadsim.locomotion.footpath import SWING_KNOTS

#: Shortest swing, as a fraction of the stride, worth lifting a foot for.
MIN_SWING = 0.12

_KNOTS = np.ascontiguousarray(SWING_KNOTS, dtype=float)


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
                u = (th / TWO_PI) % 1.0
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
        # vaulting: each girdle drops as far as its planted feet need
        for i in range(4):
            g = 1 if i < 2 else 0
            kh = key_heading[n, g]
            c, sn = math.cos(kh), math.sin(kh)
            ox, oy, oz = foot_offset[n, i, 0], foot_offset[n, i, 1], foot_offset[n, i, 2]
            mx = c * ox + sn * oz + keys[n, g, 0]
            my = oy + keys[n, g, 1]
            mz = -sn * ox + c * oz + keys[n, g, 2]
            along = (feet[n, i, 0] - mx) * sn + (feet[n, i, 1] - my) * 0.0 \
                + (feet[n, i, 2] - mz) * c
            need[i] = 0.0
            if stance[n, i]:  # np.interp(x, sweep_cols[n, i], drops)
                x = abs(along) / reach_margin
                xp = sweep_cols[n, i]
                j = -1
                for k in range(D):
                    if xp[k] <= x:
                        j += 1
                if j < 0:
                    need[i] = drops[0]
                elif j >= D - 1:
                    need[i] = drops[D - 1]
                else:
                    need[i] = (drops[j + 1] - drops[j]) / (xp[j + 1] - xp[j]) * (x - xp[j]) \
                        + drops[j]
            # the foot in its girdle's frame, for the sway
            cm, sm = math.cos(-kh), math.sin(-kh)
            fx, fz = feet[n, i, 0] - keys[n, g, 0], feet[n, i, 2] - keys[n, g, 2]
            lx[i] = cm * fx + sm * fz
            lz[i] = -sm * fx + cm * fz
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
