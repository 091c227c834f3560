"""Batched rotation conversions.

Quaternions are stored as ``(w, x, y, z)`` (scalar first, the transforms3d
order). Rotation matrices act on column vectors: ``v_world = R @ v_local``.
Every function takes any leading batch shape.
"""

from __future__ import annotations

import numpy as np

_EULER_AXES = {"X": 0, "Y": 1, "Z": 2}


def matrices_about_axis(axis: int, angles: np.ndarray) -> np.ndarray:
    """Rotation matrices about a coordinate axis.

    Parameters
    ----------
    axis : int
        0 for X, 1 for Y, 2 for Z.
    angles : array-like, shape (...)
        Angles in radians (right-handed).

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
    """
    a = np.asarray(angles, dtype=float)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def matrices_yaw_pitch(yaw: np.ndarray, pitch: np.ndarray) -> np.ndarray:
    """``R_y(yaw) @ R_x(pitch)`` in closed form: a turn about +Y after a tilt
    about +X.

    Parameters
    ----------
    yaw, pitch : array-like, shape (...)
        Angles in radians (broadcast together).

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
    """
    a = np.asarray(yaw, dtype=float)
    b = np.asarray(pitch, dtype=float)
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    R = np.empty(np.broadcast_shapes(a.shape, b.shape) + (3, 3))
    R[..., 0, 0] = ca
    R[..., 0, 1] = sa * sb
    R[..., 0, 2] = sa * cb
    R[..., 1, 0] = 0.0
    R[..., 1, 1] = cb
    R[..., 1, 2] = -sb
    R[..., 2, 0] = -sa
    R[..., 2, 1] = ca * sb
    R[..., 2, 2] = ca * cb
    return R


def matrices_from_axis_angles(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rodrigues' formula, batched.

    Parameters
    ----------
    axis : array-like, shape (..., 3)
        Rotation axes (normalised here; a zero axis gives the identity).
    angles : array-like, shape (...)
        Angles in radians.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
    """
    axis = np.asarray(axis, dtype=float)
    n = np.linalg.norm(axis, axis=-1, keepdims=True)
    k = np.divide(axis, n, out=np.zeros_like(axis), where=n > 1e-12)
    a = np.asarray(angles, dtype=float)[..., None, None]
    K = np.zeros(k.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2] = -k[..., 2], k[..., 1]
    K[..., 1, 0], K[..., 1, 2] = k[..., 2], -k[..., 0]
    K[..., 2, 0], K[..., 2, 1] = -k[..., 1], k[..., 0]
    eye = np.broadcast_to(np.eye(3), K.shape)
    return eye + np.sin(a) * K + (1.0 - np.cos(a)) * (K @ K)


def matrices_from_quaternions(q: np.ndarray) -> np.ndarray:
    """Rotation matrices from unit quaternions ``(w, x, y, z)``.

    Parameters
    ----------
    q : array-like, shape (..., 4)

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
    """
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - z * w)
    R[..., 0, 2] = 2 * (x * z + y * w)
    R[..., 1, 0] = 2 * (x * y + z * w)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - x * w)
    R[..., 2, 0] = 2 * (x * z - y * w)
    R[..., 2, 1] = 2 * (y * z + x * w)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def quaternions_from_matrices(R: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(w, x, y, z)`` with ``w >= 0`` from rotation matrices.

    Uses the numerically stable branch on the largest diagonal term.

    Parameters
    ----------
    R : array-like, shape (..., 3, 3)

    Returns
    -------
    q : ndarray, shape (..., 4)
    """
    R = np.asarray(R, dtype=float)
    m00, m11, m22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    tr = m00 + m11 + m22
    cand = np.stack([tr, m00, m11, m22], axis=-1)
    k = np.argmax(cand, axis=-1)
    q = np.empty(R.shape[:-2] + (4,))
    # each branch computed everywhere, then selected (vectorised)
    s0 = np.sqrt(np.maximum(1.0 + tr, 1e-300)) * 2
    q0 = np.stack([0.25 * s0, (R[..., 2, 1] - R[..., 1, 2]) / s0,
                   (R[..., 0, 2] - R[..., 2, 0]) / s0, (R[..., 1, 0] - R[..., 0, 1]) / s0], -1)
    s1 = np.sqrt(np.maximum(1.0 + m00 - m11 - m22, 1e-300)) * 2
    q1 = np.stack([(R[..., 2, 1] - R[..., 1, 2]) / s1, 0.25 * s1,
                   (R[..., 0, 1] + R[..., 1, 0]) / s1, (R[..., 0, 2] + R[..., 2, 0]) / s1], -1)
    s2 = np.sqrt(np.maximum(1.0 - m00 + m11 - m22, 1e-300)) * 2
    q2 = np.stack([(R[..., 0, 2] - R[..., 2, 0]) / s2, (R[..., 0, 1] + R[..., 1, 0]) / s2,
                   0.25 * s2, (R[..., 1, 2] + R[..., 2, 1]) / s2], -1)
    s3 = np.sqrt(np.maximum(1.0 - m00 - m11 + m22, 1e-300)) * 2
    q3 = np.stack([(R[..., 1, 0] - R[..., 0, 1]) / s3, (R[..., 0, 2] + R[..., 2, 0]) / s3,
                   (R[..., 1, 2] + R[..., 2, 1]) / s3, 0.25 * s3], -1)
    q = np.choose(k[..., None], [q0, q1, q2, q3])
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0, -q, q)


