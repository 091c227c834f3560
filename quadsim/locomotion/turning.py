"""Key-point turning: predicting the body's path on a commanded arc.

The seed (Su and Lu) turns a quadruped with *key points*: a point between
the feet of each girdle, rotated with the swing feet by the turn angle step
by step, that the first and last spine joints follow. Here each girdle's
key point is its centre on the ground; both advance along the arc the
commanded speed and yaw rate describe, the hind key point at the pelvis and
the fore one a body length ahead on the same arc. Swing feet are planned
about the key points' predicted positions and headings at touchdown, and
the spine bends by the heading difference between the two key points.

:func:`arc_step` and :func:`steer_rate` are the compiled forms the plan
runs; :func:`arc_advance` and :func:`turn_rate_towards` their faces for
arrays.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from quadsim.locomotion.rowmath import plan_inner

TWO_PI = 2.0 * math.pi


#: Proportional gain (1/s) of steering towards a commanded heading.
HEADING_GAIN = 2.0
#: Below this turn angle (rad) an arc is taken as its straight-line limit.
STRAIGHT_TURN = 1e-6


@plan_inner
def arc_step(heading, speed, yaw_rate, tau):
    """Move ``tau`` s along the arc of ``speed`` (m/s) and ``yaw_rate``
    (rad/s) from ``heading`` (rad): the ground displacement ``(dx, dz)`` (m)
    and the end heading (rad). The exact arc; its straight-line limit where
    the turn is below :data:`STRAIGHT_TURN`."""
    dh = yaw_rate * tau
    if abs(dh) < STRAIGHT_TURN:
        dx = speed * tau * math.sin(heading + 0.5 * dh)
        dz = speed * tau * math.cos(heading + 0.5 * dh)
    else:
        k = speed / yaw_rate
        dx = k * (math.cos(heading) - math.cos(heading + dh))
        dz = k * (math.sin(heading + dh) - math.sin(heading))
    return dx, dz, heading + dh


@plan_inner
def steer_rate(heading, target, max_rate, gain):
    """Yaw rate (rad/s) steering ``heading`` towards ``target`` (rad):
    ``gain`` (1/s) times the wrapped error, within ``max_rate``."""
    err = (target - heading + math.pi) % TWO_PI - math.pi
    return min(max(gain * err, -max_rate), max_rate)


@njit(cache=True)
def _arc_rows(p, h, v, w, tau, out, out_h):
    for n in range(p.shape[0]):
        dx, dz, he = arc_step(h[n], v[n], w[n], tau[n])
        out_h[n] = he
        out[n, 0] = p[n, 0] + dx
        out[n, 1] = p[n, 1] + 0.0
        out[n, 2] = p[n, 2] + dz


@njit(cache=True)
def _steer_rows(h, t, m, gain, out):
    for n in range(h.shape[0]):
        out[n] = steer_rate(h[n], t[n], m[n], gain)


def _rows(batch, x, tail=()):
    return np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), batch + tail)
                                ).reshape((-1,) + tail)


def arc_advance(position, heading, speed, yaw_rate, tau):
    """Position and heading after moving ``tau`` seconds along an arc
    (:func:`arc_step`, the feet stage's own, for arrays).

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
    batch = np.broadcast_shapes(np.shape(position)[:-1], np.shape(heading), np.shape(speed),
                                np.shape(yaw_rate), np.shape(tau))
    m = math.prod(batch)
    out, out_h = np.empty((m, 3)), np.empty(m)
    _arc_rows(_rows(batch, position, (3,)), _rows(batch, heading), _rows(batch, speed),
              _rows(batch, yaw_rate), _rows(batch, tau), out, out_h)
    return out.reshape(batch + (3,)), out_h.reshape(batch)


def turn_rate_towards(heading, target, max_rate, gain=HEADING_GAIN):
    """Yaw rate (rad/s) that steers ``heading`` towards ``target``
    (:func:`steer_rate`, the plan's own, for arrays).

    Proportional to the wrapped heading error with ``gain`` (1/s), capped at
    ``max_rate``.
    """
    batch = np.broadcast_shapes(np.shape(heading), np.shape(target), np.shape(max_rate))
    out = np.empty(math.prod(batch))
    _steer_rows(_rows(batch, heading), _rows(batch, target), _rows(batch, max_rate),
                float(gain), out)
    return out.reshape(batch)[()] if not batch else out.reshape(batch)


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
