"""The data-driven horse's per-frame work, compiled: clip sampling and world placement.

:class:`~quadsim.horse.controller.HorseDataController` keeps its mode logic
(gait choice, transitions, leaps, standing) in Python on scalars and hands
the numerical work of a frame to numba kernels:

* :func:`sample_row` -- a pose between two clip frames: the root linearly,
  every joint by shortest-path slerp (:func:`~quadsim.kinematics.rotations.slerp_one`);
* :func:`stance_row` -- which feet a looped clip holds still at a generic
  time (on the time and on the two frames about it);
* :func:`place_row` -- the whole world placement of a frame: travel along
  the heading, pitch with the ground, the body lead
  (:class:`~quadsim.horse.turning.BodyLead`), forward kinematics, the
  planted feet moving the root (equation 11), foot targets
  (:class:`~quadsim.horse.turning.FootPlanter`), lowering for reach, the
  two-bone IK of the four legs
  (:func:`~quadsim.kinematics.chains.two_bone_row`), quaternions and the
  final forward kinematics (:func:`~quadsim.kinematics.chains.fk_row`);
* :func:`place_feet_rows` -- legs of many poses put on their targets (the
  clip editor's :func:`~quadsim.horse.legs.place_feet`).

Inputs and state travel as named bundles (``typing.NamedTuple`` of arrays
and scalars, which numba compiles and caches like arrays):
:class:`~.bundles.PlaceRig` (the character's joints and body geometry),
:class:`~.bundles.PlaceTuning` (the placement's constants),
:class:`~.bundles.PlaceState` (what the placement carries from frame to
frame: root position, pitch, sag, the body lead's and the feet's state),
:class:`~.bundles.PlaceFrame` (one frame's clip pose and heading) and
:class:`~.bundles.PlacedPose` (the output buffers), all in :mod:`.bundles`. The ground is the ramp table of
:attr:`Ground.table <quadsim.horse.slope.Ground.table>`, (R, 6): origin x,
z, height, direction x, z and ``tan(slope)`` of each ramp, oldest first.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..kinematics.chains import copy_into, fk_row, mul_into, mul_tn_into, two_bone_row
from ..kinematics.rotations import matrix_from_quaternion, quaternion_from_matrix, slerp_one
from .ground_kernel import SETTLE_TURN, ground_height, ground_heights, toe_onto_ground
from .hoof_kernel import tuck_hooves

#: Slack (cycles) of the contact test at a contact's ends (rounding of measured ends).
CONTACT_SLACK = 1e-9
#: A generic time at most this far past a frame (in frames) counts as on the frame.
ON_FRAME = 1e-9
#: Work matrices :func:`place_row` needs beyond one per joint (its scratch is (J + this, 3, 3)).
WORK_MATRICES = 16
#: Work points per leg :func:`place_row` needs (its leg scratch is (this, 4, 3)).
LEG_VECTORS = 5
#: A swing foot is at least this fraction of its clip clearance over the ground under it
#: (a high foot over ground rising above the body's plane otherwise follows the pose: lifted
#: from 46 % to 50 % of its clearance, a galloping fore hoof reaching forward jerked its
#: elbow 30 % faster than the clip's).
MIN_CLEARANCE_FRACTION = 0.3
#: A swing foot the pose puts higher than its clip clearance over the ground is eased onto
#: that height over this span (m): it rises at most half of it above, and its height keeps
#: a continuous velocity where the pose crosses the clearance (a hard cap turned a hind
#: leg's path there, after a descent onto the level, into a jerk of the hip: 1.9x the
#: clip's angular acceleration in the canter).
CAP_EASE = 0.04


# ------------------------------------------------------------------ small pieces
@njit(cache=True)
def _smoothstep(x):
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


@njit(cache=True)
def slerp_into(q0, q1, a, out):
    """Shortest-path slerp of quaternion rows ``q0``, ``q1`` (J, 4) at ``a`` into ``out``
    (which may be ``q0``)."""
    for j in range(q0.shape[0]):
        slerp_one(q0[j], q1[j], a, out[j])


@njit(cache=True, _nrt=False)
def sample_row(roots, rots, i0, i1, a, root_out, q_out):
    """The pose a fraction ``a`` of the way from frame ``i0`` to frame ``i1``.

    Parameters
    ----------
    roots : ndarray, shape (F, 3)
        Root positions (m).
    rots : ndarray, shape (F, J, 4)
        Local rotations, quaternions ``(w, x, y, z)``.
    i0, i1 : int
    a : float
        In [0, 1].
    root_out : ndarray, shape (3,)
        Output: the root, linearly interpolated.
    q_out : ndarray, shape (J, 4)
        Output: every joint slerped.
    """
    for c in range(3):
        root_out[c] = roots[i0, c] * (1.0 - a) + roots[i1, c] * a
    slerp_into(rots[i0], rots[i1], a, q_out)


@njit(cache=True)
def sample_rows(roots, rots, i0, i1, a, root_out, q_out):
    """:func:`sample_row` for ``n`` samples: frames ``i0``, ``i1`` (n,) int, fractions
    ``a`` (n,); ``root_out`` (n, 3), ``q_out`` (n, J, 4) output."""
    for k in range(i0.shape[0]):
        sample_row(roots, rots, i0[k], i1[k], a[k], root_out[k], q_out[k])


@njit(cache=True)
def _in_contact(on_off, count, leg, t):
    x = t % 1.0
    for k in range(count[leg]):
        on = on_off[leg, k, 0]
        off = on_off[leg, k, 1]
        if (x - on) % 1.0 <= (off - on) + CONTACT_SLACK:
            return True
    return False


@njit(cache=True, _nrt=False)
def stance_row(on_off, count, frames, phase, out):
    """The feet (4,) a looped clip holds still at generic time ``phase`` (cycles).

    A foot counts when it is in one of its contacts (``on_off`` (4, M, 2) in
    cycles, ``count`` (4,) how many each foot has) at ``phase`` and, when
    ``phase`` falls between two frames, on both of them.
    """
    f = phase * frames
    k = math.floor(f)
    between = f - k > ON_FRAME
    for leg in range(4):
        st = _in_contact(on_off, count, leg, phase)
        if between and st:
            st = _in_contact(on_off, count, leg, k / frames) and \
                _in_contact(on_off, count, leg, (k + 1) / frames)
        out[leg] = st


@njit(cache=True)
def contact_rows(on_off, count, t, out):
    """Whether each leg is in one of its contacts at generic times ``t`` (T, 4) (cycles):
    ``out`` (T, 4) bool. ``on_off`` (4, M, 2) and ``count`` (4,) as in :func:`stance_row`."""
    for r in range(t.shape[0]):
        for leg in range(4):
            out[r, leg] = _in_contact(on_off, count, leg, t[r, leg])


@njit(cache=True)
def place_feet_rows(parents, offsets, L, roots, legs, targets, q_out):
    """Legs of T poses put on their targets (:func:`~quadsim.horse.legs.place_feet`).

    Parameters
    ----------
    parents : ndarray of int, shape (J,)
    offsets : ndarray, shape (J, 3)
    L : ndarray, shape (T, J, 3, 3)
        Local rotations; each moved leg's pair is overwritten.
    roots : ndarray, shape (T, 3)
        Root positions (m).
    legs : ndarray of int, shape (n, 4)
        Per moved leg: its column in ``targets``, its pair's top and middle
        joints and its foot joint.
    targets : ndarray, shape (T, 4, 3)
        Wanted foot positions (m).
    q_out : ndarray, shape (T, J, 4)
        Output: every joint's local rotation as a quaternion.
    """
    J = parents.shape[0]
    G = np.empty((J, 3, 3))
    P = np.empty((J, 3))
    work = np.empty((4, 3, 3))
    for t in range(L.shape[0]):
        fk_row(parents, offsets, L[t], roots[t], G, P)
        for k in range(legs.shape[0]):
            i, top, mid, foot = legs[k, 0], legs[k, 1], legs[k, 2], legs[k, 3]
            # the legs hang from the trunk apart: one leg's new pair leaves the others' frames
            two_bone_row(P[top], P[mid], P[foot], G[parents[top]], G[top], G[mid],
                         targets[t, i], L[t, top], L[t, mid], work)
        for j in range(J):
            quaternion_from_matrix(L[t, j], q_out[t, j])


def pack_contacts(stance_cycles) -> tuple[np.ndarray, np.ndarray]:
    """Each foot's contacts (list of 4 arrays (n_i, 2), cycles) packed for
    :func:`stance_row` and :func:`contact_rows`: ``on_off`` (4, M, 2), ``count`` (4,) int64."""
    count = np.array([len(x) for x in stance_cycles], dtype=np.int64)
    on_off = np.zeros((4, max(1, int(count.max())), 2))
    for j, x in enumerate(stance_cycles):
        on_off[j, :len(x)] = x
    return on_off, count


# ------------------------------------------------------------------ the placement
@njit(cache=True, _nrt=False)
def place_row(frame, rig, tuning, state, ramps, out):
    """Place one clip-local pose in the world (the data-driven horse's frame).

    Parameters
    ----------
    frame : PlaceFrame
        The clip's pose, its contacts and the heading.
    rig : PlaceRig
    tuning : PlaceTuning
    state : PlaceState
        Updated.
    ramps : ndarray, shape (R, 6)
        The ground's ramp table (:attr:`~quadsim.horse.slope.Ground.table`).
    out : PlacedPose
        Overwritten with the placed pose.
    """
    J = rig.parents.shape[0]
    G = out.scratch[:J]
    M = out.scratch[J:]
    _travel(frame, rig, state)
    th, ahead = _pitch_to_ground(frame, rig, tuning, state, ramps)
    _lead_step(frame, rig, tuning, state.lead, th, ahead)
    L = out.local_rotations
    _clip_pose(frame, rig, state.lead, th, L, M)
    # ---- the root over the ground, forward kinematics
    sy, cy = math.sin(frame.yaw), math.cos(frame.yaw)
    h = frame.local[1]
    root = out.root
    root[0] = state.position[0]
    root[2] = state.position[2]
    root[1] = _body_height(ramps, root[0], root[2], sy, cy, rig.centre, th, h)
    P = out.positions
    fk_row(rig.parents, rig.offsets, L, root, G, P)
    F = out.legs[0]
    clearance = out.clearance
    contacts = out.contacts
    R = M[0]
    feet, band, clip_contacts = rig.feet, tuning.ground_band, frame.contacts
    for i in range(4):
        f = feet[i]
        F[i, 0], F[i, 1], F[i, 2] = P[f, 0], P[f, 1], P[f, 2]
        # the feet's height above the clip's ground, in the body's frame
        clearance[i] = (F[i, 0] - root[0]) * R[0, 1] + (F[i, 1] - root[1]) * R[1, 1] \
            + (F[i, 2] - root[2]) * R[2, 1] + h
        contacts[i] = clip_contacts[i] or clearance[i] <= band
    shift = _follow_plants(frame, rig, tuning, state, ramps, root, F, clearance, contacts, th)
    tgt = out.legs[1]
    _foot_targets(frame, tuning, state.feet, ramps, F, clearance, contacts, tgt)
    A = out.legs[2]
    B = out.legs[3]
    sag = _reach_sag(frame, rig, tuning, state, P, shift, F, tgt, contacts, A, B)
    root[1] -= sag
    _legs_onto_targets(rig, G, A, B, F, sag, tgt, L, M, out.legs[4, 0])
    rotations, ground = out.rotations, out.ground
    fk_row(rig.parents, rig.offsets, L, root, G, P)
    _hold_attitudes(rig, tuning, state.feet, ramps, G, P, L, M[14], rotations)
    tuck_hooves(rig, ramps, tgt, contacts, L, G, P)
    for j in range(J):
        quaternion_from_matrix(L[j], rotations[j])
    toes = rig.toes
    for i in range(4):
        f = feet[i]
        ground[i] = ground_height(ramps, P[f, 0], P[f, 2])
        tx, tz = P[f, 0], P[f, 2]  # and under its toe tip
        for c in range(3):
            tx += G[f, 0, c] * toes[i, c]
            tz += G[f, 2, c] * toes[i, c]
        out.toe_ground[i] = ground_height(ramps, tx, tz)


@njit(cache=True, inline="always")
def _hold_attitudes(rig, tuning, feet, ramps, G, P, L, W, rotations):
    """Each planted foot keeps the world rotation it struck with, and a lifted one
    eases from it to the pose's as its offset fades (``L``, ``G`` and ``P`` of the
    feet and the joints below them updated; ``W`` (3, 3) and the feet's rows of
    ``rotations`` (J, 4) work space). A foot that strikes toe down is
    pitched about its joint until its toe tip is (nearly) on the ground, a
    little a frame from its strike on (:func:`~.ground_kernel.toe_onto_ground`).

    The two-bone IK swings the pair and leaves the bones below at their clip
    angles, so a planted paw turned with the lower leg as the body passed over
    it, its toe tip sliding 5-9 mm while the paw joint stayed put.
    """
    parents, offsets = rig.parents, rig.offsets
    fade_t = tuning.swing_fade
    for i in range(4):
        f = rig.feet[i]
        q = rotations[f]
        if feet.struck[i]:
            toe_onto_ground(G[f], P[f], rig.toes[i], ramps, W)
            quaternion_from_matrix(W, feet.attitude[i])
        w = 1.0 if feet.planted[i] else 1.0 - _smoothstep(feet.air[i] / fade_t)
        if w <= 0.0:
            continue
        if w < 1.0:  # lifting: eased from the held attitude to the pose's
            quaternion_from_matrix(G[f], q)
            slerp_one(q, feet.attitude[i], w, q)
            matrix_from_quaternion(q, W)
        else:
            matrix_from_quaternion(feet.attitude[i], W)
            # a toe still deeper than the strike's turn could lift turns on, frame by frame
            if feet.planted[i] and toe_onto_ground(W, P[f], rig.toes[i], ramps, W, SETTLE_TURN):
                quaternion_from_matrix(W, feet.attitude[i])
        mul_tn_into(G[parents[f]], W, L[f])
        copy_into(W, G[f])
        for m in range(rig.below.shape[1]):  # the joints below the foot follow it
            j = rig.below[i, m]
            if j < 0:
                break
            p = parents[j]
            for r in range(3):
                P[j, r] = P[p, r] + G[p, r, 0] * offsets[j, 0] + G[p, r, 1] * offsets[j, 1] \
                    + G[p, r, 2] * offsets[j, 2]
            mul_into(G[p], L[j], G[j])


@njit(cache=True, inline="always")
def _travel(frame, rig, state):
    """The heading change turns the body about its middle, then the clip's travel goes
    along the heading (``state.position`` updated; at the origin on the first frame)."""
    position = state.position
    if frame.first:
        position[0] = 0.0
        position[1] = 0.0
        position[2] = 0.0
        return
    sy, cy = math.sin(frame.yaw), math.cos(frame.yaw)
    c = rig.centre
    dx = frame.local[0] - frame.local_prev[0]
    dz = frame.local[2] - frame.local_prev[2]
    cp = math.cos(state.pitch[0])
    position[0] += (math.sin(frame.yaw_prev) - sy) * c + (cy * dx + sy * dz) * cp
    position[2] += (math.cos(frame.yaw_prev) - cy) * c + (-sy * dx + cy * dz) * cp


@njit(cache=True, inline="always")
def _pitch_to_ground(frame, rig, tuning, state, ramps):
    """Pitch the body towards the ground's slope between the hips and the shoulders.

    Returns the new pitch and the slope (rad) of the ground ahead of the shoulders.
    """
    sy, cy = math.sin(frame.yaw), math.cos(frame.yaw)
    hind, fore, look = rig.hind, rig.fore, tuning.look_distance
    px, pz = state.position[0], state.position[2]
    gh = ground_height(ramps, px + hind * sy, pz + hind * cy)
    gf = ground_height(ramps, px + fore * sy, pz + fore * cy)
    ga = ground_height(ramps, px + (fore + look) * sy, pz + (fore + look) * cy)
    target = math.atan2(gf - gh, fore - hind)
    if frame.first:
        state.pitch[0] = target
    else:
        state.pitch[0] += (target - state.pitch[0]) * (1.0 - math.exp(-frame.dt / tuning.pitch_tau))
    th = state.pitch[0]
    return th, math.atan2(ga - gf, look)


@njit(cache=True, inline="always")
def _lead_step(frame, rig, tuning, lead, th, ahead):
    """Each chain joint's leads towards its share of the wanted yaw and pitch leads."""
    my, mp = tuning.max_yaw_lead, tuning.max_pitch_lead
    yl = min(max(frame.yaw_lead, -my), my)
    pl = min(max(ahead - th, -mp), mp)
    dt, first = frame.dt, frame.first
    tau, share, yaw, pitch = rig.tau, rig.share, lead.yaw, lead.pitch
    for k in range(rig.chain.shape[0]):
        a = 1.0 - math.exp(-dt / tau[k])
        yaw[k] += a * (share[k] * yl - yaw[k])
        pitch[k] += a * (share[k] * pl - pitch[k])
        if first:
            yaw[k] = share[k] * yl


