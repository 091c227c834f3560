"""The posing of plans, compiled: spine, neck, tail, leg IK and forward kinematics.

:func:`pose_rows` turns a block of packed plans (one row per frame or per
character, all of one character) into local joint rotations, world joint
positions and IK errors, in one compiled loop over the rows (numba). It is
the only implementation of the posing: :meth:`Poser.pose
<quadsim.locomotion.posing.Poser.pose>` packs the plans of a clip or of many
characters, the interactive step packs one frame. The array forms it mirrors
-- :func:`~quadsim.kinematics.ik.solve_leg` and
:func:`~quadsim.skeleton.fk.forward_kinematics` -- stay the general,
vectorised API and the tests' reference.

Packed plan row (:func:`plan_columns`), angles in rad and positions in m:
``root`` (3), ``heading``, ``pitch``, ``sway`` (2), ``bend_yaw``,
``bend_pitch``, ``feet`` (4 x 3, row-major), ``fold`` (4), ``toe`` (4),
``look``, then ``tail`` (n_tail x (pitch, yaw)).

Leg constants (:func:`pack_legs`), per leg LF, RF, LH, RH: ``leg_int`` (4, 4 + n_max + 1)
holds the number of bones n, the pair's upper bone, the top joint's parent,
whether the post joints are limited (0/1) and the chain's joint indices;
``leg_top`` (4, 3) the top joint's offset (m); ``leg_bones`` (4, 5, n_max)
the bone lengths (m), rest angles, full-fold angles, lower and upper flexion
limits (rad); ``leg_scal`` (4, 5) the bend sign, pre and post gains, toe
angle and rest leg angle (rad). Conventions as in :mod:`quadsim.kinematics.ik`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

#: column of each packed plan field (the tail follows from ``TAIL``)
ROOT, HEADING, PITCH, SWAY, BEND_YAW, BEND_PITCH, FEET, FOLD, TOE, LOOK, TAIL = (
    0, 3, 4, 5, 7, 8, 9, 21, 25, 29, 30)


def plan_columns(n_tail: int) -> int:
    """Width of a packed plan row for a character with ``n_tail`` tail joints."""
    return TAIL + 2 * n_tail


def pack_plan(plan: dict, n_tail: int) -> np.ndarray:
    """Plans with a leading row axis T as one (T, F) float array.

    Parameters
    ----------
    plan : dict
        Arrays of the shapes of :data:`~quadsim.locomotion.posing.PLAN_FIELDS`
        with a leading axis T; ``tail`` may have more joints than ``n_tail``
        (zero padding of a batch), only the first ``n_tail`` are read.
    n_tail : int

    Returns
    -------
    ndarray, shape (T, plan_columns(n_tail))
    """
    root = np.asarray(plan["root"], dtype=float)
    T = root.shape[0]
    out = np.empty((T, plan_columns(n_tail)))
    out[:, ROOT:ROOT + 3] = root
    out[:, HEADING] = plan["heading"]
    out[:, PITCH] = plan["pitch"]
    out[:, SWAY:SWAY + 2] = plan["sway"]
    out[:, BEND_YAW] = plan["bend_yaw"]
    out[:, BEND_PITCH] = plan["bend_pitch"]
    out[:, FEET:FEET + 12] = np.reshape(plan["feet"], (T, 12))
    out[:, FOLD:FOLD + 4] = plan["fold"]
    out[:, TOE:TOE + 4] = plan["toe"]
    out[:, LOOK] = plan["look"]
    if n_tail:
        out[:, TAIL:] = np.reshape(np.asarray(plan["tail"])[:, :n_tail], (T, 2 * n_tail))
    return out


def pack_legs(legs) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The four legs' :class:`~quadsim.kinematics.ik.LegGeometry` as the
    kernel's ``leg_int``, ``leg_top``, ``leg_bones`` and ``leg_scal`` arrays
    (see the module notes)."""
    n_max = max(g.n_bones for g in legs)
    leg_int = np.zeros((len(legs), 4 + n_max + 1), dtype=np.int64)
    leg_top = np.zeros((len(legs), 3))
    leg_bones = np.zeros((len(legs), 5, n_max))
    leg_scal = np.zeros((len(legs), 5))
    for i, g in enumerate(legs):
        n = g.n_bones
        leg_int[i, :4] = n, g.pair, g.parent, int(g.limited)
        leg_int[i, 4:4 + n + 1] = g.chain
        leg_top[i] = g.top_offset
        for r, arr in enumerate((g.lengths, g.rest_angles, g.fold, g.lower, g.upper)):
            leg_bones[i, r, :n] = arr
        leg_scal[i] = g.bend, g.pre_gain, g.post_gain, g.toe_angle, g.rest_leg_angle
    return leg_int, leg_top, leg_bones, leg_scal


