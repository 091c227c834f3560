"""Batched rotation conversions.

Quaternions are stored as ``(w, x, y, z)`` (scalar first, the transforms3d
order). Rotation matrices act on column vectors: ``v_world = R @ v_local``.
Every function takes any leading batch shape. The quaternion conversions
and slerp run as compiled loops over the batch; their one-item forms
(:func:`matrix_from_quaternion`, :func:`quaternion_from_matrix`,
:func:`slerp_one`) are what compiled code elsewhere calls per joint.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

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


def _rows(x: np.ndarray, item: tuple) -> np.ndarray:
    """``x`` as a writeable C-contiguous float array of rows of shape ``item`` (a copy
    only when needed: the compiled loops then see one array type)."""
    return np.require(np.reshape(x, (-1,) + item), dtype=float, requirements=["C", "W"])


def matrices_from_quaternions(q: np.ndarray) -> np.ndarray:
    """Rotation matrices from unit quaternions ``(w, x, y, z)``.

    Parameters
    ----------
    q : array-like, shape (..., 4)
        Normalised here.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
    """
    q = np.asarray(q, dtype=float)
    flat = _rows(q, (4,))
    R = np.empty((len(flat), 3, 3))
    _matrices_rows(flat, R)
    return R.reshape(q.shape[:-1] + (3, 3))


@njit(cache=True, inline="always")  # inlined: 4x faster in a caller's loop
def matrix_from_quaternion(q, M):
    """``M`` (3, 3) = the rotation of the quaternion ``q`` (4,) ``(w, x, y, z)``, normalised."""
    n = 1.0 / math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    w, x, y, z = q[0] * n, q[1] * n, q[2] * n, q[3] * n
    M[0, 0] = 1 - 2 * (y * y + z * z)
    M[0, 1] = 2 * (x * y - z * w)
    M[0, 2] = 2 * (x * z + y * w)
    M[1, 0] = 2 * (x * y + z * w)
    M[1, 1] = 1 - 2 * (x * x + z * z)
    M[1, 2] = 2 * (y * z - x * w)
    M[2, 0] = 2 * (x * z - y * w)
    M[2, 1] = 2 * (y * z + x * w)
    M[2, 2] = 1 - 2 * (x * x + y * y)


@njit(cache=True)
def _matrices_rows(q, R):
    for i in range(q.shape[0]):
        matrix_from_quaternion(q[i], R[i])


def quaternions_from_matrices(R: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(w, x, y, z)`` with ``w >= 0`` from rotation matrices.

    Uses the numerically stable branch on the largest of the trace and the
    diagonal terms (:func:`quaternion_from_matrix`).

    Parameters
    ----------
    R : array-like, shape (..., 3, 3)

    Returns
    -------
    q : ndarray, shape (..., 4)
    """
    R = np.asarray(R, dtype=float)
    flat = _rows(R, (3, 3))
    q = np.empty((len(flat), 4))
    _quaternions_rows(flat, q)
    return q.reshape(R.shape[:-2] + (4,))


@njit(cache=True, inline="always")  # inlined: 4x faster in a caller's loop
def quaternion_from_matrix(R, q):
    """``q`` (4,) = the unit quaternion, ``w >= 0``, of the rotation matrix ``R`` (3, 3)."""
    m00, m11, m22 = R[0, 0], R[1, 1], R[2, 2]
    tr = m00 + m11 + m22
    k = 0
    best = tr
    if m00 > best:
        k, best = 1, m00
    if m11 > best:
        k, best = 2, m11
    if m22 > best:
        k = 3
    if k == 0:
        s = math.sqrt(max(1.0 + tr, 1e-300)) * 2
        i = 1.0 / s  # one division, then products (4x faster than four)
        w, x, y, z = 0.25 * s, (R[2, 1] - R[1, 2]) * i, (R[0, 2] - R[2, 0]) * i, \
            (R[1, 0] - R[0, 1]) * i
    elif k == 1:
        s = math.sqrt(max(1.0 + m00 - m11 - m22, 1e-300)) * 2
        i = 1.0 / s
        w, x, y, z = (R[2, 1] - R[1, 2]) * i, 0.25 * s, (R[0, 1] + R[1, 0]) * i, \
            (R[0, 2] + R[2, 0]) * i
    elif k == 2:
        s = math.sqrt(max(1.0 - m00 + m11 - m22, 1e-300)) * 2
        i = 1.0 / s
        w, x, y, z = (R[0, 2] - R[2, 0]) * i, (R[0, 1] + R[1, 0]) * i, 0.25 * s, \
            (R[1, 2] + R[2, 1]) * i
    else:
        s = math.sqrt(max(1.0 - m00 - m11 + m22, 1e-300)) * 2
        i = 1.0 / s
        w, x, y, z = (R[1, 0] - R[0, 1]) * i, (R[0, 2] + R[2, 0]) * i, \
            (R[1, 2] + R[2, 1]) * i, 0.25 * s
    n = 1.0 / math.sqrt(w * w + x * x + y * y + z * z)
    if w < 0.0:
        n = -n
    q[0], q[1], q[2], q[3] = w * n, x * n, y * n, z * n


@njit(cache=True)
def _quaternions_rows(R, q):
    for i in range(R.shape[0]):
        quaternion_from_matrix(R[i], q[i])


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
        Normalised; where the two are within 1e-6 rad of each other, the
        normalised linear blend (:func:`slerp_one`).
    """
    q0 = np.asarray(q0, dtype=float)
    q1 = np.asarray(q1, dtype=float)
    t = np.asarray(t, dtype=float)
    shape = np.broadcast_shapes(q0.shape, q1.shape, t.shape + (4,))
    a = _rows(np.broadcast_to(q0, shape), (4,))
    b = _rows(np.broadcast_to(q1, shape), (4,))
    out = np.empty_like(a)
    _slerp_rows(a, b, _rows(np.broadcast_to(t, shape[:-1]), ()), out)
    return out.reshape(shape)


@njit(cache=True)
def slerp_one(q0, q1, a, out):
    """``out`` (4,) = shortest-path slerp of the quaternions ``q0`` and ``q1`` at ``a``.

    ``out`` may be ``q0`` (each component is read before it is written).
    """
    d = q0[0] * q1[0] + q0[1] * q1[1] + q0[2] * q1[2] + q0[3] * q1[3]
    sign = -1.0 if d < 0.0 else 1.0
    theta = math.acos(min(abs(d), 1.0))
    s = math.sin(theta)
    if s < 1e-6:
        w0 = 1.0 - a
        w1 = a
    else:
        w0 = math.sin((1.0 - a) * theta) / s
        w1 = math.sin(a * theta) / s
    w1 *= sign
    n = 0.0
    for c in range(4):
        v = w0 * q0[c] + w1 * q1[c]
        out[c] = v
        n += v * v
    n = math.sqrt(n)
    for c in range(4):
        out[c] /= n


@njit(cache=True)
def _slerp_rows(q0, q1, t, out):
    for i in range(q0.shape[0]):
        slerp_one(q0[i], q1[i], t[i], out[i])


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
