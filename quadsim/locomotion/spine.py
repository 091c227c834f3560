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
"""

from __future__ import annotations

import numpy as np

DOUBLE_FLIGHT, FRONT_STANCE, DOUBLE_STANCE, BACK_STANCE = range(4)
STATE_NAMES = ("double flight", "front stance", "double stance", "back stance")


def spine_state(fore_down, hind_down):
    """State index from whether any fore / hind foot is down (arrays of bool)."""
    fore = np.asarray(fore_down, dtype=bool)
    hind = np.asarray(hind_down, dtype=bool)
    return np.where(fore, np.where(hind, DOUBLE_STANCE, FRONT_STANCE),
                    np.where(hind, BACK_STANCE, DOUBLE_FLIGHT))


def spine_target(state, flexed, extended):
    """``theta_c`` for double flight and front stance, ``theta_v`` otherwise."""
    state = np.asarray(state)
    return np.where((state == DOUBLE_FLIGHT) | (state == FRONT_STANCE), flexed, extended)


def rate_limited(angle, target, max_rate, dt):
    """One step of the bounded-speed approach: move at most ``max_rate * dt``."""
    err = np.asarray(target) - np.asarray(angle)  # e_b, the rotation still to do
    step = np.clip(err, -max_rate * dt, max_rate * dt)
    return angle + step


def flex_angle(theta_s, amplitude):
    """Compress/stretch angle of the slow gaits from the spine oscillator phase."""
    return amplitude * np.sin(np.asarray(theta_s))
