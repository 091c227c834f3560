"""The posing of plans, compiled: spine, neck, tail, leg IK and forward kinematics.

:func:`pose_rows` turns packed plans (one row per frame or per character,
all of one character) into local joint rotations, world joint positions and
IK errors, compiled (numba): blocks of :data:`CHUNK` rows go through the
trunk (:func:`_trunk_rows`: spine, tail, neck and the trunk's forward
kinematics), the legs' IK (:func:`quadsim.kinematics.ik.leg_rows`) and the other joints' forward
kinematics (:func:`_rest_rows`). It is the only implementation of the
posing: :meth:`Poser.pose <quadsim.locomotion.posing.Poser.pose>` packs the
plans of a clip or of many characters, the batch's plan kernel
(:func:`~quadsim.locomotion.plan_kernels.plan_rows`) packs its rows as it
plans them, the interactive step packs one frame. The legs' IK is
:func:`quadsim.kinematics.ik.leg_rows`, the kernel
:func:`~quadsim.kinematics.ik.solve_leg` wraps.

Packed plan row (:func:`plan_columns`), angles in rad and positions in m:
``root`` (3), ``heading``, ``pitch``, ``sway`` (2), ``bend_yaw``,
``bend_pitch``, ``feet`` (4 x 3, row-major), ``fold`` (4), ``toe`` (4),
``look``, ``foot_yaw`` (4), ``load`` (4), then ``tail`` (n_tail x (pitch, yaw)).

Leg constants (:func:`pack_legs`), per leg LF, RF, LH, RH: ``leg_int`` (4, 4 + n_max + 1)
holds the number of bones n, the pair's upper bone, the top joint's parent,
whether the post joints are limited (0/1) and the chain's joint indices;
``leg_top`` (4, 3) the top joint's offset (m); ``leg_bones`` (4, 9, n_max)
the bone lengths (m), rest angles, full-fold angles, lower and upper flexion
limits (rad), the rest angles' cosines and sines, the full-load sink angles and
the digit's carried fold angles (rad); ``leg_scal`` (4, 8) the bend sign, pre
and post gains, toe angle, rest leg angle, the foot's carried fold angle (rad),
the tuck height (m) and the pair's shortest span in swing (m).
Conventions as in :mod:`quadsim.kinematics.ik`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from quadsim.kinematics.ik import leg_rows, pack_legs
from quadsim.locomotion.rowmath import plan_inner

__all__ = ["CHUNK", "PARALLEL_ROWS", "PoseRig", "PoseScratch", "layout", "nod_of", "pack_legs",
           "pack_plan", "plan_columns", "pose_rig", "pose_rows", "pose_scratch"]

#: column of each packed plan field (the tail follows from ``TAIL``)
ROOT, HEADING, PITCH, SWAY, BEND_YAW, BEND_PITCH, FEET, FOLD, TOE, LOOK, FOOT_YAW, LOAD, TAIL = (
    0, 3, 4, 5, 7, 8, 9, 21, 25, 29, 30, 34, 38)


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
    if "foot_yaw" in plan:
        out[:, FOOT_YAW:FOOT_YAW + 4] = plan["foot_yaw"]
    else:  # the body's heading, the fore feet's with the spine's yaw
        out[:, FOOT_YAW:FOOT_YAW + 4] = out[:, HEADING, None]
        out[:, FOOT_YAW:FOOT_YAW + 2] += out[:, BEND_YAW, None]
    out[:, LOAD:LOAD + 4] = plan["load"] if "load" in plan else 0.0
    if n_tail:
        out[:, TAIL:] = np.reshape(np.asarray(plan["tail"])[:, :n_tail], (T, 2 * n_tail))
    return out


@njit(cache=True, inline="always")
def _yaw_pitch(local, t, j, ca, sa, cb, sb):
    """``local[t, j] = R_y(yaw) @ R_x(pitch)`` (as ``matrices_yaw_pitch``) from
    the cosines and sines of yaw (``ca``, ``sa``) and pitch (``cb``, ``sb``)."""
    local[t, j, 0, 0] = ca
    local[t, j, 0, 1] = sa * sb
    local[t, j, 0, 2] = sa * cb
    local[t, j, 1, 0] = 0.0
    local[t, j, 1, 1] = cb
    local[t, j, 1, 2] = -sb
    local[t, j, 2, 0] = -sa
    local[t, j, 2, 1] = ca * sb
    local[t, j, 2, 2] = ca * cb


#: How :func:`_fk_joint` multiplies by a joint's local rotation (:func:`layout`).
FK_FULL, FK_ABOUT_X, FK_IDENTITY = 0, 1, 2


@njit(cache=True, inline="always")
def _fk_joint(t, g, j, p, how, frame, local, offsets, G, positions):
    """World position of joint ``j`` of row ``t`` from its parent ``p``'s
    world frame ``G[g, p]``, and its own world frame ``G[g, j]`` if
    ``frame`` (in place). ``how`` is :data:`FK_FULL`, or :data:`FK_ABOUT_X`
    for a local rotation about +X, or :data:`FK_IDENTITY` for the identity:
    then only the products with the rotation's non-zero entries are taken,
    which the full product's zero terms do not change (bar the sign of a
    zero). The parent's frame is read once, into scalars."""
    a00, a01, a02 = G[g, p, 0, 0], G[g, p, 0, 1], G[g, p, 0, 2]
    a10, a11, a12 = G[g, p, 1, 0], G[g, p, 1, 1], G[g, p, 1, 2]
    a20, a21, a22 = G[g, p, 2, 0], G[g, p, 2, 1], G[g, p, 2, 2]
    o0, o1, o2 = offsets[j, 0], offsets[j, 1], offsets[j, 2]
    positions[t, j, 0] = positions[t, p, 0] + (a00 * o0 + a01 * o1 + a02 * o2)
    positions[t, j, 1] = positions[t, p, 1] + (a10 * o0 + a11 * o1 + a12 * o2)
    positions[t, j, 2] = positions[t, p, 2] + (a20 * o0 + a21 * o1 + a22 * o2)
    if not frame:
        return
    if how == FK_IDENTITY:
        G[g, j, 0, 0], G[g, j, 0, 1], G[g, j, 0, 2] = a00, a01, a02
        G[g, j, 1, 0], G[g, j, 1, 1], G[g, j, 1, 2] = a10, a11, a12
        G[g, j, 2, 0], G[g, j, 2, 1], G[g, j, 2, 2] = a20, a21, a22
        return
    l11, l12 = local[t, j, 1, 1], local[t, j, 1, 2]
    l21, l22 = local[t, j, 2, 1], local[t, j, 2, 2]
    if how == FK_ABOUT_X:
        G[g, j, 0, 0] = a00
        G[g, j, 0, 1] = a01 * l11 + a02 * l21
        G[g, j, 0, 2] = a01 * l12 + a02 * l22
        G[g, j, 1, 0] = a10
        G[g, j, 1, 1] = a11 * l11 + a12 * l21
        G[g, j, 1, 2] = a11 * l12 + a12 * l22
        G[g, j, 2, 0] = a20
        G[g, j, 2, 1] = a21 * l11 + a22 * l21
        G[g, j, 2, 2] = a21 * l12 + a22 * l22
        return
    l00, l01, l02 = local[t, j, 0, 0], local[t, j, 0, 1], local[t, j, 0, 2]
    l10, l20 = local[t, j, 1, 0], local[t, j, 2, 0]
    G[g, j, 0, 0] = a00 * l00 + a01 * l10 + a02 * l20
    G[g, j, 0, 1] = a00 * l01 + a01 * l11 + a02 * l21
    G[g, j, 0, 2] = a00 * l02 + a01 * l12 + a02 * l22
    G[g, j, 1, 0] = a10 * l00 + a11 * l10 + a12 * l20
    G[g, j, 1, 1] = a10 * l01 + a11 * l11 + a12 * l21
    G[g, j, 1, 2] = a10 * l02 + a11 * l12 + a12 * l22
    G[g, j, 2, 0] = a20 * l00 + a21 * l10 + a22 * l20
    G[g, j, 2, 1] = a20 * l01 + a21 * l11 + a22 * l21
    G[g, j, 2, 2] = a20 * l02 + a21 * l12 + a22 * l22