@njit(cache=True)
def _yaw_pitch(M, yaw, pitch):
    """``M[:] = R_y(yaw) @ R_x(pitch)`` (as ``matrices_yaw_pitch``)."""
    ca, sa, cb, sb = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    M[0, 0] = ca
    M[0, 1] = sa * sb
    M[0, 2] = sa * cb
    M[1, 0] = 0.0
    M[1, 1] = cb
    M[1, 2] = -sb
    M[2, 0] = -sa
    M[2, 1] = ca * sb
    M[2, 2] = ca * cb


@njit(cache=True)
def _fk_joint(j, p, L, offsets, G, P):
    """World frame of joint ``j`` from its parent ``p``'s (in place)."""
    for i in range(3):
        for c in range(3):
            G[j, i, c] = G[p, i, 0] * L[j, 0, c] + G[p, i, 1] * L[j, 1, c] \
                + G[p, i, 2] * L[j, 2, c]
        P[j, i] = P[p, i] + (G[p, i, 0] * offsets[j, 0] + G[p, i, 1] * offsets[j, 1]
                             + G[p, i, 2] * offsets[j, 2])


@njit(cache=True)
def _solve_pair(phi, n, k0, L, bend, qd, qf, down_t, fwd_t):
    """Solve the two-bone pair in place in ``phi`` (see ``ik._solve_pair``);
    returns how far the foot falls short of the target (m)."""
    cd = 0.0
    cf = 0.0
    for k in range(k0 + 2, n):
        cd += L[k] * math.cos(phi[k])
        cf += L[k] * math.sin(phi[k])
    cd = down_t - cd
    cf = fwd_t - cf
    l1 = L[k0]
    l2 = L[k0 + 1]
    vd = cd - qd
    vf = cf - qf
    r_true = math.hypot(vd, vf)
    r = min(max(r_true, abs(l1 - l2) + 1e-6), l1 + l2 - 1e-6)
    gam = math.atan2(vf, vd)
    cos_delta = min(max((l1 * l1 + r * r - l2 * l2) / (2.0 * l1 * r), -1.0), 1.0)
    phi[k0] = gam + bend * math.acos(cos_delta)
    bd = qd + l1 * math.cos(phi[k0])
    bf = qf + l1 * math.sin(phi[k0])
    phi[k0 + 1] = math.atan2(qf + r * math.sin(gam) - bf, qd + r * math.cos(gam) - bd)
    return abs(r_true - r)


