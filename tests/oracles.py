"""Pure-numpy oracles: the engine's stages written a second way, for the tests.

The engine runs compiled kernels only; these independent array forms are
what the tests hold the kernels to (to rounding, about 1e-12).
"""

from __future__ import annotations

import numpy as np

from quadsim.frames import UP
from quadsim.kinematics.ik import (LIFT_CUTOFF, SWING_LIFT_BAND, SWING_LIFT_FOLD,
                                   SWING_PAIR_REACH)
from quadsim.kinematics.rotations import matrices_about_axis
from quadsim.locomotion.cpg import TWO_PI, CPGParams
from quadsim.locomotion.footpath import (SWING_KNOTS, SWING_KNOTS_BOUND, SWING_KNOTS_FAST,
                                         SWING_KNOTS_WALK)

#: the leg pairs (i, j), i < j, of the coupling terms
_PAIR_I = np.array([0, 0, 0, 1, 1, 2])
_PAIR_J = np.array([1, 2, 3, 2, 3, 3])


def amplitude_after(r, t, p: CPGParams):
    """Exact solution of ``dr/dt = a (mu - r^2) r`` after ``t`` seconds."""
    r = np.asarray(r, dtype=float)
    r2 = r * r
    safe = np.where(r2 > 0, r2, 1.0)
    decay = np.exp(-2.0 * p.gain * p.mu * t)
    out = np.sqrt(p.mu / (1.0 + (p.mu / safe - 1.0) * decay))
    return np.where(r2 > 0, out, 0.0)


def _phase_derivatives(theta, r, theta_s, omega, phi, psi_s, p: CPGParams):
    sn = np.sin(theta[..., _PAIR_J] - theta[..., _PAIR_I] - phi)
    s01, s02, s03, s12, s13, s23 = np.moveaxis(sn, -1, 0)
    r0, r1, r2, r3 = np.moveaxis(r, -1, 0)
    w = p.coupling
    dtheta = np.stack([omega + w * (r1 * s01 + r2 * s02 + r3 * s03),
                       omega + w * (r0 * -s01 + r2 * s12 + r3 * s13),
                       omega + w * (r0 * -s02 + r1 * -s12 + r3 * s23),
                       omega + w * (r0 * -s03 + r1 * -s13 + r2 * -s23)], axis=-1)
    dtheta_s = omega + p.spine_coupling * (r0 * np.sin(theta[..., 0] + psi_s[..., 0] - theta_s)
                                           + r2 * np.sin(theta[..., 2] + psi_s[..., 1] - theta_s))
    return dtheta, dtheta_s


def cpg_step(theta, r, theta_s, r_s, omega, psi, dt, params: CPGParams | None = None):
    """The polar Hopf network's step: exact amplitudes, RK4 phases."""
    params = params or CPGParams()
    omega = np.asarray(omega, dtype=float)
    psi = np.asarray(psi, dtype=float)
    h = dt / params.substeps
    theta = np.asarray(theta, dtype=float)
    theta_s = np.asarray(theta_s, dtype=float)
    phi = TWO_PI * (psi[..., _PAIR_I] - psi[..., _PAIR_J])
    psi_s = TWO_PI * psi[..., [0, 2]]
    for _ in range(params.substeps):
        r_mid = amplitude_after(r, 0.5 * h, params)
        r_end = amplitude_after(r, h, params)
        k1 = _phase_derivatives(theta, r, theta_s, omega, phi, psi_s, params)
        k2 = _phase_derivatives(theta + 0.5 * h * k1[0], r_mid, theta_s + 0.5 * h * k1[1],
                                omega, phi, psi_s, params)
        k3 = _phase_derivatives(theta + 0.5 * h * k2[0], r_mid, theta_s + 0.5 * h * k2[1],
                                omega, phi, psi_s, params)
        k4 = _phase_derivatives(theta + h * k3[0], r_end, theta_s + h * k3[1],
                                omega, phi, psi_s, params)
        theta = theta + (h / 6.0) * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        theta_s = theta_s + (h / 6.0) * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        r = r_end
        r_s = amplitude_after(r_s, h, params)
    return theta, r, theta_s, r_s