@njit(cache=True)
def layout(parents, spine, tail, neck, trunk, leg_int):
    """What :func:`pose_rows` needs of the skeleton, worked out once per character
    (:class:`PoseRig`'s ``how``, ``frame``, ``fixed`` and ``rest``).

    Returns ``how`` (J,), each joint's :func:`_fk_joint` product (the leg
    joints below the top turn about +X, the joints no stage sets keep the
    identity); ``frame`` (J,) bool, whether a joint has children (a leaf's
    world frame is never read); ``fixed``, the joints left at the identity;
    and ``rest``, the joints of the second forward kinematics pass: those
    outside the trunk -- or every joint but the root, should a joint the
    neck or a leg sets be in the trunk, whose first-pass frames would then
    be stale.
    """
    J = parents.shape[0]
    how = np.full(J, FK_IDENTITY, dtype=np.int64)
    frame = np.zeros(J, dtype=np.bool_)
    in_trunk = np.zeros(J, dtype=np.bool_)
    late = np.zeros(J, dtype=np.bool_)  # set after the first pass
    for j in range(1, J):
        frame[parents[j]] = True
    for m in range(trunk.shape[0]):
        in_trunk[trunk[m]] = True
    how[0] = FK_FULL
    for k in range(spine.shape[0]):
        how[spine[k]] = FK_FULL
    for k in range(tail.shape[0]):
        how[tail[k]] = FK_FULL
    for k in range(neck.shape[0]):
        how[neck[k]] = FK_FULL
        late[neck[k]] = True
    for i in range(leg_int.shape[0]):
        n = leg_int[i, 0]
        for k in range(n + 1):
            j = leg_int[i, 4 + k]
            # the foot joint also turns about its vertical (its yaw held)
            how[j] = FK_FULL if k == 0 or k == n else FK_ABOUT_X
            late[j] = True
    stale = False
    n_fixed = 0
    for j in range(J):
        if how[j] == FK_IDENTITY:
            n_fixed += 1
        if in_trunk[j] and late[j]:
            stale = True
    n_rest = 0
    for j in range(1, J):
        if stale or not in_trunk[j]:
            n_rest += 1
    fixed = np.empty(n_fixed, dtype=np.int64)
    rest = np.empty(n_rest, dtype=np.int64)
    n_fixed = 0
    n_rest = 0
    for j in range(J):
        if how[j] == FK_IDENTITY:
            fixed[n_fixed] = j
            n_fixed += 1
        if j > 0 and (stale or not in_trunk[j]):
            rest[n_rest] = j
            n_rest += 1
    return how, frame, fixed, rest


