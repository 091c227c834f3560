"""The joints' angular velocities, speeds and accelerations of a motion, and the
interior angles of its hinges, compiled.

:func:`angular_figures` gives at once what
:func:`~quadsim.analysis.smoothness.angular_velocity_vectors`, its norms
(:func:`~quadsim.analysis.smoothness.angular_velocity`) and
:func:`~quadsim.analysis.smoothness.angular_acceleration` give, for the
report of a motion (:func:`quadsim.analysis.measure.measure_motion`): the
same numbers to the last bit, in a fraction of the time (NumPy's version
walks many strided temporary arrays).

To be the same numbers, the compiled loops do each operation of the NumPy
code in its order -- NumPy's own ``arctan2`` is called between them, and
its four- and three-term ``einsum`` dot products are summed as NumPy sums
them. That summation order is NumPy's implementation, not a promise: on
first use the compiled path is compared with the NumPy code on a probe of
random rotations (large and small steps, both signs), and where any number
differs in any bit the NumPy code is used instead (:func:`compiled_path`).
:func:`hinge_angles` is checked the same way.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["angular_figures", "compiled_path", "hinge_angles"]

_COMPILED: list[bool] = []  # [the compiled path gives NumPy's bits], once found
_HINGES_COMPILED: list[bool] = []  # the same of hinge_angles


@njit(cache=True)
def _steps(q, v, n, absw, neg):
    """Per joint and pair of frames: the change ``dq = q[t+1] conj(q[t])`` of the
    normalised quaternions, its vector part ``v``, its norm ``n``, ``|w|`` and w < 0."""
    T, J = q.shape[0], q.shape[1]
    qn = np.empty((T, J, 4))
    for t in range(T):
        for j in range(J):
            a0, a1, a2, a3 = q[t, j, 0], q[t, j, 1], q[t, j, 2], q[t, j, 3]
            r = np.sqrt((a0 * a0 + a2 * a2) + (a1 * a1 + a3 * a3))  # einsum's order
            qn[t, j, 0], qn[t, j, 1], qn[t, j, 2], qn[t, j, 3] = a0 / r, a1 / r, a2 / r, a3 / r
    for t in range(T - 1):
        for j in range(J):
            aw, ax, ay, az = qn[t, j, 0], qn[t, j, 1], qn[t, j, 2], qn[t, j, 3]
            bw, bx, by, bz = qn[t + 1, j, 0], qn[t + 1, j, 1], qn[t + 1, j, 2], qn[t + 1, j, 3]
            w = aw * bw + ax * bx + ay * by + az * bz
            v0 = aw * bx - bw * ax - (by * az - bz * ay)
            v1 = aw * by - bw * ay - (bz * ax - bx * az)
            v2 = aw * bz - bw * az - (bx * ay - by * ax)
            v[t, j, 0], v[t, j, 1], v[t, j, 2] = v0, v1, v2
            n[t, j] = np.sqrt((v0 * v0 + v2 * v2) + v1 * v1)  # einsum's order
            absw[t, j] = abs(w)
            neg[t, j] = w < 0


@njit(cache=True)
def _vectors(v, n, angle, neg, fps, omega, speed, accel):
    """``omega = v * angle / n * (+-fps)``, its norms, and the norms of its change
    between frames times ``fps``."""
    T1, J = v.shape[0], v.shape[1]
    for t in range(T1):
        for j in range(J):
            s = angle[t, j] / n[t, j] if n[t, j] > 1e-12 else 2.0
            s *= -fps if neg[t, j] else fps
            o0, o1, o2 = v[t, j, 0] * s, v[t, j, 1] * s, v[t, j, 2] * s
            omega[t, j, 0], omega[t, j, 1], omega[t, j, 2] = o0, o1, o2
            speed[t, j] = np.sqrt((o0 * o0 + o1 * o1) + o2 * o2)
    for t in range(T1 - 1):
        for j in range(J):
            d0 = omega[t + 1, j, 0] - omega[t, j, 0]
            d1 = omega[t + 1, j, 1] - omega[t, j, 1]
            d2 = omega[t + 1, j, 2] - omega[t, j, 2]
            accel[t, j] = np.sqrt((d0 * d0 + d1 * d1) + d2 * d2) * fps


def _compiled(q: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    q = np.ascontiguousarray(q, dtype=float)
    T, J = q.shape[0], q.shape[1]
    T1 = max(T - 1, 0)
    v, n, absw = np.empty((T1, J, 3)), np.empty((T1, J)), np.empty((T1, J))
    neg = np.empty((T1, J), dtype=np.bool_)
    _steps(q, v, n, absw, neg)
    angle = 2.0 * np.arctan2(n, absw)  # NumPy's arctan2, as the NumPy code
    omega, speed = np.empty((T1, J, 3)), np.empty((T1, J))
    accel = np.empty((max(T1 - 1, 0), J))
    _vectors(v, n, angle, neg, float(fps), omega, speed, accel)
    return omega, speed, accel


def _numpy(q: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    from quadsim.analysis.smoothness import angular_velocity_vectors

    omega = angular_velocity_vectors(q, fps)
    return (omega, np.linalg.norm(omega, axis=-1),
            np.linalg.norm(np.diff(omega, axis=0), axis=-1) * fps)


def compiled_path() -> bool:
    """Whether :func:`angular_figures` runs compiled: its numbers were found equal,
    bit for bit, to the NumPy code's on a probe (checked once a process)."""
    if not _COMPILED:
        rng = np.random.default_rng(20261202)
        q = rng.standard_normal((64, 8, 4))
        q[1::2] = q[0::2] + rng.standard_normal((32, 8, 4)) * rng.choice([1e-14, 1e-7, 1e-3, 0.1],
                                                                            (32, 8, 1))
        q[5:9] *= -1.0  # sign flips: the shorter way round
        q[20:22] = q[19]  # no change at all
        ok = True
        for fps in (60.0, 29.97):
            got, want = _compiled(q, fps), _numpy(q, fps)
            ok = ok and all(a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
                            for a, b in zip(got, want))
        _COMPILED.append(bool(ok))
    return _COMPILED[0]


