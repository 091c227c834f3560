"""Smoothness measured from local joint rotations: angular velocity and acceleration.

Quaternions are ``(w, x, y, z)``, motions ``(T, J, 4)``; rates are per
second at the motion's frame rate.
"""

from __future__ import annotations

import numpy as np

from quadsim.skeleton.contacts import _check_fps

__all__ = ["angular_acceleration", "angular_velocity", "angular_velocity_vectors"]


def _quaternions_fps(motion, fps) -> tuple[np.ndarray, float]:
    if hasattr(motion, "rotations") and hasattr(motion, "fps"):
        q, fps = motion.rotations, motion.fps if fps is None else fps
    else:
        q = motion
        if fps is None:
            raise ValueError("`fps` is required when rotations are given as an array")
    q = np.asarray(q, dtype=float)
    if q.ndim < 2 or q.shape[-1] != 4:
        raise ValueError(f"`rotations` has shape {q.shape}, expected (T, J, 4)")
    return q, _check_fps(fps)


def angular_velocity_vectors(motion, fps: float | None = None) -> np.ndarray:
    """Angular velocity of each joint relative to its parent, as vectors.

    Between frames t and t+1 the local rotation changes by
    ``dq = q[t+1] * conj(q[t])`` (expressed in the parent's frame); the vector
    is its axis times its angle (the shorter way round) times ``fps``.

    Parameters
    ----------
    motion : Motion or array-like, shape (T, J, 4)
        A motion, or local quaternions ``(w, x, y, z)``.
    fps : float, optional
        Required with an array; overrides the motion's.

    Returns
    -------
    omega : ndarray, shape (T - 1, J, 3)
        rad/s.
    """
    q, fps = _quaternions_fps(motion, fps)
    q = q / np.sqrt(np.einsum("...i,...i->...", q, q))[..., None]
    aw, ax, ay, az = np.moveaxis(q[:-1], -1, 0)
    bw, bx, by, bz = np.moveaxis(q[1:], -1, 0)
    # dq = b * conj(a) = (w, v)
    w = aw * bw + ax * bx + ay * by + az * bz
    v = np.stack([aw * bx - bw * ax - (by * az - bz * ay),
                  aw * by - bw * ay - (bz * ax - bx * az),
                  aw * bz - bw * az - (bx * ay - by * ax)], axis=-1)
    n = np.sqrt(np.einsum("...i,...i->...", v, v))
    angle = 2.0 * np.arctan2(n, np.abs(w))           # the shorter way round
    scale = np.divide(angle, n, out=np.full_like(n, 2.0), where=n > 1e-12)
    scale *= np.where(w < 0, -fps, fps)
    return v * scale[..., None]


def angular_velocity(motion, fps: float | None = None) -> np.ndarray:
    """Local angular speed of each joint between consecutive frames.

    ``2 arccos(|<q_t, q_t+1>|) * fps``, computed stably as the norm of
    :func:`angular_velocity_vectors`.

    Returns
    -------
    speed : ndarray, shape (T - 1, J)
        rad/s.
    """
    return np.linalg.norm(angular_velocity_vectors(motion, fps), axis=-1)


def angular_acceleration(motion, fps: float | None = None) -> np.ndarray:
    """Magnitude of the change of each joint's angular velocity vector.

    ``|omega[t+1] - omega[t]| * fps`` with the vectors of
    :func:`angular_velocity_vectors`, so a joint that reverses its swing shows
    up even when its angular speed does not change.

    Returns
    -------
    accel : ndarray, shape (T - 2, J)
        rad/s^2.
    """
    q, fps = _quaternions_fps(motion, fps)
    w = angular_velocity_vectors(q, fps)
    return np.linalg.norm(np.diff(w, axis=0), axis=-1) * fps