@njit(cache=True)
def _solve_leg(i, Gp, Pp, tx, ty, tz, fold, toe, leg_int, leg_top, leg_bones, leg_scal,
               phi, Lout):
    """Leg ``i``'s IK (``ik.solve_leg`` for one leg and one frame): writes the
    chain's local rotations into ``Lout`` (J, 3, 3), returns the miss (m)."""
    n = leg_int[i, 0]
    k0 = leg_int[i, 1]
    limited = leg_int[i, 3]
    lengths = leg_bones[i, 0]
    A0 = leg_bones[i, 1]
    folds = leg_bones[i, 2]
    lower = leg_bones[i, 3]
    upper = leg_bones[i, 4]
    bend, pre_gain, post_gain = leg_scal[i, 0], leg_scal[i, 1], leg_scal[i, 2]
    toe_angle, rest_leg = leg_scal[i, 3], leg_scal[i, 4]
    ox, oy, oz = leg_top[i, 0], leg_top[i, 1], leg_top[i, 2]
    ex = tx - (Pp[0] + (Gp[0, 0] * ox + Gp[0, 1] * oy + Gp[0, 2] * oz))
    ey = ty - (Pp[1] + (Gp[1, 0] * ox + Gp[1, 1] * oy + Gp[1, 2] * oz))
    ez = tz - (Pp[2] + (Gp[2, 0] * ox + Gp[2, 1] * oy + Gp[2, 2] * oz))
    # the target in the parent's frame
    d0 = Gp[0, 0] * ex + Gp[1, 0] * ey + Gp[2, 0] * ez
    d1 = Gp[0, 1] * ex + Gp[1, 1] * ey + Gp[2, 1] * ez
    d2 = Gp[0, 2] * ex + Gp[1, 2] * ey + Gp[2, 2] * ez
    # abduction about the parent's forward axis brings it into the leg's plane
    a = math.atan2(d0, -d1)
    ca, sa = math.cos(a), math.sin(a)
    down_t = -(d1 * ca - d0 * sa)
    fwd_t = d2
    # world down in the leg plane
    gy = -(Gp[0, 1] * -1.0) * sa + (Gp[1, 1] * -1.0) * ca
    phi_down = math.atan2(Gp[2, 1] * -1.0, -gy)
    swing = math.atan2(fwd_t, down_t) - rest_leg
    qd = 0.0
    qf = 0.0
    for k in range(k0):  # pre bones swing with the leg
        phi[k] = A0[k] + pre_gain * swing
        qd = qd + lengths[k] * math.cos(phi[k])
        qf = qf + lengths[k] * math.sin(phi[k])
    for k in range(k0 + 2, n):  # post bones: to the world vertical, turned, folded
        phi[k] = A0[k] + phi_down + post_gain * swing + folds[k] * fold
    reached = _solve_pair(phi, n, k0, lengths, bend, qd, qf, down_t, fwd_t)
    # post joints inside their limits, then the pair again (twice)
    for _ in range(2 if limited else 0):
        for k in range(k0 + 2, n):
            above = A0[k - 1] - phi[k - 1]
            rel = min(max((A0[k] - phi[k]) - above, lower[k]), upper[k])
            phi[k] = A0[k] - above - rel
        reached = _solve_pair(phi, n, k0, lengths, bend, qd, qf, down_t, fwd_t)
    prev = 0.0
    for k in range(n + 1):
        if k < n:
            cum = A0[k] - phi[k]
        else:
            cum = toe_angle - (phi_down + math.pi / 2 + toe)
        rel = cum - prev if k else cum
        prev = cum
        cb, sb = math.cos(rel), math.sin(rel)
        M = Lout[leg_int[i, 4 + k]]
        if k == 0:  # R_z(a) @ R_x(rel)
            M[0, 0] = ca
            M[0, 1] = -sa * cb
            M[0, 2] = sa * sb
            M[1, 0] = sa
            M[1, 1] = ca * cb
            M[1, 2] = -ca * sb
        else:
            M[0, 0] = 1.0
            M[0, 1] = 0.0
            M[0, 2] = 0.0
            M[1, 0] = 0.0
            M[1, 1] = cb
            M[1, 2] = -sb
        M[2, 0] = 0.0
        M[2, 1] = sb
        M[2, 2] = cb
    return reached


