"""Key-point turning: predicting the body's path on a commanded arc.

The seed (Su and Lu) turns a quadruped with *key points*: a point between
the feet of each girdle, rotated with the swing feet by the turn angle step
by step, that the first and last spine joints follow. Here each girdle's
key point is its centre on the ground; both advance along the arc the
commanded speed and yaw rate describe, the hind key point at the pelvis and
the fore one a body length ahead on the same arc. Swing feet are planned
about the key points' predicted positions and headings at touchdown, and
the spine bends by the heading difference between the two key points.
"""

from __future__ import annotations

import numpy as np

from quadsim.frames import wrap_angle


def arc_advance(position, heading, speed, yaw_rate, tau):
    """Position and heading after moving ``tau`` seconds along an arc.

    Parameters
    ----------
    position : array-like, shape (..., 3)
        Start point on the ground (m).
    heading : array-like, shape (...)
        Start heading (rad).
    speed : array-like, shape (...)
        Forward speed (m/s).
    yaw_rate : array-like, shape (...)
        Turn rate (rad/s), positive left.
    tau : array-like, shape (...)
        Time ahead (s).

    Returns
    -------
    position : ndarray, shape (..., 3)
    heading : ndarray, shape (...)
    """
    p = np.asarray(position, dtype=float)
    h = np.asarray(heading, dtype=float)
    v = np.asarray(speed, dtype=float)
    w = np.asarray(yaw_rate, dtype=float)
    tau = np.asarray(tau, dtype=float)
    dh = w * tau
    straight = np.abs(dh) < 1e-6
    safe_w = np.where(straight, 1.0, w)
    # exact arc; its straight-line limit where the turn is negligible
    dx = np.where(straight, v * tau * np.sin(h + 0.5 * dh),
                  (v / safe_w) * (np.cos(h) - np.cos(h + dh)))
    dz = np.where(straight, v * tau * np.cos(h + 0.5 * dh),
                  (v / safe_w) * (np.sin(h + dh) - np.sin(h)))
    out = p.copy() if p.ndim else p
    out = out + np.stack([dx, np.zeros_like(dx), dz], axis=-1)
    return out, h + dh


def turn_rate_towards(heading, target, max_rate, gain=2.0):
    """Yaw rate (rad/s) that steers ``heading`` towards ``target``.

    Proportional to the wrapped heading error with ``gain`` (1/s), capped at
    ``max_rate``.
    """
    err = wrap_angle(np.asarray(target) - np.asarray(heading))
    return np.clip(gain * err, -max_rate, max_rate)


def rotate_y(vectors, angle):
    """Rotate ``(..., 3)`` vectors about +Y by ``angle`` (rad)."""
    v = np.asarray(vectors, dtype=float)
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    out = np.empty(np.broadcast_shapes(v.shape, a.shape + (3,)))
    v0, v2 = v[..., 0], v[..., 2]
    out[..., 0] = c * v0 + s * v2
    out[..., 1] = v[..., 1]
    out[..., 2] = -s * v0 + c * v2
    return out