@plan_inner
def _trunk_rows(plan, a, b, parents, offsets, spine, tail, trunk, how, fixed, local,
                positions, G):
    """Rows ``a`` to ``b`` of :func:`pose_rows` up to the legs: the pelvis,
    spine and tail rotations and the trunk's world frames (``G[t - a]``) and
    positions.

    Rotations that share an angle share its cosine and sine: the spine
    joints' common pitch and the yaw of the joints between the first and
    the last.
    """
    K = spine.shape[0]
    for t in range(a, b):
        g = t - a
        for m in range(fixed.shape[0]):
            j = fixed[m]
            for r in range(3):
                for c in range(3):
                    local[t, j, r, c] = 1.0 if r == c else 0.0
        flex = plan[t, BEND_PITCH]
        sway0 = plan[t, SWAY]
        sway1 = plan[t, SWAY + 1]
        # pelvis: heading plus hind sway, tilted back by half the flexion
        yaw = plan[t, HEADING] + sway0
        pitch = plan[t, PITCH] - 0.5 * flex
        _yaw_pitch(local, t, 0, math.cos(yaw), math.sin(yaw), math.cos(pitch),
                   math.sin(pitch))
        # the spine: one pitch; the yaw of the first and last joints has the sway
        pitch = flex / K * 1.0
        cb, sb = math.cos(pitch), math.sin(pitch)
        ca, sa = 1.0, 0.0
        for k in range(K):
            if k < 2 or k == K - 1:  # else the middle joints' yaw, as joint 1's
                yaw = plan[t, BEND_YAW] / K * 1.0
                if k == 0:
                    yaw = yaw - sway0
                if k == K - 1:
                    yaw = yaw + sway1
                ca, sa = math.cos(yaw), math.sin(yaw)
            _yaw_pitch(local, t, spine[k], ca, sa, cb, sb)
        for k in range(tail.shape[0]):
            yaw = plan[t, TAIL + 2 * k + 1]
            pitch = plan[t, TAIL + 2 * k]
            _yaw_pitch(local, t, tail[k], math.cos(yaw), math.sin(yaw), math.cos(pitch),
                       math.sin(pitch))
        # the trunk's world frames
        for r in range(3):
            for c in range(3):
                G[g, 0, r, c] = local[t, 0, r, c]
            positions[t, 0, r] = plan[t, ROOT + r]
        for m in range(1, trunk.shape[0]):
            j = trunk[m]
            _fk_joint(t, g, j, parents[j], how[j], True, local, offsets, G, positions)


