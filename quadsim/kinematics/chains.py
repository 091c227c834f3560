"""Compiled kernels for chains of joints: forward kinematics and two-bone IK.

The one implementation of each, shared by the procedural posing, the
data-driven horse and :func:`quadsim.skeleton.fk.forward_kinematics`. Plain
arrays only (no skeleton objects), so this sits at the bottom of the package
beside :mod:`quadsim.kinematics.rotations`. Rotation matrices act on column
vectors; positions in metres.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["axis_angle_into", "copy_into", "fk_joint", "fk_row", "mul_into", "mul_tn_into", "two_bone_row",
           "two_bone_rows"]


@njit(cache=True)
def axis_angle_into(kx, ky, kz, ang, R):
    """Rodrigues' rotation about the unit axis ``k`` by ``ang`` into ``R`` (3, 3)."""
    s, c = math.sin(ang), 1.0 - math.cos(ang)
    # R = I + s K + c K K, K the cross-product matrix of k
    R[0, 0] = 1.0 - c * (ky * ky + kz * kz)
    R[1, 1] = 1.0 - c * (kx * kx + kz * kz)
    R[2, 2] = 1.0 - c * (kx * kx + ky * ky)
    R[0, 1] = -s * kz + c * kx * ky
    R[1, 0] = s * kz + c * kx * ky
    R[0, 2] = s * ky + c * kx * kz
    R[2, 0] = -s * ky + c * kx * kz
    R[1, 2] = -s * kx + c * ky * kz
    R[2, 1] = s * kx + c * ky * kz


@njit(cache=True)
def mul_into(A, B, out):
    """``out = A @ B`` for 3 x 3 matrices (``out`` distinct from both)."""
    for r in range(3):
        for c in range(3):
            out[r, c] = A[r, 0] * B[0, c] + A[r, 1] * B[1, c] + A[r, 2] * B[2, c]


@njit(cache=True)
def copy_into(A, out):
    """``out[:, :] = A`` for 3 x 3 matrices, element by element (a slice
    assignment makes numba compile its shape-mismatch error path, about 3 s
    of the horse placement kernel's compile)."""
    for r in range(3):
        for c in range(3):
            out[r, c] = A[r, c]


@njit(cache=True)
def mul_tn_into(A, B, out):
    """``out = A.T @ B`` for 3 x 3 matrices."""
    for r in range(3):
        for c in range(3):
            out[r, c] = A[0, r] * B[0, c] + A[1, r] * B[1, c] + A[2, r] * B[2, c]