def swing_position(liftoff, touchdown, height, s, fast=0.0, walk=0.0, bounding=0.0):
    """The swing path at progress ``s``: the Catmull-Rom segment of the knots,
    the share ``fast`` of them the fast gaits', ``walk`` the walk's and ``bounding``
    the bounding gaits'."""
    a = np.asarray(liftoff, dtype=float)
    b = np.asarray(touchdown, dtype=float)
    h = np.asarray(height, dtype=float)
    s = np.asarray(s, dtype=float)
    batch = np.broadcast_shapes(a.shape[:-1], b.shape[:-1], h.shape, s.shape)
    f = np.asarray(fast, dtype=float)
    w = np.asarray(walk, dtype=float)
    r = np.asarray(bounding, dtype=float)
    batch = np.broadcast_shapes(batch, f.shape, w.shape, r.shape)
    s = np.broadcast_to(np.clip(s, 0.0, 1.0), batch)
    nseg = len(SWING_KNOTS) - 3
    x = s * nseg
    i = np.minimum(np.floor(x).astype(int), nseg - 1)
    # every point's own knots, (..., K, 2): the forward fractions blended
    table = np.broadcast_to(SWING_KNOTS, batch + SWING_KNOTS.shape).copy()
    table[..., 0] += f[..., None] * (SWING_KNOTS_FAST[:, 0] - SWING_KNOTS[:, 0])
    table[..., 0] += w[..., None] * (SWING_KNOTS_WALK[:, 0] - SWING_KNOTS[:, 0])
    table[..., 0] += r[..., None] * (SWING_KNOTS_BOUND[:, 0] - SWING_KNOTS[:, 0])
    k = (i[..., None] + np.arange(4))[..., None]
    knots = np.take_along_axis(table, np.broadcast_to(k, batch + (4, 2)), axis=-2)
    P = (a[..., None, :] + knots[..., :1] * (b - a)[..., None, :]
         + knots[..., 1:] * (h[..., None, None] * UP))
    p0, p1, p2, p3 = (P[..., k, :] for k in range(4))
    t = (x - i)[..., None]
    return 0.5 * ((2 * p1) + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t * t
                  + (-p0 + 3 * p1 - 3 * p2 + p3) * t * t * t)


def arc_advance(position, heading, speed, yaw_rate, tau):
    """Position and heading after ``tau`` s on the arc, by the chord
    ``v tau sinc(dh / 2)`` along the mean heading (no switch to a line)."""
    p = np.asarray(position, dtype=float)
    h = np.asarray(heading, dtype=float)
    dh = np.asarray(yaw_rate, dtype=float) * tau
    chord = np.asarray(speed, dtype=float) * tau * np.sinc(dh / (2 * np.pi))
    mid = h + 0.5 * dh
    return p + np.stack([chord * np.sin(mid), 0 * chord, chord * np.cos(mid)], -1), h + dh