def angular_figures(rotations, fps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Angular velocity vectors, speeds and accelerations of the joints.

    Parameters
    ----------
    rotations : array-like, shape (T, J, 4)
        Local quaternions ``(w, x, y, z)`` (normalised here), T >= 1.
    fps : float
        Frames per second.

    Returns
    -------
    omega : ndarray, shape (T - 1, J, 3)
        :func:`~quadsim.analysis.smoothness.angular_velocity_vectors` (rad/s).
    speed : ndarray, shape (T - 1, J)
        Its norms (rad/s).
    accel : ndarray, shape (T - 2, J)
        ``|omega[t + 1] - omega[t]| * fps`` (rad/s^2), as
        :func:`~quadsim.analysis.smoothness.angular_acceleration`.
    """
    q = np.asarray(rotations, dtype=float)
    fps = float(fps)
    if q.ndim != 3 or q.shape[-1] != 4 or len(q) < 2 or not compiled_path():
        return _numpy(q, fps)
    return _compiled(q, fps)


@njit(cache=True)
def _hinge_terms(P, p, j, c, cross_norm, dot):
    """Per pose and hinge, of the chords ``a = P[j] - P[p]`` and ``b = P[c] - P[j]``:
    ``|a x b|`` and ``a . b``, each summed as NumPy's ``norm`` and ``einsum`` sum."""
    for t in range(P.shape[0]):
        for h in range(p.shape[0]):
            a0 = P[t, j[h], 0] - P[t, p[h], 0]
            a1 = P[t, j[h], 1] - P[t, p[h], 1]
            a2 = P[t, j[h], 2] - P[t, p[h], 2]
            b0 = P[t, c[h], 0] - P[t, j[h], 0]
            b1 = P[t, c[h], 1] - P[t, j[h], 1]
            b2 = P[t, c[h], 2] - P[t, j[h], 2]
            c0 = a1 * b2 - a2 * b1  # np.cross's order
            c1 = a2 * b0 - a0 * b2
            c2 = a0 * b1 - a1 * b0
            cross_norm[t, h] = np.sqrt((c0 * c0 + c1 * c1) + c2 * c2)
            dot[t, h] = 0.0 + ((a0 * b0 + a2 * b2) + a1 * b1)  # einsum's zero is never -0


def _hinges_numpy(P, p, j, c) -> np.ndarray:
    a, b = P[..., j, :] - P[..., p, :], P[..., c, :] - P[..., j, :]
    return 180.0 - np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1),
                                         np.einsum("...i,...i->...", a, b)))


def _hinges_compiled(P, p, j, c) -> np.ndarray:
    lead = P.shape[:-2]
    flat = np.ascontiguousarray(P, dtype=float).reshape((-1,) + P.shape[-2:])
    n, d = np.empty((len(flat), len(p))), np.empty((len(flat), len(p)))
    idx = [np.asarray(x, dtype=np.int64) for x in (p, j, c)]
    _hinge_terms(flat, *idx, n, d)
    return (180.0 - np.degrees(np.arctan2(n, d))).reshape(lead + (len(p),))


def hinge_angles(P, parents, joints, children) -> np.ndarray:
    """Interior angle at each hinge joint between its two chords, in degrees.

    Parameters
    ----------
    P : array-like, shape (..., J, 3)
        Joint world positions (m).
    parents, joints, children : sequence of int, length H
        Each hinge's parent, joint and child.

    Returns
    -------
    ndarray, shape (..., H)
        ``180 - angle(P[joint] - P[parent], P[child] - P[joint])`` (degrees,
        180 straight), the numbers of the NumPy expression to the last bit.
    """
    P = np.asarray(P, dtype=float)
    if not _HINGES_COMPILED:
        rng = np.random.default_rng(20261203)
        probe = rng.standard_normal((50, 6, 3))
        probe[:5, 2] = probe[:5, 1]  # a chord of zero length
        probe[5:9, 3] = 2.0 * probe[5:9, 2] - probe[5:9, 1]  # straight: the cross is ~0
        hp, hj, hc = [0, 1, 2, 1], [1, 2, 3, 4], [2, 3, 4, 5]
        _HINGES_COMPILED.append(bool(np.array_equal(_hinges_compiled(probe, hp, hj, hc),
                                                     _hinges_numpy(probe, hp, hj, hc))))
    if _HINGES_COMPILED[0] and P.ndim >= 2 and P.size:
        return _hinges_compiled(P, parents, joints, children)
    return _hinges_numpy(P, list(parents), list(joints), list(children))