@njit(cache=True)
def two_bone_row(A, B, F, W_parent, W_top, W_mid, target, L_top, L_mid, work):
    """One leg's ``two_bone``: local rotations (3, 3) of the
    pair's top and middle joints putting the foot ``F`` on ``target``.

    ``A``, ``B``, ``F``, ``target`` (3,) are world positions (m); ``W_*`` (3, 3)
    world rotations; ``work`` (4, 3, 3) scratch.
    """
    ux, uy, uz = A[0] - B[0], A[1] - B[1], A[2] - B[2]
    wx, wy, wz = F[0] - B[0], F[1] - B[1], F[2] - B[2]
    l1 = math.sqrt(ux * ux + uy * uy + uz * uz)
    l2 = math.sqrt(wx * wx + wy * wy + wz * wz)
    tx, ty, tz = target[0] - A[0], target[1] - A[1], target[2] - A[2]
    d = min(max(math.sqrt(tx * tx + ty * ty + tz * tz), abs(l1 - l2) + 1e-6), l1 + l2 - 1e-6)
    nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
    nn = math.sqrt(nx * nx + ny * ny + nz * nz)
    if nn > 1e-9:
        nx, ny, nz = nx / nn, ny / nn, nz / nn
    else:
        nx, ny, nz = 1.0, 0.0, 0.0
    beta0 = math.acos(min(max((ux * wx + uy * wy + uz * wz) / (l1 * l2), -1.0), 1.0))
    beta1 = math.acos(min(max((l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2), -1.0), 1.0))
    Rm, Rs, Wt, T = work[0], work[1], work[2], work[3]
    axis_angle_into(nx, ny, nz, beta1 - beta0, Rm)
    ax_ = Rm[0, 0] * wx + Rm[0, 1] * wy + Rm[0, 2] * wz + B[0] - A[0]
    ay_ = Rm[1, 0] * wx + Rm[1, 1] * wy + Rm[1, 2] * wz + B[1] - A[1]
    az_ = Rm[2, 0] * wx + Rm[2, 1] * wy + Rm[2, 2] * wz + B[2] - A[2]
    na = math.sqrt(ax_ * ax_ + ay_ * ay_ + az_ * az_)
    ax_, ay_, az_ = ax_ / na, ay_ / na, az_ / na
    nb = max(math.sqrt(tx * tx + ty * ty + tz * tz), 1e-12)
    bx, by, bz = tx / nb, ty / nb, tz / nb
    cx, cy, cz = ay_ * bz - az_ * by, az_ * bx - ax_ * bz, ax_ * by - ay_ * bx
    s = math.sqrt(cx * cx + cy * cy + cz * cz)
    ang = math.atan2(s, ax_ * bx + ay_ * by + az_ * bz)
    if s > 1e-12:
        cx, cy, cz = cx / s, cy / s, cz / s
    else:
        cx, cy, cz = nx, ny, nz
    axis_angle_into(cx, cy, cz, ang, Rs)
    mul_into(Rs, W_top, Wt)                 # the top joint's new world rotation
    mul_tn_into(W_parent, Wt, L_top)
    mul_into(Rm, W_mid, T)
    mul_into(Rs, T, work[0])                # the middle joint's new world rotation (Rm no longer used)
    mul_tn_into(Wt, work[0], L_mid)


@njit(cache=True)
def two_bone_rows(A, B, F, W_parent, W_top, W_mid, targets, L_top, L_mid):
    """:func:`two_bone_row` for ``n`` legs or frames at once.

    ``A``, ``B``, ``F``, ``targets`` (n, 3) world positions (m); ``W_*`` (n, 3, 3)
    world rotations; ``L_top``, ``L_mid`` (n, 3, 3) output local rotations.
    """
    work = np.empty((4, 3, 3))
    for k in range(A.shape[0]):
        two_bone_row(A[k], B[k], F[k], W_parent[k], W_top[k], W_mid[k], targets[k],
                     L_top[k], L_mid[k], work)


@njit(cache=True)
def fk_row(parents, offsets, L, root, G, P):
    """World rotations ``G`` (J, 3, 3) and positions ``P`` (J, 3) of one pose.

    Parameters
    ----------
    parents : ndarray of int, shape (J,)
        Parent of each joint, ``parents[j] < j``; joint 0 is the root.
    offsets : ndarray, shape (J, 3)
        Each joint's offset from its parent, in the parent's frame (m).
    L : ndarray, shape (J, 3, 3)
        Local rotations (the root's is its world orientation).
    root : ndarray, shape (3,)
        Root position (m).
    G, P : ndarray, shapes (J, 3, 3) and (J, 3)
        Output.
    """
    for r in range(3):
        for c in range(3):
            G[0, r, c] = L[0, r, c]
        P[0, r] = root[r]
    for j in range(1, parents.shape[0]):
        fk_joint(parents[j], j, offsets[j], L[j], G, P)


@njit(cache=True, inline="always")
def fk_joint(p, m, off, Lj, G, P):
    """Joint ``m`` of a pose from its parent ``p`` (already placed): ``G[m] = G[p] Lj``,
    ``P[m] = P[p] + G[p] off`` -- the one forward-kinematics step every kernel uses."""
    for r in range(3):
        g0, g1, g2 = G[p, r, 0], G[p, r, 1], G[p, r, 2]
        for c in range(3):
            G[m, r, c] = g0 * Lj[0, c] + g1 * Lj[1, c] + g2 * Lj[2, c]
        P[m, r] = P[p, r] + g0 * off[0] + g1 * off[1] + g2 * off[2]