# ------------------------------------------------------------ leg IK
def _solve_pair(geom, phi, qd, qf, down_t, fwd_t, lift=None, height=0.0):
    """Solve the two-bone pair in place in ``phi`` given the pre and post bones.

    The pair runs from Q (below the pre bones) to C (the target less the
    post bones). Where ``lift`` (per leg, 0 to 1: a swinging foot's weight) is
    positive, C's component down the leg is first eased, by that weight, to
    keep the pair within SWING_PAIR_REACH of its span (a soft minimum over
    SWING_LIFT_BAND of it).
    Returns how far the foot falls short of the (eased) target (m).
    """
    L = geom.lengths
    k0 = geom.pair
    post = slice(k0 + 2, None)
    cd = down_t - (L[..., post] * np.cos(phi[..., post])).sum(axis=-1)
    cf = fwd_t - (L[..., post] * np.sin(phi[..., post])).sum(axis=-1)
    l1, l2 = L[..., k0], L[..., k0 + 1]
    vd, vf = cd - qd, cf - qf
    if lift is not None:
        span = l1 + l2
        lim = SWING_PAIR_REACH * span
        top = np.sqrt(np.maximum(lim * lim - vf * vf, 0.0))
        k = SWING_LIFT_BAND * span
        z = (vd - top) / k
        eased = vd - k * np.logaddexp(0.0, np.maximum(z, -LIFT_CUTOFF))
        on = lift > 0.0
        vd = np.where(on & (vf * vf < lim * lim) & (vd > 0.0) & (z >= -LIFT_CUTOFF),
                      vd + lift * (eased - vd), vd)
    r_true = np.hypot(vd, vf)
    # np.minimum(np.maximum(...)) is np.clip without its per-call overhead
    r0 = np.minimum(np.maximum(r_true, np.abs(l1 - l2) + 1e-6), 0.998 * (l1 + l2) - 1e-6)
    # a swinging foot is not drawn so close that the middle joint passes its limit
    # (by no more than the target's ``height`` is above a tenth of the pair's span)
    room = np.maximum(height - 0.1 * (l1 + l2), 0.0)
    r = r0 if lift is None else np.where(
        lift > 0.0, np.maximum(r0, np.minimum(geom.pair_min_span, r_true + room)), r0)
    gam = np.arctan2(vf, vd)
    cos_delta = np.minimum(np.maximum((l1 * l1 + r * r - l2 * l2) / (2.0 * l1 * r), -1.0), 1.0)
    phi[..., k0] = gam + geom.bend * np.arccos(cos_delta)
    bd = qd + l1 * np.cos(phi[..., k0])
    bf = qf + l1 * np.sin(phi[..., k0])
    phi[..., k0 + 1] = np.arctan2(qf + r * np.sin(gam) - bf, qd + r * np.cos(gam) - bd)
    return np.abs(r_true - r0)


