"""The data-driven horse's per-frame work, compiled: clip sampling and world placement.

:class:`~quadsim.horse.controller.HorseDataController` keeps its mode logic
(gait choice, transitions, leaps, standing) in Python on scalars and hands
the numerical work of a frame to three numba kernels:

* :func:`sample_row` -- a pose between two clip frames: the root linearly,
  every joint by shortest-path slerp (as :func:`~quadsim.kinematics.rotations.quaternion_slerp`);
* :func:`stance_row` -- which feet a looped clip holds still at a generic
  time (as :func:`~quadsim.horse.root.in_stance` on the time and on the two
  frames about it);
* :func:`place_row` -- the whole world placement of
  :meth:`HorseDataController._emit <quadsim.horse.controller.HorseDataController._emit>`:
  travel along the heading, pitch with the ground, the body lead
  (:class:`~quadsim.horse.turning.BodyLead`), forward kinematics, the
  planted feet moving the root (equation 11), foot targets
  (:class:`~quadsim.horse.turning.FootPlanter`), lowering for reach, the
  two-bone IK of the four legs (:func:`two_bone_row`, one leg of
  :func:`~quadsim.horse.legs.two_bone`), quaternions
  (:func:`~quadsim.kinematics.rotations.quaternion_from_matrix`) and the final forward kinematics
  (:func:`fk_row`).

The array forms these pieces mirror (forward kinematics, the two-bone IK,
the ramp ground, the contact test, the motion sampler) stay the general API -- clip editing and transitions run on whole motions -- and are
the reference the compiled pieces are tested against
(``tests/test_horse_kernels.py``). The placement itself (lead, planting,
reach) exists only here, described in :mod:`quadsim.horse.turning` and the
controller's notes.

Packed inputs (all float64 unless said; m, s, rad):

``ramps`` (R, 6)
    :attr:`Ground.table <quadsim.horse.slope.Ground.table>`: origin x, z,
    height, direction x, z, ``tan(slope)`` of each ramp, oldest first.
``body`` (n, 4)
    :attr:`BodyLead.state <quadsim.horse.turning.BodyLead.state>`: per chain
    joint its yaw lead, pitch lead (updated), share and follow time constant.
``feet_state`` (4, 12)
    :attr:`FootPlanter.state <quadsim.horse.turning.FootPlanter.state>`: per
    leg planted (0/1), plant x, y, z, offset x, z, hold x, z, time in the air,
    drop, contact (0/1) and a spare column; row 0's spare is 1 once started.
``scal`` (:data:`N_SCALARS`,)
    The controller's placement state and constants, columns :data:`SCALARS`.
``ints`` (n_ints,) int64
    ``[n_chain, chain..., feet (4), tops (4), mids (4)]``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..kinematics.chains import fk_row, mul_into, mul_tn_into, two_bone_row
from ..kinematics.rotations import matrix_from_quaternion, quaternion_from_matrix, slerp_one

#: Columns of the ``scal`` array of :func:`place_row` (state first, then constants).
SCALARS = ("pitch", "sag", "centre", "hind", "fore", "look_distance", "pitch_tau",
           "sag_tau", "reach", "shift_speed", "root_band", "ground_band", "swing_fade",
           "swing_low", "swing_high", "max_yaw_lead", "max_pitch_lead")
(S_PITCH, S_SAG, S_CENTRE, S_HIND, S_FORE, S_LOOK, S_PITCH_TAU, S_SAG_TAU, S_REACH,
 S_SHIFT_SPEED, S_ROOT_BAND, S_GROUND_BAND, S_SWING_FADE, S_SWING_LOW, S_SWING_HIGH,
 S_MAX_YAW, S_MAX_PITCH) = range(len(SCALARS))
N_SCALARS = len(SCALARS)

#: Columns of the ``feet_state`` rows.
F_PLANTED, F_PLANT, F_OFFSET, F_HOLD, F_AIR, F_DROP, F_CONTACT, F_SPARE = 0, 1, 4, 6, 8, 9, 10, 11
FEET_COLUMNS = 12


# ------------------------------------------------------------------ small pieces
@njit(cache=True)
def ground_height(ramps, x, z):
    """Height (m) of the ramp field at the horizontal point ``(x, z)``: the
    newest ramp whose half-plane holds the point, else 0."""
    h = 0.0
    for r in range(ramps.shape[0]):
        s = (x - ramps[r, 0]) * ramps[r, 3] + (z - ramps[r, 1]) * ramps[r, 4]
        if s >= 0.0:
            h = ramps[r, 2] + ramps[r, 5] * s
    return h


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


@njit(cache=True)
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
def _in_contact(on_off, count, leg, t):
    x = t % 1.0
    for k in range(count[leg]):
        on = on_off[leg, k, 0]
        off = on_off[leg, k, 1]
        if (x - on) % 1.0 <= (off - on) + 1e-9:
            return True
    return False


@njit(cache=True)
def stance_row(on_off, count, frames, phase, out):
    """The feet (4,) a looped clip holds still at generic time ``phase`` (cycles).

    A foot counts when it is in one of its contacts (``on_off`` (4, M, 2) in
    cycles, ``count`` (4,) how many each foot has) at ``phase`` and, when
    ``phase`` falls between two frames, on both of them.
    """
    f = phase * frames
    k = math.floor(f)
    between = f - k > 1e-9
    for leg in range(4):
        st = _in_contact(on_off, count, leg, phase)
        if between and st:
            st = _in_contact(on_off, count, leg, k / frames) and \
                _in_contact(on_off, count, leg, (k + 1) / frames)
        out[leg] = st


@njit(cache=True)
def place_feet_rows(parents, offsets, L, roots, legs, targets, q_out):
    """Legs of T poses put on their targets (the compiled :func:`~quadsim.horse.legs.place_feet`).

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