@njit(cache=True)
def pose_rows(plan, parents, offsets, spine, tail, neck, trunk, thorax,
              leg_int, leg_top, leg_bones, leg_scal, local, positions, err):
    """Pose T packed plans of one character (compiled).

    Parameters
    ----------
    plan : ndarray, shape (T, F)
        Packed plans (:func:`pack_plan`).
    parents : ndarray of int, shape (J,)
        Skeleton parents, ``parents[j] < j``.
    offsets : ndarray, shape (J, 3)
        Rest offsets (m).
    spine, tail, neck : ndarray of int
        The spine joints below the pelvis (K,), tail joints and neck joints.
    trunk : ndarray of int, shape (M,)
        Increasing joints, each with its parent, holding the legs' parents
        and the thorax ``thorax``: the first forward kinematics pass.
    thorax : int
    leg_int, leg_top, leg_bones, leg_scal : ndarray
        The legs (:func:`pack_legs`).
    local : ndarray, shape (T, J, 3, 3)
        Output: local rotations.
    positions : ndarray, shape (T, J, 3)
        Output: world joint positions (m).
    err : ndarray, shape (T, 4)
        Output: distance from each foot target to the foot reached (m).
    """
    T = plan.shape[0]
    J = parents.shape[0]
    K = spine.shape[0]
    G = np.empty((J, 3, 3))
    phi = np.empty(leg_bones.shape[2])
    for t in range(T):
        row = plan[t]
        L = local[t]
        P = positions[t]
        for j in range(J):
            for r in range(3):
                for c in range(3):
                    L[j, r, c] = 1.0 if r == c else 0.0
        flex = row[BEND_PITCH]
        sway0 = row[SWAY]
        sway1 = row[SWAY + 1]
        # pelvis: heading plus hind sway, tilted back by half the flexion
        _yaw_pitch(L[0], row[HEADING] + sway0, row[PITCH] - 0.5 * flex)
        for k in range(K):
            yaw = row[BEND_YAW] / K * 1.0
            if k == 0:
                yaw = yaw - sway0
            if k == K - 1:
                yaw = yaw + sway1
            _yaw_pitch(L[spine[k]], yaw, flex / K * 1.0)
        for k in range(tail.shape[0]):
            _yaw_pitch(L[tail[k]], row[TAIL + 2 * k + 1], row[TAIL + 2 * k])
        # the trunk's world frames
        for r in range(3):
            for c in range(3):
                G[0, r, c] = L[0, r, c]
            P[0, r] = row[ROOT + r]
        for m in range(1, trunk.shape[0]):
            _fk_joint(trunk[m], parents[trunk[m]], L, offsets, G, P)
        # neck and head: keep the head level, look into the turn
        nn = neck.shape[0]
        if nn:
            pitch = math.asin(min(max(-G[thorax, 1, 2], -1.0), 1.0))
            for k in range(nn):
                _yaw_pitch(L[neck[k]], row[LOOK] / nn * 1.0, -pitch / nn * 1.0)
        for i in range(leg_int.shape[0]):
            p = leg_int[i, 2]
            err[t, i] = _solve_leg(i, G[p], P[p], row[FEET + 3 * i], row[FEET + 3 * i + 1],
                                   row[FEET + 3 * i + 2], row[FOLD + i], row[TOE + i],
                                   leg_int, leg_top, leg_bones, leg_scal, phi, L)
        for j in range(1, J):
            _fk_joint(j, parents[j], L, offsets, G, P)


#: Fewest rows for which :func:`pose_rows_parallel` splits the work over threads.
PARALLEL_ROWS = 256


@njit(cache=True, parallel=True)
def pose_rows_parallel(n_blocks, plan, parents, offsets, spine, tail, neck, trunk, thorax,
                       leg_int, leg_top, leg_bones, leg_scal, local, positions, err):
    """:func:`pose_rows` with the rows split into ``n_blocks`` blocks, run on threads.

    Rows are independent and each block runs :func:`pose_rows` with its own
    scratch arrays, so the result is the same as :func:`pose_rows`' whatever
    the number of blocks or threads. ``n_blocks`` is passed in (the caller
    gives ``numba.get_num_threads()``, one block per core by default) rather
    than asked for inside, which would keep numba from caching the kernel.
    The other parameters are :func:`pose_rows`'.
    """
    T = plan.shape[0]
    n = max(n_blocks, 1)
    size = (T + n - 1) // n
    for b in prange(n):
        a = b * size
        e = min(T, a + size)
        if a < e:
            pose_rows(plan[a:e], parents, offsets, spine, tail, neck, trunk, thorax,
                      leg_int, leg_top, leg_bones, leg_scal, local[a:e], positions[a:e],
                      err[a:e])