def solve_leg(geom, parent_rot: np.ndarray, parent_pos: np.ndarray,
              target: np.ndarray, fold: np.ndarray | float = 0.0,
              toe_pitch: np.ndarray | float = 0.0,
              foot_yaw: np.ndarray | float | None = None,
              load: np.ndarray | float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations that put a leg's foot joint on a target (and, if
    ``foot_yaw`` is given, the foot at that world yaw, rad).

    Parameters
    ----------
    geom : LegGeometry
        One leg (:func:`quadsim.kinematics.legs.leg_geometry`).
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
        Stance load over the body's weight: the digit bones turn by ``geom.sink`` times it.

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
    batch = np.broadcast_shapes(Rp.shape[:-2], Pp.shape[:-1], tgt.shape[:-1],
                                np.shape(fold), np.shape(toe_pitch), np.shape(load))
    RpT = np.swapaxes(Rp, -1, -2)
    top = Pp + np.einsum("...ij,...j->...i", Rp, geom.top_offset)
    d = np.einsum("...ij,...j->...i", RpT, tgt - top)
    d = np.broadcast_to(d, batch + (3,))
    # abduction about the parent's forward axis brings the target into the plane
    # (a target above the top joint swings the plane past horizontal: the
    # leg then points at it, and `reached` reports the true miss)
    a = np.arctan2(d[..., 0], -d[..., 1])
    ca, sa = np.cos(a), np.sin(a)
    down_t = -(d[..., 1] * ca - d[..., 0] * sa)  # -(y') with y' = -x sin a + y cos a
    fwd_t = d[..., 2]
    # world down in the leg plane
    g = np.broadcast_to(Rp[..., 1, :] * -1.0, batch + (3,))  # R^T (0,-1,0) = -R[1, :]
    gy = -g[..., 0] * sa + g[..., 1] * ca
    phi_down = np.arctan2(g[..., 2], -gy)

    L = geom.lengths
    A0 = geom.rest_angles
    n = geom.n_bones
    k0 = geom.pair
    phi = np.empty(batch + (n,))
    # pre bones swing with the leg
    alpha = np.arctan2(fwd_t, down_t)
    qd = np.zeros(batch)
    qf = np.zeros(batch)
    swing = alpha - phi_down - geom.rest_leg_angle  # from rest, to the world vertical
    for k in range(k0):
        phi[..., k] = A0[..., k] + phi_down + geom.pre_gain * swing
        qd = qd + L[..., k] * np.cos(phi[..., k])
        qf = qf + L[..., k] * np.sin(phi[..., k])
    # post bones: rest angle to the world vertical, turned with the leg, plus
    # the swing fold and the digit's sink under load
    fold = np.asarray(fold, dtype=float)
    for k in range(k0 + 2, n):
        phi[..., k] = (A0[..., k] + phi_down + geom.post_gain * swing
                       + geom.fold[..., k] * fold + geom.sink[..., k] * np.asarray(load))
    lift = None if foot_yaw is None else np.broadcast_to(
        np.minimum(fold / SWING_LIFT_FOLD, 1.0), batch)
    reached = _solve_pair(geom, phi, qd, qf, down_t, fwd_t, lift, tgt[..., 1])
    # keep the post joints inside their limits relative to the bone above,
    # then solve the pair again for the moved post bones (twice: the second
    # pass corrects the small change the re-solved pair makes)
    for _ in range(2 if geom.limited else 0):
        for k in range(k0 + 2, n):
            rel = (A0[..., k] - phi[..., k]) - (A0[..., k - 1] - phi[..., k - 1])
            rel = np.minimum(np.maximum(rel, geom.lower[..., k]), geom.upper[..., k])
            phi[..., k] = A0[..., k] - (A0[..., k - 1] - phi[..., k - 1]) - rel
        reached = _solve_pair(geom, phi, qd, qf, down_t, fwd_t, lift, tgt[..., 1])

    # the digit (and the foot) drawn folded further with the fold, as far as the target is
    # up, which the pair does not make up for
    carried = np.maximum(fold, 0.0)
    if geom.tuck_height > 0.0:  # as far as the target is up
        carried = carried * np.clip(np.asarray(target, dtype=float)[..., 1] / geom.tuck_height,
                                    0.0, 1.0)
    for k in range(k0 + 3, n):
        phi[..., k] = phi[..., k] + geom.carry[..., k] * carried
    theta = A0 - phi  # cumulative rotation about +X of each chain joint
    toe_phi = phi_down + np.pi / 2 + np.asarray(toe_pitch, dtype=float) \
        + geom.foot_carry * carried
    theta_foot = geom.toe_angle - toe_phi
    cum = np.concatenate([theta, theta_foot[..., None]], axis=-1)
    rel = np.concatenate([cum[..., :1], np.diff(cum, axis=-1)], axis=-1)
    local = matrices_about_axis(0, rel)
    local[..., 0, :, :] = matrices_about_axis(2, a) @ local[..., 0, :, :]
    if foot_yaw is not None:  # the foot held level and at this world yaw: the leg
        # plane's roll (its hinge axis's tilt) undone about the horizontal axis w
        # square to the hinge, then the plane's heading (w's) turned to the yaw
        B = np.broadcast_to(Rp, batch + (3, 3)) @ matrices_about_axis(2, a)
        h = B[..., :, 0]
        roll = np.arcsin(np.clip(h[..., 1], -1.0, 1.0))
        w = np.stack([-h[..., 2], np.zeros(batch), h[..., 0]], axis=-1)
        w /= np.linalg.norm(w, axis=-1, keepdims=True)
        turn = matrices_about_axis(1, np.asarray(foot_yaw, dtype=float)
                                   - np.arctan2(w[..., 0], w[..., 2])) @ _about(w, -roll)
        foot = B @ matrices_about_axis(0, cum[..., n])             # the foot posed in the plane
        above = B @ matrices_about_axis(0, cum[..., n - 1])        # the bone above's turn
        local[..., n, :, :] = np.swapaxes(above, -1, -2) @ turn @ foot
    return local, reached


def _about(axis, angle):
    """Rotation matrices about unit ``axis`` (..., 3) by ``angle`` (...) (Rodrigues)."""
    x, y, z = np.moveaxis(axis, -1, 0)
    c, s = np.cos(angle), np.sin(angle)
    k = 1.0 - c
    return np.stack([np.stack([c + k * x * x, k * x * y - s * z, k * x * z + s * y], -1),
                     np.stack([k * y * x + s * z, c + k * y * y, k * y * z - s * x], -1),
                     np.stack([k * z * x - s * y, k * z * y + s * x, c + k * z * z], -1)], -2)