def quaternion_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` of ``(w, x, y, z)`` quaternions, batched."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ], axis=-1)


def quaternion_slerp(q0: np.ndarray, q1: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Shortest-path spherical interpolation, batched.

    Parameters
    ----------
    q0, q1 : array-like, shape (..., 4)
        Unit quaternions ``(w, x, y, z)``.
    t : array-like, shape (...)
        Interpolation parameter, 0 gives ``q0`` and 1 gives ``q1``.

    Returns
    -------
    q : ndarray, shape (..., 4)
    """
    q0 = np.asarray(q0, dtype=float)
    q1 = np.asarray(q1, dtype=float)
    t = np.asarray(t, dtype=float)[..., None]
    d = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(d < 0, -q1, q1)
    d = np.abs(d)
    theta = np.arccos(np.clip(d, -1.0, 1.0))
    sin_t = np.sin(theta)
    near = sin_t < 1e-6
    safe = np.where(near, 1.0, sin_t)
    w0 = np.where(near, 1.0 - t, np.sin((1.0 - t) * theta) / safe)
    w1 = np.where(near, t, np.sin(t * theta) / safe)
    q = w0 * q0 + w1 * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def euler_from_matrices(R: np.ndarray, order: str) -> np.ndarray:
    """Intrinsic Euler angles (radians) for an axis order such as ``"ZXY"``.

    ``R = R_a(angles[..., 0]) @ R_b(angles[..., 1]) @ R_c(angles[..., 2])`` for
    ``order = "abc"`` -- the BVH channel convention (rotations applied in the
    order the channels are listed, each about the already-rotated axes).
    Proper Euler orders (a repeated axis) are not supported.

    Parameters
    ----------
    R : array-like, shape (..., 3, 3)
    order : str
        Three distinct letters from ``XYZ``.

    Returns
    -------
    angles : ndarray, shape (..., 3)
    """
    a, b, c = (_EULER_AXES[ch] for ch in order.upper())
    if len({a, b, c}) != 3:
        raise ValueError(f"Euler order {order!r} must use three distinct axes")
    # parity: +1 for cyclic orders (XYZ, YZX, ZXY), -1 otherwise
    sign = 1.0 if (b - a) % 3 == 1 else -1.0
    R = np.asarray(R, dtype=float)
    # The first angle turns column c into the a-c plane; the other two are
    # read from what it leaves, N = R_a(t0).T @ R = R_b(t1) @ R_c(t2), rather
    # than each from R on its own. Near gimbal lock the first and last angles
    # then stay consistent with each other, so a matrix with rounding noise
    # (say from a quaternion) is rebuilt to ~1e-15, where angle-by-angle
    # formulas can be off by a large angle.
    t0 = np.arctan2(-sign * R[..., b, c], R[..., c, c])
    N = np.swapaxes(matrices_about_axis(a, t0), -1, -2) @ R
    t1 = np.arctan2(sign * N[..., a, c], N[..., c, c])
    t2 = np.arctan2(sign * N[..., b, a], N[..., b, b])
    return np.stack([t0, t1, t2], axis=-1)


def matrices_from_euler(angles: np.ndarray, order: str) -> np.ndarray:
    """Inverse of :func:`euler_from_matrices`.

    Parameters
    ----------
    angles : array-like, shape (..., 3)
        Radians, in the order of the letters of ``order``.
    order : str
        Three distinct letters from ``XYZ``, e.g. ``"ZXY"``.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
    """
    angles = np.asarray(angles, dtype=float)
    R = None
    for k, ch in enumerate(order.upper()):
        Rk = matrices_about_axis(_EULER_AXES[ch], angles[..., k])
        R = Rk if R is None else R @ Rk
    return R