@njit(cache=True, inline="always")
def _clip_pose(frame, rig, lead, th, L, M):
    """The clip's rotations into ``L`` (J, 3, 3), the root turned to the heading and
    pitched by ``th`` (that rotation left in ``M[0]``), the body lead into the chain."""
    q = frame.rotations
    for j in range(q.shape[0]):
        matrix_from_quaternion(q[j], L[j])
    sy, cy = math.sin(frame.yaw), math.cos(frame.yaw)
    sth, cth = math.sin(th), math.cos(th)
    R = M[0]                                   # R_y(yaw) @ R_x(-th)
    R[0, 0] = cy
    R[0, 1] = -sy * sth
    R[0, 2] = sy * cth
    R[1, 0] = 0.0
    R[1, 1] = cth
    R[1, 2] = sth
    R[2, 0] = -sy
    R[2, 1] = -cy * sth
    R[2, 2] = cy * cth
    mul_into(R, L[0], M[1])
    copy_into(M[1], L[0])
    # the lead into the pose: chain joint k's world rotation becomes A_k W_k,
    # A_k = R_y(yaw_k) (Y_h R_x(-pitch_k) Y_h^T); L_k' = Wp^T A_{k-1}^T A_k Wp L_k
    chain, lead_yaw, lead_pitch = rig.chain, lead.yaw, lead.pitch
    Wp, Wn, Ap, An, T1, T2 = M[2], M[3], M[4], M[5], M[6], M[7]
    copy_into(L[chain[0]], Wp)
    _lead_matrix(lead_yaw[0], lead_pitch[0], sy, cy, Ap)
    for k in range(1, chain.shape[0]):
        j = chain[k]
        mul_into(Wp, L[j], Wn)                 # the joint's world rotation before the lead
        _lead_matrix(lead_yaw[k], lead_pitch[k], sy, cy, An)
        mul_tn_into(Ap, An, T1)                # A_{k-1}^T A_k
        mul_into(T1, Wp, T2)
        mul_tn_into(Wp, T2, T1)                # Wp^T A_{k-1}^T A_k Wp
        mul_into(T1, L[j], T2)
        copy_into(T2, L[j])
        copy_into(Wn, Wp)
        copy_into(An, Ap)