# ------------------------------------------------------------------ the placement
@njit(cache=True)
def place_row(local, local_prev, q, clip_contacts, first, dt, yaw, yaw0, yaw_lead,
              position, scal, body, feet_state, ramps, ints, parents, offsets,
              out_L, out_q, out_P, out_root, out_contacts, out_ground, scratch):
    """Place one clip-local pose in the world (the compiled
    :meth:`~quadsim.horse.controller.HorseDataController._emit`).

    Parameters
    ----------
    local, local_prev : ndarray, shape (3,)
        The clip's root this frame and last frame (m, clip frame, travel unwrapped).
    q : ndarray, shape (J, 4)
        The clip's local rotations.
    clip_contacts : ndarray of bool, shape (4,)
        Feet the clip holds on the ground.
    first : bool
        The first frame (the horse is put at the origin, leads and pitch set at once).
    dt : float
        Time since the last frame (s), 0 on the first.
    yaw, yaw0 : float
        The heading this frame and last frame (rad).
    yaw_lead : float
        How far the head should lead the root in yaw (rad).
    position : ndarray, shape (3,)
        World position of the root on the ground plane ``(x, 0, z)`` (updated).
    scal : ndarray, shape (N_SCALARS,)
        Pitch and sag (updated), then constants (see :data:`SCALARS`).
    body, feet_state, ramps, ints : ndarray
        See the module notes (``body`` and ``feet_state`` updated).
    parents : ndarray of int, shape (J,)
    offsets : ndarray, shape (J, 3)
    out_L : ndarray, shape (J, 3, 3)
        Output: local rotations.
    out_q : ndarray, shape (J, 4)
        Output: local rotations as quaternions.
    out_P : ndarray, shape (J, 3)
        Output: world joint positions (m).
    out_root : ndarray, shape (3,)
        Output: world root position (m).
    out_contacts : ndarray of bool, shape (4,)
        Output: the planted feet.
    out_ground : ndarray, shape (4,)
        Output: ground height under each foot (m).
    scratch : ndarray, shape (J + 16, 3, 3)
        Work space.
    """
    J = parents.shape[0]
    n_chain = ints[0]
    chain = ints[1:1 + n_chain]
    feet = ints[1 + n_chain:5 + n_chain]
    tops = ints[5 + n_chain:9 + n_chain]
    mids = ints[9 + n_chain:13 + n_chain]
    G = scratch[:J]
    M = scratch[J:J + 16]
    c = scal[S_CENTRE]
    sy, cy = math.sin(yaw), math.cos(yaw)
    # ---- travel: the heading change turns the body about its middle, then the clip's travel
    if first:
        position[0] = 0.0
        position[1] = 0.0
        position[2] = 0.0
    else:
        dx = local[0] - local_prev[0]
        dz = local[2] - local_prev[2]
        cp = math.cos(scal[S_PITCH])
        position[0] += (math.sin(yaw0) - sy) * c + (cy * dx + sy * dz) * cp
        position[2] += (math.cos(yaw0) - cy) * c + (-sy * dx + cy * dz) * cp
    # ---- pitch towards the ground's slope between the hips and the shoulders
    hind, fore, look = scal[S_HIND], scal[S_FORE], scal[S_LOOK]
    px, pz = position[0], position[2]
    gh = ground_height(ramps, px + hind * sy, pz + hind * cy)
    gf = ground_height(ramps, px + fore * sy, pz + fore * cy)
    ga = ground_height(ramps, px + (fore + look) * sy, pz + (fore + look) * cy)
    target = math.atan2(gf - gh, fore - hind)
    if first:
        scal[S_PITCH] = target
    else:
        scal[S_PITCH] += (target - scal[S_PITCH]) * (1.0 - math.exp(-dt / scal[S_PITCH_TAU]))
    th = scal[S_PITCH]
    ahead = math.atan2(ga - gf, look)
    # ---- the body lead: each joint towards its share of the wanted leads
    my, mp = scal[S_MAX_YAW], scal[S_MAX_PITCH]
    yl = min(max(yaw_lead, -my), my)
    pl = min(max(ahead - th, -mp), mp)
    for k in range(n_chain):
        a = 1.0 - math.exp(-dt / body[k, 3])
        body[k, 0] += a * (body[k, 2] * yl - body[k, 0])
        body[k, 1] += a * (body[k, 2] * pl - body[k, 1])
        if first:
            body[k, 0] = body[k, 2] * yl
    # ---- the clip's rotations, the root turned to the heading and pitched
    for j in range(J):
        matrix_from_quaternion(q[j], out_L[j])
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
    mul_into(R, out_L[0], M[1])
    out_L[0, :, :] = M[1]
    # ---- the lead into the pose: chain joint k's world rotation becomes A_k W_k,
    #      A_k = R_y(yaw_k) (Y_h R_x(-pitch_k) Y_h^T); L_k' = Wp^T A_{k-1}^T A_k Wp L_k
    Wp, Wn, Ap, An, T1, T2 = M[2], M[3], M[4], M[5], M[6], M[7]
    Wp[:, :] = out_L[chain[0]]
    _lead_matrix(body[0, 0], body[0, 1], sy, cy, Ap)
    for k in range(1, n_chain):
        j = chain[k]
        mul_into(Wp, out_L[j], Wn)                 # the joint's world rotation before the lead
        _lead_matrix(body[k, 0], body[k, 1], sy, cy, An)
        mul_tn_into(Ap, An, T1)                    # A_{k-1}^T A_k
        mul_into(T1, Wp, T2)
        mul_tn_into(Wp, T2, T1)                    # Wp^T A_{k-1}^T A_k Wp
        mul_into(T1, out_L[j], T2)
        out_L[j, :, :] = T2
        Wp[:, :] = Wn
        Ap[:, :] = An
    # ---- the root over the ground, forward kinematics
    h = local[1]
    root = out_root
    root[0] = position[0]
    root[2] = position[2]
    root[1] = _body_height(ramps, root[0], root[2], sy, cy, c, th, h)
    fk_row(parents, offsets, out_L, root, G, out_P)
    fx = np.empty(4)
    fy = np.empty(4)
    fz = np.empty(4)
    clearance = np.empty(4)
    contacts = np.empty(4, dtype=np.bool_)
    gb = scal[S_GROUND_BAND]
    for i in range(4):
        f = feet[i]
        fx[i], fy[i], fz[i] = out_P[f, 0], out_P[f, 1], out_P[f, 2]
        # the feet's height above the clip's ground, in the body's frame
        clearance[i] = (fx[i] - root[0]) * R[0, 1] + (fy[i] - root[1]) * R[1, 1] \
            + (fz[i] - root[2]) * R[2, 1] + h
        contacts[i] = clip_contacts[i] or clearance[i] <= gb
    # ---- the root follows the planted feet the clip holds down (equation 11)
    started = feet_state[0, F_SPARE] > 0.5
    sx = 0.0
    sz = 0.0
    n_stay = 0
    if started:
        for i in range(4):
            if feet_state[i, F_PLANTED] > 0.5 and contacts[i] and clearance[i] <= scal[S_ROOT_BAND]:
                sx += feet_state[i, F_PLANT] - fx[i]
                sz += feet_state[i, F_PLANT + 2] - fz[i]
                n_stay += 1
    shx = 0.0
    shy = 0.0
    shz = 0.0
    if n_stay:
        sx /= n_stay
        sz /= n_stay
        n = math.hypot(sx, sz)
        lim = scal[S_SHIFT_SPEED] * dt
        if n > lim:
            sx *= lim / n
            sz *= lim / n
        if sx != 0.0 or sz != 0.0:
            y1 = _body_height(ramps, root[0] + sx, root[2] + sz, sy, cy, c, th, h)
            shx, shy, shz = sx, y1 - root[1], sz
            root[0] += shx
            root[1] = y1
            root[2] += shz
            for i in range(4):
                fx[i] += shx
                fy[i] += shy
                fz[i] += shz
            position[0] = root[0]
            position[2] = root[2]
    # ---- foot targets (the FootPlanter's rules)
    if not started:
        feet_state[0, F_SPARE] = 1.0
        for i in range(4):
            feet_state[i, F_PLANTED] = 0.0
    tgt = np.empty((4, 3))
    fade_t, low, high = scal[S_SWING_FADE], scal[S_SWING_LOW], scal[S_SWING_HIGH]
    for i in range(4):
        st = feet_state[i]
        planted = st[F_PLANTED] > 0.5
        if planted and not contacts[i]:        # lift-off: keep the last planted correction
            st[F_OFFSET] = st[F_HOLD]
            st[F_OFFSET + 1] = st[F_HOLD + 1]
            st[F_AIR] = 0.0
        elif not contacts[i]:
            st[F_AIR] += dt
        fade = 1.0 - _smoothstep(st[F_AIR] / fade_t)
        tx = fx[i] + st[F_OFFSET] * fade
        tz = fz[i] + st[F_OFFSET + 1] * fade
        clear = max(clearance[i], 0.0)
        g = ground_height(ramps, tx, tz)
        over = g + clear
        w = 1.0 - _smoothstep((clear - low) / (high - low))
        ty = max(min(over, fy[i] + w * (over - fy[i])), over - 0.5 * clear)
        if contacts[i] and not planted:        # strike: the plant, on the ground
            st[F_PLANT], st[F_PLANT + 1], st[F_PLANT + 2] = tx, g, tz
            st[F_DROP] = ty - g
        else:
            st[F_DROP] = 0.0
        st[F_PLANTED] = 1.0 if contacts[i] else 0.0
        st[F_CONTACT] = st[F_PLANTED]
        if contacts[i]:
            tx, ty, tz = st[F_PLANT], st[F_PLANT + 1], st[F_PLANT + 2]
            st[F_HOLD] = tx - fx[i]
            st[F_HOLD + 1] = tz - fz[i]
        else:
            st[F_HOLD] = 0.0
            st[F_HOLD + 1] = 0.0
        tgt[i, 0], tgt[i, 1], tgt[i, 2] = tx, ty, tz
        out_contacts[i] = contacts[i]
    # ---- lower the body when a planted foot is beyond its leg's reach
    A = np.empty((4, 3))
    B = np.empty((4, 3))
    need = -np.inf
    for i in range(4):
        for r in range(3):
            s_r = shx if r == 0 else (shy if r == 1 else shz)
            A[i, r] = out_P[tops[i], r] + s_r
            B[i, r] = out_P[mids[i], r] + s_r
        ab = math.sqrt((A[i, 0] - B[i, 0]) ** 2 + (A[i, 1] - B[i, 1]) ** 2
                       + (A[i, 2] - B[i, 2]) ** 2)
        fb = math.sqrt((fx[i] - B[i, 0]) ** 2 + (fy[i] - B[i, 1]) ** 2 + (fz[i] - B[i, 2]) ** 2)
        reach = (ab + fb) * scal[S_REACH]
        vx, vy, vz = tgt[i, 0] - A[i, 0], tgt[i, 1] - A[i, 1], tgt[i, 2] - A[i, 2]
        val = 0.0
        if contacts[i] and math.sqrt(vx * vx + vy * vy + vz * vz) > reach:
            val = -math.sqrt(max(reach * reach - (vx * vx + vz * vz), 0.0)) - vy
        need = max(need, val)
    scal[S_SAG] = max(need, scal[S_SAG] * math.exp(-dt / scal[S_SAG_TAU]))
    sag = scal[S_SAG]
    root[1] -= sag
    # ---- the legs onto their targets (two-bone IK), then the final pose
    Fp = np.empty(3)
    for i in range(4):
        A[i, 1] -= sag
        B[i, 1] -= sag
        Fp[0], Fp[1], Fp[2] = fx[i], fy[i] - sag, fz[i]
        top, mid = tops[i], mids[i]
        two_bone_row(A[i], B[i], Fp, G[parents[top]], G[top], G[mid], tgt[i],
                     M[8], M[9], M[10:14])
        out_L[top, :, :] = M[8]
        out_L[mid, :, :] = M[9]
    for j in range(J):
        quaternion_from_matrix(out_L[j], out_q[j])
    fk_row(parents, offsets, out_L, root, G, out_P)
    for i in range(4):
        f = feet[i]
        out_ground[i] = ground_height(ramps, out_P[f, 0], out_P[f, 2])


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


__all__ = ["FEET_COLUMNS", "N_SCALARS", "SCALARS", "fk_row", "ground_height", "place_feet_rows",
           "place_row", "sample_row", "slerp_into", "stance_row", "two_bone_row"]
