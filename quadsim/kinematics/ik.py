"""Inverse kinematics for quadruped legs.

A leg is a chain of joints from the top of the leg (scapula or hip) to the
foot contact joint. Below the top joint every bone lies in the leg's
sagittal plane at rest, so a leg moves in a plane that the top joint swings
sideways (abduction about the body's forward axis). In that plane the chain
is solved as

* **pre** bones (above the two-bone pair, e.g. the cat's scapula): at their
  rest angle to the *world* vertical, swung with the leg by a fixed fraction
  of the leg's angle (so a trunk that pitches or flexes does not carry the
  shoulder joint fore and aft);
* the **two-bone pair** (shoulder-elbow-wrist, hip-knee-hock): solved exactly
  by the law of cosines, the middle joint bending forward (knee) or back
  (elbow) as the character file says;
* **post** bones (metatarsus, cannon, pastern, hoof): at their rest angle
  to the *world* vertical, turned with the leg by a fraction of its swing
  angle (the heel rises as the leg sweeps back), plus a fold while the foot
  is in swing; the digit (the post bones below the first: a horse's pasterns)
  turns towards the ground under the stance's load (the fetlock sinks), and
  in swing is drawn folded with the bone above it and flexed at its own
  joint (a hoof tucks up behind the carpus), the foot turning with it: a fold
  the pair does not make up for, so the foot joint is carried with it.

Reachable targets are reached exactly; so is a foot joint's world yaw, the
foot held level, when the posing asks for it (:func:`leg_rows`). An
unreachable target gives the closest pose along the line to it, never NaN,
the pair stretched to :data:`PAIR_REACH` of its length (it keeps a bend of a
few degrees) and the miss reported. Under the posing (the yaw asked for), a
swinging foot (fold above 0) whose target is beyond :data:`SWING_PAIR_REACH`
of its pair is first lifted in the leg's plane (:func:`_lifted`); the miss is
then measured from the lifted target, so the lift by design is not a miss. Nor
is a swinging foot drawn so close that the pair's middle joint (elbow, knee,
stifle) passes its flexion limit: the pair keeps at least that span
(:data:`SPAN_CLEAR`), the foot drawn out along the pair's line, also not a miss.

:func:`leg_rows` is the IK, compiled: the posing
(:mod:`quadsim.locomotion.pose_kernel`) runs it for every frame, and
:func:`solve_leg` is its face for arrays of any leading batch shape.

In-plane angles are measured from the downward direction towards forward
(+Z), in radians: a bone of length ``l`` at angle ``phi`` spans
``(down, forward) = l (cos phi, sin phi)``. A rotation about +X by ``theta``
turns a bone at angle ``phi`` to ``phi - theta``.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numba import njit

from quadsim.kinematics.legs import LegGeometry, leg_geometry, pack_legs

#: The legs' description lives in :mod:`quadsim.kinematics.legs`; the IK's users
#: take it from here too.
__all__ = ["LegGeometry", "leg_geometry", "leg_rows", "pack_legs", "solve_leg"]

#: The two-bone pair is never quite straight nor quite folded: its span
#: stays this far (m) inside ``[|l1 - l2|, l1 + l2]`` (no singular bend).
PAIR_SLACK = 1e-6
#: ... and never longer than this fraction of ``l1 + l2``: an elbow or knee
#: keeps about 7 degrees of bend (a locked straight leg reads as a prop, and
#: snaps when it bends again); a target beyond is missed (``reached``).
PAIR_REACH = 0.998
#: A swinging leg's pair reaches at most this fraction of ``l1 + l2`` (its
#: elbow or knee keeps about 20 degrees of bend): a swing target further away
#: is lifted in the leg's plane rather than reached for with a straight leg
#: (which locked it, then snapped it back at touchdown) ...
SWING_PAIR_REACH = 0.985
#: A swinging foot's pair is not folded past its middle joint's flexion limit
#: (:attr:`~quadsim.kinematics.legs.LegGeometry.pair_min_span`): the foot is drawn
#: out along the pair's line instead, by no more than its target is above this
#: fraction of the pair's span.
SPAN_CLEAR = 0.1
#: ... eased in over this fraction of ``l1 + l2`` (a soft minimum), and over
#: the first and last frames of the swing, until its fold reaches this (the
#: fold is about ``sin^2(pi s)``: the first and last 7 % of the swing; lifted
#: from its first frame, a foot's measured stance came out short by up to 0.06
#: of the stride).
SWING_LIFT_BAND = 0.01
SWING_LIFT_FOLD = 0.05
#: The soft minimum is skipped more than this many bands inside the reach (it
#: would lift the foot by under 0.0004 of a band there).
LIFT_CUTOFF = 8.0
_inner = njit(no_cpython_wrapper=True, no_cfunc_wrapper=True)
#: ... compiled without numba's reference counting: the IK allocates nothing
#: (its work rows are the caller's), and threads posing blocks of rows would
#: otherwise count references to the same legs' arrays, atomically, on every call.
_inner_nrt_free = njit(no_cpython_wrapper=True, no_cfunc_wrapper=True, _nrt=False)


@_inner_nrt_free
def _solve_pair(l1, l2, bend, qd, qf, cd, cf, r_min):
    """The two-bone pair of lengths ``l1``, ``l2`` from Q = (``qd``, ``qf``)
    towards C = (``cd``, ``cf``), the target less the post bones, by the law
    of cosines, as cosines and sines.

    Returns the upper bone's cosine and sine, the lower bone's, the lower
    bone's vector (its angle is ``atan2(y, x)``) and how far the foot falls
    short of the target (m). The law of cosines is taken in cosines and
    sines: those of the direction to C (``gam``) and of the bend (``bend *
    delta``, its sine from its cosine for a bend of +-1) give the upper
    bone's as those of a sum (equal to rounding); the upper bone's angle
    itself is never needed. The span is at least ``r_min`` (a swinging foot's:
    the middle joint inside its flexion limit), by design not a miss.
    """
    vd = cd - qd
    vf = cf - qf
    r_true = math.sqrt(vd * vd + vf * vf)
    r0 = min(max(r_true, abs(l1 - l2) + PAIR_SLACK), PAIR_REACH * (l1 + l2) - PAIR_SLACK)
    r = max(r0, r_min)
    cg, sg = _direction(vd, vf, r_true)  # (cos, sin) of gam = atan2(vf, vd)
    cos_delta = min(max((l1 * l1 + r * r - l2 * l2) / (2.0 * l1 * r), -1.0), 1.0)
    if bend == 1.0 or bend == -1.0:  # (cos, sin) of bend * acos(cos_delta)
        cb = cos_delta
        sb = bend * math.sqrt((1.0 - cos_delta) * (1.0 + cos_delta))
    else:
        turn = bend * math.acos(cos_delta)
        cb = math.cos(turn)
        sb = math.sin(turn)
    c0 = cg * cb - sg * sb  # the upper bone at gam + bend * delta
    s0 = sg * cb + cg * sb
    x = qd + r * cg - (qd + l1 * c0)
    y = qf + r * sg - (qf + l1 * s0)
    c1, s1 = _direction(x, y, math.sqrt(x * x + y * y))
    return c0, s0, c1, s1, x, y, abs(r_true - r0)


@_inner_nrt_free
def _lifted(x, y, span):
    """The down component ``x`` (m) of a swinging foot's target from its pair's top
    (``y`` along the leg), eased so the pair reaches it with a bend: at most
    :data:`SWING_PAIR_REACH` of the pair's ``span``, by a soft minimum over
    :data:`SWING_LIFT_BAND` of it (the foot is lifted in the leg's plane where
    the path would carry it out of reach)."""
    lim = SWING_PAIR_REACH * span
    k = SWING_LIFT_BAND * span
    near = x + LIFT_CUTOFF * k  # well inside the reach (z below -LIFT_CUTOFF): as it is
    if x <= 0.0 or near <= 0.0 or near * near + y * y < lim * lim or y * y >= lim * lim:
        return x
    z = (x - math.sqrt(lim * lim - y * y)) / k
    return x - k * (z + math.log1p(math.exp(-z)) if z > 0.0 else math.log1p(math.exp(z)))


@_inner_nrt_free
def _foot_turn(G, g, p, ca, sa, want):
    """The turn that holds a foot level and at world yaw ``want`` (rad), in
    its leg plane's frame, as its nine entries row by row.

    The leg's plane is ``B = G[g, p] @ R_z(a)`` (``ca``, ``sa`` the cosine and
    sine of the abduction ``a``). Its hinge axis ``h = B e_x`` tilts from the
    horizontal by the plane's roll ``asin(h_y)``; a foot posed in the plane
    rolls and turns with it. The turn ``C = R_y(d) R_w(-roll)`` undoes the
    roll about the horizontal axis ``w`` square to the hinge, then turns the
    plane's heading (``w``'s) to ``want`` about the vertical; returned is
    ``B^T C B``.
    """
    hx = G[g, p, 0, 0] * ca + G[g, p, 0, 1] * sa
    hy = G[g, p, 1, 0] * ca + G[g, p, 1, 1] * sa
    hz = G[g, p, 2, 0] * ca + G[g, p, 2, 1] * sa
    c = math.sqrt(hx * hx + hz * hz)  # the cosine of the roll
    if c > 0.0:
        wx, wz = -hz / c, hx / c  # horizontal and square to the hinge: the plane's heading
    else:
        c, wx, wz = 1.0, G[g, p, 0, 2], G[g, p, 2, 2]
    s = -hy  # the sine of the turn (minus the roll)
    k = 1.0 - c
    # R_w(-roll), w = (wx, 0, wz) (Rodrigues)
    r00, r01, r02 = c + k * wx * wx, -s * wz, k * wx * wz
    r10, r11, r12 = s * wz, c, -s * wx
    r20, r21, r22 = k * wz * wx, s * wx, c + k * wz * wz
    # the turn d = want - atan2(wx, wz) about the vertical, by its cosine and sine
    cw, sw = math.cos(want), math.sin(want)
    cy, sy = cw * wz + sw * wx, sw * wz - cw * wx
    # C = R_y(d) R
    c00, c01, c02 = cy * r00 + sy * r20, cy * r01 + sy * r21, cy * r02 + sy * r22
    c10, c11, c12 = r10, r11, r12
    c20, c21, c22 = -sy * r00 + cy * r20, -sy * r01 + cy * r21, -sy * r02 + cy * r22
    # B's columns
    b00, b10, b20 = hx, hy, hz
    b01 = -G[g, p, 0, 0] * sa + G[g, p, 0, 1] * ca
    b11 = -G[g, p, 1, 0] * sa + G[g, p, 1, 1] * ca
    b21 = -G[g, p, 2, 0] * sa + G[g, p, 2, 1] * ca
    b02, b12, b22 = G[g, p, 0, 2], G[g, p, 1, 2], G[g, p, 2, 2]
    # E = C B
    e00 = c00 * b00 + c01 * b10 + c02 * b20
    e01 = c00 * b01 + c01 * b11 + c02 * b21
    e02 = c00 * b02 + c01 * b12 + c02 * b22
    e10 = c10 * b00 + c11 * b10 + c12 * b20
    e11 = c10 * b01 + c11 * b11 + c12 * b21
    e12 = c10 * b02 + c11 * b12 + c12 * b22
    e20 = c20 * b00 + c21 * b10 + c22 * b20
    e21 = c20 * b01 + c21 * b11 + c22 * b21
    e22 = c20 * b02 + c21 * b12 + c22 * b22
    # B^T E
    return (b00 * e00 + b10 * e10 + b20 * e20, b00 * e01 + b10 * e11 + b20 * e21,
            b00 * e02 + b10 * e12 + b20 * e22,
            b01 * e00 + b11 * e10 + b21 * e20, b01 * e01 + b11 * e11 + b21 * e21,
            b01 * e02 + b11 * e12 + b21 * e22,
            b02 * e00 + b12 * e10 + b22 * e20, b02 * e01 + b12 * e11 + b22 * e21,
            b02 * e02 + b12 * e12 + b22 * e22)


@_inner_nrt_free
def _direction(x, y, h):
    """Cosine and sine of the angle ``atan2(y, x)`` of the vector ``(x, y)`` of length ``h``."""
    if h > 0.0:
        return x / h, y / h
    a = math.atan2(y, x)
    return math.cos(a), math.sin(a)


@_inner_nrt_free
def leg_rows(plan, cols, a, b, legs, G, positions, local, err, work):
    """The legs' IK, compiled: each leg of ``legs`` (:func:`pack_legs`) in
    rows ``a`` to ``b``, from its parent's world frame ``G[t - a, p]`` (3, 3)
    and position ``positions[t, p]`` (m), to the target, swing fold, toe
    pitch and stance load in the columns ``cols = [target, fold, toe, heading, load]``
    (int array) of ``plan[t]`` (leg ``i`` at ``target + 3 i``, ``fold + i``,
    ``toe + i``, ``heading + i``, the world yaw the foot keeps, and ``load + i``, the
    load over the body's weight its digit sinks under; -1: none):
    writes the chains' local rotations ``local[t, j]`` and the misses
    ``err[t, i]`` (m); ``work`` (3, n_max) is its scratch (any values). If
    ``heading >= 0`` each foot keeps the world yaw its column gives and stays
    level whatever the yaw and roll of its leg's plane (the girdles' sway and
    the abduction, :func:`_foot_turn`): it turns about the world vertical
    through its joint, so a planted foot's toe stays put (its toe tip slid
    up to 6 mm sideways in a rotary gallop's stance, and dipped 6 mm into the
    ground in a tight turn, when the yaw was turned about the foot's own
    axis).

    The bones' in-plane angles ``phi`` are carried with their cosines and
    sines, from which the pair (:func:`_solve_pair`) and the local rotations
    follow without more trigonometry. A limit pass that moves no post bone
    would solve the same pair again, so the pair is solved again only after
    a pass that does (the joint limits rarely bind in a stride).
    """
    leg_int, leg_top, leg_bones, leg_scal = legs
    FEET, FOLD, TOE, HEAD, LOAD = cols[0], cols[1], cols[2], cols[3], cols[4]
    phi, cphi, sphi = work[0], work[1], work[2]
    for t in range(a, b):
        g = t - a
        for i in range(leg_int.shape[0]):
            n = leg_int[i, 0]
            k0 = leg_int[i, 1]
            p = leg_int[i, 2]
            limited = leg_int[i, 3]
            bend, pre_gain, post_gain = leg_scal[i, 0], leg_scal[i, 1], leg_scal[i, 2]
            toe_angle, rest_leg, foot_carry = leg_scal[i, 3], leg_scal[i, 4], leg_scal[i, 5]
            l1 = leg_bones[i, 0, k0]
            l2 = leg_bones[i, 0, k0 + 1]
            ox, oy, oz = leg_top[i, 0], leg_top[i, 1], leg_top[i, 2]
            ex = plan[t, FEET + 3 * i] - (positions[t, p, 0] + (
                G[g, p, 0, 0] * ox + G[g, p, 0, 1] * oy + G[g, p, 0, 2] * oz))
            ey = plan[t, FEET + 3 * i + 1] - (positions[t, p, 1] + (
                G[g, p, 1, 0] * ox + G[g, p, 1, 1] * oy + G[g, p, 1, 2] * oz))
            ez = plan[t, FEET + 3 * i + 2] - (positions[t, p, 2] + (
                G[g, p, 2, 0] * ox + G[g, p, 2, 1] * oy + G[g, p, 2, 2] * oz))
            # the target in the parent's frame
            d0 = G[g, p, 0, 0] * ex + G[g, p, 1, 0] * ey + G[g, p, 2, 0] * ez
            d1 = G[g, p, 0, 1] * ex + G[g, p, 1, 1] * ey + G[g, p, 2, 1] * ez
            d2 = G[g, p, 0, 2] * ex + G[g, p, 1, 2] * ey + G[g, p, 2, 2] * ez
            # abduction a = atan2(d0, -d1) about the parent's forward axis
            # brings it into the leg's plane (only its cosine and sine are used)
            rho = math.sqrt(d0 * d0 + d1 * d1)
            if rho > 0.0:
                ca = -d1 / rho
                sa = d0 / rho
            else:
                ab = math.atan2(d0, -d1)
                ca, sa = math.cos(ab), math.sin(ab)
            down_t = -(d1 * ca - d0 * sa)
            fwd_t = d2
            # world down in the parent's frame is G^T (0, -1, 0) = -G[1, :];
            # its angle in the leg plane
            gy = -(G[g, p, 1, 0] * -1.0) * sa + (G[g, p, 1, 1] * -1.0) * ca
            phi_down = math.atan2(G[g, p, 1, 2] * -1.0, -gy)
            # the leg's swing from its rest angle to the world vertical (a
            # trunk that pitches or flexes does not swing the leg's bones)
            swing = math.atan2(fwd_t, down_t) - phi_down - rest_leg
            qd = 0.0
            qf = 0.0
            for k in range(k0):  # pre bones: to the world vertical, swung with the leg
                ang = leg_bones[i, 1, k] + phi_down + pre_gain * swing
                phi[k] = ang
                cphi[k] = math.cos(ang)
                sphi[k] = math.sin(ang)
                qd = qd + leg_bones[i, 0, k] * cphi[k]
                qf = qf + leg_bones[i, 0, k] * sphi[k]
            load = plan[t, LOAD + i] if LOAD >= 0 else 0.0
            for k in range(k0 + 2, n):  # post bones: to the world vertical, turned, folded,
                # the digit sunk under its load
                ang = leg_bones[i, 1, k] + phi_down + post_gain * swing \
                    + leg_bones[i, 2, k] * plan[t, FOLD + i] + leg_bones[i, 7, k] * load
                phi[k] = ang
                cphi[k] = math.cos(ang)
                sphi[k] = math.sin(ang)
            # post joints inside their limits, then the pair again (twice); a
            # pass that moves no bone would solve the same pair again: done
            for rep in range(3 if limited else 1):
                if rep:
                    moved = False
                    for k in range(k0 + 2, n):
                        above = leg_bones[i, 1, k - 1] - phi[k - 1]
                        rel = (leg_bones[i, 1, k] - phi[k]) - above
                        lo = leg_bones[i, 3, k]
                        hi = leg_bones[i, 4, k]
                        if not (rel >= lo and rel <= hi):
                            rel = min(max(rel, lo), hi)
                            ang = leg_bones[i, 1, k] - above - rel
                            phi[k] = ang
                            cphi[k] = math.cos(ang)
                            sphi[k] = math.sin(ang)
                            moved = True
                    if not moved:
                        break
                cd = 0.0
                cf = 0.0
                for k in range(k0 + 2, n):
                    cd += leg_bones[i, 0, k] * cphi[k]
                    cf += leg_bones[i, 0, k] * sphi[k]
                tx = down_t - cd
                ty = fwd_t - cf
                r_min = 0.0
                if HEAD >= 0 and plan[t, FOLD + i] > 0.0:  # swinging: lifted, not locked,
                    wl = min(plan[t, FOLD + i] / SWING_LIFT_FOLD, 1.0)  # nor over-flexed
                    tx = tx + wl * (_lifted(tx - qd, ty - qf, l1 + l2) + qd - tx)
                    r_min = leg_scal[i, 7]
                    # (pushed out no further than the target is above SPAN_CLEAR of the
                    # pair's span: a foot low in its swing is not driven into the ground)
                    r_min = min(r_min, math.sqrt((tx - qd) * (tx - qd) + (ty - qf) * (ty - qf))
                                + max(plan[t, FEET + 3 * i + 1] - SPAN_CLEAR * (l1 + l2), 0.0))
                c0, s0, c1, s1, x, y, reached = _solve_pair(l1, l2, bend, qd, qf, tx, ty,
                                                            r_min)
                cphi[k0], sphi[k0], cphi[k0 + 1], sphi[k0 + 1] = c0, s0, c1, s1
                if limited:
                    phi[k0 + 1] = math.atan2(y, x)
            err[t, i] = reached
            # the digit drawn folded beyond what the pair made up for (carried), with
            # the fold, as far as the foot's target is up (``tuck_height``): a tucked
            # hoof hangs its toe below its joint (tucked by the fold alone, the toe
            # dipped 9 mm into the ground in the walk; by its fourth power, lower near
            # the ground, the fetlock turned at up to 2,467 deg/s into the canter)
            f = max(plan[t, FOLD + i], 0.0)
            if f > 0.0 and leg_scal[i, 6] > 0.0:
                f *= min(max(plan[t, FEET + 3 * i + 1] / leg_scal[i, 6], 0.0), 1.0)
            if f > 0.0:
                for k in range(k0 + 3, n):
                    if leg_bones[i, 8, k] != 0.0:
                        phi[k] += leg_bones[i, 8, k] * f
                        cphi[k] = math.cos(phi[k])
                        sphi[k] = math.sin(phi[k])
            # local rotations about +X by rel_k = cum_k - cum_(k-1), where
            # cum_k = A0_k - phi_k (the foot's: toe_angle - (phi_down + pi / 2
            # + toe)), as the cosine and sine of angle differences
            pc = 1.0
            ps = 0.0
            for k in range(n + 1):
                if k < n:  # cos and sin of A0_k - phi_k
                    cc = leg_bones[i, 5, k] * cphi[k] + leg_bones[i, 6, k] * sphi[k]
                    cs = leg_bones[i, 6, k] * cphi[k] - leg_bones[i, 5, k] * sphi[k]
                else:
                    cum = toe_angle - (phi_down + math.pi / 2 + plan[t, TOE + i] + foot_carry * f)
                    cc = math.cos(cum)
                    cs = math.sin(cum)
                cb = cc * pc + cs * ps
                sb = cs * pc - cc * ps
                p0c, p0s = pc, ps
                pc = cc
                ps = cs
                j = leg_int[i, 4 + k]
                if k == 0:  # R_z(a) @ R_x(rel)
                    local[t, j, 0, 0] = ca
                    local[t, j, 0, 1] = -sa * cb
                    local[t, j, 0, 2] = sa * sb
                    local[t, j, 1, 0] = sa
                    local[t, j, 1, 1] = ca * cb
                    local[t, j, 1, 2] = -ca * sb
                elif k == n and HEAD >= 0:
                    # the foot held level and at its world yaw: R_x(-cum_(n-1)) Q R_x(cum_n)
                    q00, q01, q02, q10, q11, q12, q20, q21, q22 = _foot_turn(
                        G, g, p, ca, sa, plan[t, HEAD + i])
                    # M = Q R_x(cum_n)
                    m01, m02 = q01 * cc + q02 * cs, -q01 * cs + q02 * cc
                    m11, m12 = q11 * cc + q12 * cs, -q11 * cs + q12 * cc
                    m21, m22 = q21 * cc + q22 * cs, -q21 * cs + q22 * cc
                    # R_x(-cum_(n-1)) M
                    local[t, j, 0, 0] = q00
                    local[t, j, 0, 1] = m01
                    local[t, j, 0, 2] = m02
                    local[t, j, 1, 0] = p0c * q10 + p0s * q20
                    local[t, j, 1, 1] = p0c * m11 + p0s * m21
                    local[t, j, 1, 2] = p0c * m12 + p0s * m22
                    local[t, j, 2, 0] = -p0s * q10 + p0c * q20
                    local[t, j, 2, 1] = -p0s * m11 + p0c * m21
                    local[t, j, 2, 2] = -p0s * m12 + p0c * m22
                    continue
                else:
                    local[t, j, 0, 0] = 1.0
                    local[t, j, 0, 1] = 0.0
                    local[t, j, 0, 2] = 0.0
                    local[t, j, 1, 0] = 0.0
                    local[t, j, 1, 1] = cb
                    local[t, j, 1, 2] = -sb
                local[t, j, 2, 0] = 0.0
                local[t, j, 2, 1] = sb
                local[t, j, 2, 2] = cb


def solve_leg(geom: LegGeometry, parent_rot: np.ndarray, parent_pos: np.ndarray,
              target: np.ndarray, fold: np.ndarray | float = 0.0,
              toe_pitch: np.ndarray | float = 0.0,
              load: np.ndarray | float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations that put a leg's foot joint on a target
    (:func:`leg_rows`, the posing's own kernel, for arrays of any batch shape).

    Parameters
    ----------
    geom : LegGeometry
    parent_rot : array-like, shape (..., 3, 3)
        World rotation of the top joint's parent.
    parent_pos : array-like, shape (..., 3)
        World position of the top joint's parent (m).
    target : array-like, shape (..., 3)
        World position wanted for the foot joint (m).
    fold : array-like, shape (...)
        Swing fold of the post bones, 0 (planted) to 1 (fully folded).
    toe_pitch : array-like, shape (...)
        Rotation of the toes/hoof from level (rad), positive tips them down.
    load : array-like, shape (...)
        Stance load over the body's weight: the digit sinks by ``geom.sink`` times it.

    Returns
    -------
    local : ndarray, shape (..., n + 1, 3, 3)
        Local rotation of each chain joint, top to foot.
    reached : ndarray, shape (...)
        Distance from the target to the foot actually reached (m); 0 for a
        reachable target.
    """
    Rp = np.asarray(parent_rot, dtype=float)
    Pp = np.asarray(parent_pos, dtype=float)
    tgt = np.asarray(target, dtype=float)
    fold = np.asarray(fold, dtype=float)
    toe = np.asarray(toe_pitch, dtype=float)
    load = np.asarray(load, dtype=float)
    batch = np.broadcast_shapes(Rp.shape[:-2], Pp.shape[:-1], tgt.shape[:-1], fold.shape,
                                toe.shape, load.shape)
    M = math.prod(batch)
    n = geom.n_bones
    # the chain as joints 0..n, its parent n + 1: the kernel's arrays stay small
    legs = pack_legs([replace(geom, chain=np.arange(n + 1), parent=n + 1)])
    J = n + 2
    G = np.zeros((M, J, 3, 3))
    G[:, n + 1] = np.broadcast_to(Rp, batch + (3, 3)).reshape(M, 3, 3)
    P = np.zeros((M, J, 3))
    P[:, n + 1] = np.broadcast_to(Pp, batch + (3,)).reshape(M, 3)
    plan = np.zeros((M, 6))
    plan[:, 0:3] = np.broadcast_to(tgt, batch + (3,)).reshape(M, 3)
    plan[:, 3] = np.broadcast_to(fold, batch).reshape(M)
    plan[:, 4] = np.broadcast_to(toe, batch).reshape(M)
    plan[:, 5] = np.broadcast_to(load, batch).reshape(M)
    local = np.empty((M, J, 3, 3))
    err = np.empty((M, 1))
    _solve_rows(plan, legs, G, P, local, err)
    return local[:, :n + 1].reshape(batch + (n + 1, 3, 3)), err[:, 0].reshape(batch)


@njit(cache=True)
def _solve_rows(plan, legs, G, P, local, err):
    work = np.empty((3, legs[2].shape[2]))
    leg_rows(plan, np.array([0, 3, 4, -1, 5]), np.int64(0), plan.shape[0], legs, G, P, local, err,
             work)