@njit(cache=True, inline="always")
def _follow_plants(frame, rig, tuning, state, ramps, root, F, clearance, contacts, th):
    """Move the root by the mean offset of the planted feet the clip holds down
    (equation 11), at most ``shift_speed``; ``root``, the feet ``F`` (4, 3) and
    ``state.position`` move with it. Returns the shift ``(x, y, z)`` (m)."""
    feet = state.feet
    sx = 0.0
    sz = 0.0
    n_stay = 0
    if not frame.first:
        planted, plant, band = feet.planted, feet.plant, tuning.root_band
        for i in range(4):
            if planted[i] and contacts[i] and clearance[i] <= band:
                sx += plant[i, 0] - F[i, 0]
                sz += plant[i, 2] - F[i, 2]
                n_stay += 1
    shx = 0.0
    shy = 0.0
    shz = 0.0
    if n_stay:
        sx /= n_stay
        sz /= n_stay
        n = math.hypot(sx, sz)
        lim = tuning.shift_speed * frame.dt
        if n > lim:
            sx *= lim / n
            sz *= lim / n
        if sx != 0.0 or sz != 0.0:
            sy, cy = math.sin(frame.yaw), math.cos(frame.yaw)
            y1 = _body_height(ramps, root[0] + sx, root[2] + sz, sy, cy, rig.centre, th,
                              frame.local[1])
            shx, shy, shz = sx, y1 - root[1], sz
            root[0] += shx
            root[1] = y1
            root[2] += shz
            for i in range(4):
                F[i, 0] += shx
                F[i, 1] += shy
                F[i, 2] += shz
            state.position[0] = root[0]
            state.position[2] = root[2]
    return shx, shy, shz


