"""The spine: compress/stretch in slow gaits, a concave/convex machine in fast ones.

Slow gaits (walk, trot, pace, amble, rack): the back flexes and extends a
little in step with the spine oscillator, which follows the legs.

Fast gaits (canter, gallops): the spine follows four states read from the
contact pattern (Su and Lu, figure 3; DESIGN.md):

============== ================= ======================
state          feet down         target
============== ================= ======================
double flight  none              theta_c (flexed)
front stance   fore only         theta_c
double stance  fore and hind     theta_v (extended)
back stance    hind only         theta_v
============== ================= ======================

The mid-spine angle moves towards its target at a bounded angular speed
``phi'`` and holds it once reached (the seed's equations 3-5: the error
``e_b = beta*_s - beta_s`` is the rotation still to do), then passes
through a short first-order filter so the motion has no velocity steps.

Angles are positive when the back arches (flexion).

The compiled functions (:func:`state_of`, :func:`target_of`,
:func:`rate_step`, :func:`flex_of`) are what the body stage
(:func:`quadsim.locomotion.body.body_rows`) runs; the array functions are
their faces for any batch shape.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from quadsim.locomotion.rowmath import plan_inner

DOUBLE_FLIGHT, FRONT_STANCE, DOUBLE_STANCE, BACK_STANCE = range(4)
STATE_NAMES = ("double flight", "front stance", "double stance", "back stance")


@plan_inner
def state_of(fore_down, hind_down):
    """State index from whether any fore / hind foot is down."""
    if fore_down:
        return DOUBLE_STANCE if hind_down else FRONT_STANCE
    return BACK_STANCE if hind_down else DOUBLE_FLIGHT


@plan_inner
def target_of(state, flexed, extended):
    """``flexed`` (theta_c) in double flight and front stance, else ``extended`` (theta_v)."""
    return flexed if (state == DOUBLE_FLIGHT or state == FRONT_STANCE) else extended


@plan_inner
def rate_step(angle, target, max_rate, dt):
    """One step of the bounded-speed approach: move at most ``max_rate * dt``
    (the error ``target - angle`` is the rotation still to do)."""
    return angle + min(max(target - angle, -max_rate * dt), max_rate * dt)


@plan_inner
def flex_of(theta_s, amplitude):
    """Compress/stretch angle of the slow gaits from the spine oscillator phase."""
    return amplitude * math.sin(theta_s)


@njit(cache=True)
def _state_rows(fore, hind, out):
    for n in range(out.shape[0]):
        out[n] = state_of(fore[n], hind[n])


@njit(cache=True)
def _target_rows(state, flexed, extended, out):
    for n in range(out.shape[0]):
        out[n] = target_of(state[n], flexed[n], extended[n])


@njit(cache=True)
def _rate_rows(angle, target, max_rate, dt, out):
    for n in range(out.shape[0]):
        out[n] = rate_step(angle[n], target[n], max_rate[n], dt[n])


@njit(cache=True)
def _flex_rows(theta_s, amplitude, out):
    for n in range(out.shape[0]):
        out[n] = flex_of(theta_s[n], amplitude[n])


def _each(kernel, dtype, *args):
    """``kernel`` over the broadcast of ``args`` (flattened), shaped back."""
    arrs = np.broadcast_arrays(*(np.asarray(a) for a in args))
    batch = arrs[0].shape
    flat = [np.ascontiguousarray(a).reshape(-1) for a in arrs]
    out = np.empty(flat[0].shape[0], dtype=dtype)
    kernel(*flat, out)
    return out.reshape(batch)[()] if not batch else out.reshape(batch)


def spine_state(fore_down, hind_down):
    """State index from whether any fore / hind foot is down (arrays of bool)."""
    return _each(_state_rows, np.int64, np.asarray(fore_down, dtype=bool),
                 np.asarray(hind_down, dtype=bool))


def spine_target(state, flexed, extended):
    """``theta_c`` for double flight and front stance, ``theta_v`` otherwise."""
    return _each(_target_rows, float, np.asarray(state, dtype=np.int64),
                 np.asarray(flexed, dtype=float), np.asarray(extended, dtype=float))


def rate_limited(angle, target, max_rate, dt):
    """One step of the bounded-speed approach: move at most ``max_rate * dt``."""
    return _each(_rate_rows, float, *(np.asarray(x, dtype=float)
                                      for x in (angle, target, max_rate, dt)))


def flex_angle(theta_s, amplitude):
    """Compress/stretch angle of the slow gaits from the spine oscillator phase."""
    return _each(_flex_rows, float, np.asarray(theta_s, dtype=float),
                 np.asarray(amplitude, dtype=float))