@njit(cache=True, inline="always")
def nod_of(fold, t, amplitude):
    """The head's nod (rad, positive nose down) of packed plan row ``t``:
    ``amplitude`` times half the fore legs' support less the hind legs',
    each leg's support ``1 - fold`` (1 in stance, 0 in mid-swing). It dips
    the head while the fore legs carry the trunk: twice a stride in the walk,
    once in the canter and gallop, not at all in the trot and pace, whose
    pairs hold one fore and one hind leg down together. ``fold`` is the
    packed plan."""
    fore = 2.0 - fold[t, FOLD] - fold[t, FOLD + 1]
    hind = 2.0 - fold[t, FOLD + 2] - fold[t, FOLD + 3]
    return 0.5 * amplitude * (fore - hind)


@plan_inner
def _neck_rows(plan, a, b, neck, thorax, nod, local, G):
    """The neck of rows ``a`` to ``b``: the head kept level in space (the
    thorax's pitch undone), dipped by its nod (:func:`nod_of`) and turned to
    look into the turn, shared evenly by the neck joints."""
    nn = neck.shape[0]
    if nn == 0:
        return
    for t in range(a, b):
        g = t - a
        level = -math.asin(min(max(-G[g, thorax, 1, 2], -1.0), 1.0))
        pitch = (level + nod_of(plan, t, nod)) / nn
        yaw = plan[t, LOOK] / nn
        ca, sa = math.cos(yaw), math.sin(yaw)
        cb, sb = math.cos(pitch), math.sin(pitch)
        for k in range(nn):
            _yaw_pitch(local, t, neck[k], ca, sa, cb, sb)


@plan_inner
def _rest_rows(a, b, parents, offsets, how, frame, rest, local, G, positions):
    """Forward kinematics of the joints ``rest`` in rows ``a`` to ``b``, from
    the trunk's world frames ``G[t - a]``."""
    for t in range(a, b):
        g = t - a
        for m in range(rest.shape[0]):
            j = rest[m]
            _fk_joint(t, g, j, parents[j], how[j], frame[j], local, offsets, G, positions)


#: Rows :func:`pose_rows` takes through its stages at a time (their world
#: frames, the scratch between the stages, stay in cache).
CHUNK = 32


class PoseRig(NamedTuple):
    """A character's constants for :func:`pose_rows`.

    Attributes
    ----------
    parents : ndarray of int, shape (J,)
        Skeleton parents, ``parents[j] < j``.
    offsets : ndarray, shape (J, 3)
        Rest offsets (m).
    spine, tail, neck : ndarray of int
        The spine joints below the pelvis (K,), tail joints and neck joints.
    trunk : ndarray of int, shape (M,)
        Increasing joints, each with its parent, holding the legs' parents
        and the thorax ``thorax``: the first forward kinematics pass. The
        second pass leaves them out (their frames are final after the
        first), unless the neck or a leg sets one of them.
    thorax : int
    leg_int, leg_top, leg_bones, leg_scal : ndarray
        The legs (:func:`pack_legs`).
    nod : float
        The head's nod (rad, :func:`nod_of`); 0 keeps the head level.
    how, frame, fixed, rest : ndarray
        The skeleton's layout (:func:`layout`).
    cols : ndarray of int, shape (5,)
        The packed plan's columns the legs' IK reads (feet, fold, toe, foot yaw; -1).
    """

    parents: np.ndarray
    offsets: np.ndarray
    spine: np.ndarray
    tail: np.ndarray
    neck: np.ndarray
    trunk: np.ndarray
    thorax: int
    leg_int: np.ndarray
    leg_top: np.ndarray
    leg_bones: np.ndarray
    leg_scal: np.ndarray
    nod: float
    how: np.ndarray
    frame: np.ndarray
    fixed: np.ndarray
    rest: np.ndarray
    cols: np.ndarray