@njit(cache=True, inline="always")
def _soft_floor(a, floor, k):
    """``max(a, floor)`` rounded over ``|a - floor| < k`` (at most ``k / 4`` higher),
    its slope continuous: a swing foot's path meets its clearance floor without a kink
    (a hoof whose clip swing came low over a rising slope turned its tuck, which follows
    the foot's height, from falling to still in one frame)."""
    d = abs(a - floor)
    if d >= k:
        return max(a, floor)
    e = (k - d) / k
    return max(a, floor) + 0.25 * k * e * e


@njit(cache=True, inline="always")
def _foot_targets(frame, tuning, feet, ramps, F, clearance, contacts, tgt):
    """Each foot's target ``tgt`` (4, 3) by the :class:`~quadsim.horse.turning.FootPlanter`'s
    rules: a planted foot on its plant, a striking one planted on the ground, a lifted
    one's correction fading, a swing foot over the ground -- at its clip clearance when
    low, following the pose when high, eased onto the clearance from above
    (:data:`CAP_EASE`), at least :data:`MIN_CLEARANCE_FRACTION` of it up (``feet``
    updated)."""
    planted_, plant, offset, hold, air, drop = (feet.planted, feet.plant, feet.offset, feet.hold,
                                                feet.air, feet.drop)
    if frame.first:
        for i in range(4):
            planted_[i] = False
    fade_t, low, high, dt = tuning.swing_fade, tuning.swing_low, tuning.swing_high, frame.dt
    for i in range(4):
        planted = planted_[i]
        if planted and not contacts[i]:        # lift-off: keep the last planted correction
            offset[i, 0] = hold[i, 0]
            offset[i, 1] = hold[i, 1]
            air[i] = 0.0
        elif not contacts[i]:
            air[i] += dt
        fade = 1.0 - _smoothstep(air[i] / fade_t)
        tx = F[i, 0] + offset[i, 0] * fade
        tz = F[i, 2] + offset[i, 1] * fade
        clear = max(clearance[i], 0.0)
        g = ground_height(ramps, tx, tz)
        over = g + clear
        w = 1.0 - _smoothstep((clear - low) / (high - low))
        ty = F[i, 1] + w * (over - F[i, 1])
        x = ty - over                          # above the clip's clearance: eased onto it
        if x > 0.0:
            ty = over + (x - x * x / (2.0 * CAP_EASE) if x < CAP_EASE else 0.5 * CAP_EASE)
        ty = _soft_floor(ty, g + MIN_CLEARANCE_FRACTION * clear, MIN_CLEARANCE_FRACTION * clear)
        feet.struck[i] = contacts[i] and not planted
        if feet.struck[i]:                     # strike: the plant, on the ground
            plant[i, 0], plant[i, 1], plant[i, 2] = tx, g, tz
            drop[i] = ty - g
        else:
            drop[i] = 0.0
        planted_[i] = contacts[i]
        if contacts[i]:
            tx, ty, tz = plant[i, 0], plant[i, 1], plant[i, 2]
            hold[i, 0] = tx - F[i, 0]
            hold[i, 1] = tz - F[i, 2]
        else:
            hold[i, 0] = 0.0
            hold[i, 1] = 0.0
        tgt[i, 0], tgt[i, 1], tgt[i, 2] = tx, ty, tz


@njit(cache=True, inline="always")
def _reach_sag(frame, rig, tuning, state, P, shift, F, tgt, contacts, A, B):
    """Lower the body when a planted foot is beyond its leg's reach; returns the sag (m)
    (``state.sag`` updated). ``A``, ``B`` (4, 3): output, each pair's top and middle
    joints moved by ``shift``."""
    need = -np.inf
    tops, mids = rig.tops, rig.mids
    for i in range(4):
        for r in range(3):
            A[i, r] = P[tops[i], r] + shift[r]
            B[i, r] = P[mids[i], r] + shift[r]
        ab = math.sqrt((A[i, 0] - B[i, 0]) ** 2 + (A[i, 1] - B[i, 1]) ** 2
                       + (A[i, 2] - B[i, 2]) ** 2)
        fb = math.sqrt((F[i, 0] - B[i, 0]) ** 2 + (F[i, 1] - B[i, 1]) ** 2
                       + (F[i, 2] - B[i, 2]) ** 2)
        reach = (ab + fb) * tuning.reach
        vx, vy, vz = tgt[i, 0] - A[i, 0], tgt[i, 1] - A[i, 1], tgt[i, 2] - A[i, 2]
        val = 0.0
        if contacts[i] and math.sqrt(vx * vx + vy * vy + vz * vz) > reach:
            val = -math.sqrt(max(reach * reach - (vx * vx + vz * vz), 0.0)) - vy
        need = max(need, val)
    state.sag[0] = max(need, state.sag[0] * math.exp(-frame.dt / tuning.sag_tau))
    return state.sag[0]