def pose_rig(parents, offsets, spine, tail, neck, trunk, thorax: int, legs, nod: float) -> PoseRig:
    """A :class:`PoseRig` of fresh writable arrays (one compiled signature for every
    character), with the skeleton's :func:`layout`; ``legs`` is :func:`pack_legs`'s."""
    def ints(x):
        return np.array(x, dtype=np.int64)

    parents, spine, tail, neck, trunk = (ints(x) for x in (parents, spine, tail, neck, trunk))
    legs = tuple(np.array(x) for x in legs)
    how, frame, fixed, rest = layout(parents, spine, tail, neck, trunk, legs[0])
    return PoseRig(parents, np.array(offsets, dtype=float), spine, tail, neck, trunk,
                   int(thorax), *legs, float(nod), how, frame, fixed, rest,
                   ints([FEET, FOLD, TOE, FOOT_YAW, LOAD]))


class PoseScratch(NamedTuple):
    """:func:`pose_rows`'s work space (any values; each concurrent call its own).

    Attributes
    ----------
    G : ndarray, shape (min(T, CHUNK), J, 3, 3)
        A block's world frames.
    legs : ndarray, shape (3, n_max)
        The legs' IK's bone angles, their cosines and sines.
    """

    G: np.ndarray
    legs: np.ndarray


def pose_scratch(rig: PoseRig, rows: int) -> PoseScratch:
    """A :class:`PoseScratch` for :func:`pose_rows` of ``rows`` rows of ``rig``."""
    return PoseScratch(np.empty((min(max(rows, 1), CHUNK), rig.parents.shape[0], 3, 3)),
                       np.empty((3, rig.leg_bones.shape[2])))


@njit(cache=True, nogil=True, _nrt=False)
def pose_rows(plan, rig, local, positions, err, work):
    """Pose T packed plans of one character (compiled).

    Parameters
    ----------
    plan : ndarray, shape (T, F)
        Packed plans (:func:`pack_plan`).
    rig : PoseRig
    local : ndarray, shape (T, J, 3, 3)
        Output: local rotations.
    positions : ndarray, shape (T, J, 3)
        Output: world joint positions (m).
    err : ndarray, shape (T, 4)
        Output: distance from each foot target to the foot reached (m).
    work : PoseScratch
        Work space (:func:`pose_scratch`), not shared with a concurrent call.

    Notes
    -----
    Compiled without numba's reference counting, like the plan: the posing
    borrows its caller's arrays and allocates nothing, and threads posing
    blocks of rows at once no longer count references to the same rig's
    arrays (atomically, on every helper's call).

    The rows go through in blocks of :data:`CHUNK`, each through three
    stages: :func:`_trunk_rows` (spine, tail, trunk forward kinematics),
    :func:`_neck_rows` (the neck), :func:`_leg_rows` (leg IK) and :func:`_rest_rows` (forward
    kinematics of the other joints; a leaf's world frame is not formed).
    The stages index the arrays in place rather than passing views or the
    arrays to helpers inside their loops: each such reference costs an
    atomic reference count, which threads sharing the arrays contend for.
    """
    parents, offsets, spine, tail, neck, trunk, thorax = rig[:7]
    leg_int, leg_top, leg_bones, leg_scal = rig[7:11]
    nod = rig.nod
    legs = (leg_int, leg_top, leg_bones, leg_scal)
    cols = rig.cols  # an array: solve_leg's call shares the compiled IK
    how, frame, fixed, rest = rig.how, rig.frame, rig.fixed, rig.rest
    T = plan.shape[0]
    G = work.G
    for a in range(0, T, CHUNK):
        b = min(T, a + CHUNK)
        _trunk_rows(plan, a, b, parents, offsets, spine, tail, trunk, how, fixed, local,
                    positions, G)
        _neck_rows(plan, a, b, neck, thorax, nod, local, G)
        leg_rows(plan, cols, a, b, legs, G, positions, local, err, work.legs)
        _rest_rows(a, b, parents, offsets, how, frame, rest, local, G, positions)


#: Fewest rows for which the posing and the plan are split over threads
#: (:func:`quadsim.locomotion.blocks.run_blocks`).
PARALLEL_ROWS = 256