@njit(cache=True, inline="always")
def _legs_onto_targets(rig, G, A, B, F, sag, tgt, L, M, Fp):
    """The four legs' two-bone IK onto ``tgt`` (4, 3), the body lowered by ``sag``
    (``L`` updated; ``Fp`` (3,) work space)."""
    tops, mids, parents = rig.tops, rig.mids, rig.parents
    for i in range(4):
        A[i, 1] -= sag
        B[i, 1] -= sag
        Fp[0], Fp[1], Fp[2] = F[i, 0], F[i, 1] - sag, F[i, 2]
        top, mid = tops[i], mids[i]
        two_bone_row(A[i], B[i], Fp, G[parents[top]], G[top], G[mid], tgt[i],
                     M[8], M[9], M[10:14])
        copy_into(M[8], L[top])
        copy_into(M[9], L[mid])


@njit(cache=True)
def _lead_matrix(yaw_k, pitch_k, sy, cy, out):
    """``R_y(yaw_k) @ Y_h R_x(-pitch_k) Y_h^T`` with ``Y_h = R_y(heading)`` given by its
    sine ``sy`` and cosine ``cy``: a nose-up pitch about the heading's lateral axis, then a yaw."""
    sp, cp = math.sin(-pitch_k), math.cos(-pitch_k)
    # X = Y_h R_x(p) Y_h^T: rotation by p about the axis (cy, 0, -sy)
    kx, kz = cy, -sy
    c1 = 1.0 - cp
    X00 = cp + c1 * kx * kx
    X01 = -sp * kz
    X02 = c1 * kx * kz
    X10 = sp * kz
    X11 = cp
    X12 = -sp * kx
    X20 = c1 * kx * kz
    X21 = sp * kx
    X22 = cp + c1 * kz * kz
    a, b = math.cos(yaw_k), math.sin(yaw_k)
    out[0, 0] = a * X00 + b * X20
    out[0, 1] = a * X01 + b * X21
    out[0, 2] = a * X02 + b * X22
    out[1, 0] = X10
    out[1, 1] = X11
    out[1, 2] = X12
    out[2, 0] = -b * X00 + a * X20
    out[2, 1] = -b * X01 + a * X21
    out[2, 2] = -b * X02 + a * X22


@njit(cache=True)
def _body_height(ramps, x, z, sy, cy, c, th, h):
    """Root height (m) over the ground for a body of clip height ``h`` pitched by ``th``
    whose middle lies ``c`` m ahead of the root along the heading."""
    k = c * math.cos(th)
    return ground_height(ramps, x + sy * k, z + cy * k) + h / math.cos(th) - c * math.sin(th)


__all__ = ["CAP_EASE", "CONTACT_SLACK", "LEG_VECTORS", "MIN_CLEARANCE_FRACTION", "ON_FRAME", "WORK_MATRICES",
           "contact_rows", "ground_height", "ground_heights", "pack_contacts", "place_feet_rows", "place_row",
           "sample_row", "sample_rows", "slerp_into", "stance_row"]
