"""The data-driven horse's ground, compiled: the ramp field's height, a toe put onto it.

The ground is the ramp table of :attr:`Ground.table <quadsim.horse.slope.Ground.table>`,
(R, 6): origin x, z, height, direction x, z and ``tan(slope)`` of each ramp,
oldest first (:func:`ground_height`). :func:`toe_onto_ground` pitches a
striking foot so that its toe tip is not below it (the placement,
:mod:`.place_kernel`, holds that attitude through the stance).
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["MAX_TURN", "SETTLE_TURN", "TOE_DEPTH", "ground_height", "ground_heights",
           "toe_onto_ground"]

#: A striking toe tip deeper than this under the ground (m) is raised towards it, no
#: higher: the smallest turn of the hoof.
TOE_DEPTH = 0.002
#: ... by a turn of at most this (rad) in its striking frame, and of at most
#: :data:`SETTLE_TURN` a frame after it while planted: a turn in one frame costs about
#: itself times the frame rate squared of angular acceleration. Hooves landing on the
#: level after a descent (tests/test_horse_smoothness.py, at most 1.5x the clip's
#: acceleration plus 15.7 rad/s^2) turned at 223.6 rad/s^2 against a bound of 214.7 with
#: 0.026 at the strike alone, at 228.9 with 0.022 and a quarter of it after; at 0.018
#: and a quarter, gait changes' toe tips reach 3.1 mm under the ground at most (4.9
#: without the turn).
MAX_TURN = 0.018
SETTLE_TURN = 0.25 * MAX_TURN  #: (rad a frame)


@njit(cache=True)
def ground_height(ramps, x, z):
    """Height (m) of the ramp field at the horizontal point ``(x, z)``: the
    newest ramp whose half-plane holds the point, else 0."""
    h = 0.0
    for r in range(ramps.shape[0]):
        s = (x - ramps[r, 0]) * ramps[r, 3] + (z - ramps[r, 1]) * ramps[r, 4]
        if s >= 0.0:
            h = ramps[r, 2] + ramps[r, 5] * s
    return h


@njit(cache=True)
def ground_heights(ramps, xz, out):
    """:func:`ground_height` of many points: ``xz`` (n, 2) horizontal points (m),
    ``out`` (n,) their heights (m)."""
    for k in range(xz.shape[0]):
        out[k] = ground_height(ramps, xz[k, 0], xz[k, 1])


@njit(cache=True)
def toe_onto_ground(Gf, Pf, toe, ramps, W, max_turn=MAX_TURN):
    """``W`` (3, 3) = the foot's world rotation ``Gf``, pitched about the foot joint
    (at ``Pf``, m) just enough that its toe tip (``toe`` in the foot's frame, m) is
    at most :data:`TOE_DEPTH` below the ground under it (turning at most
    ``max_turn``, rad): the toe's vector turned in its vertical plane,
    its length kept. A gait change's blended pose can strike with the hoof tipped
    forward, which the held attitude then kept through the stance: the toe tip
    4-5 mm under the ground from touchdown to lift-off (gallop -> amble or trot).
    Returns whether it turned (``W`` is ``Gf`` otherwise); ``W`` may be ``Gf``."""
    dx = Gf[0, 0] * toe[0] + Gf[0, 1] * toe[1] + Gf[0, 2] * toe[2]
    dy = Gf[1, 0] * toe[0] + Gf[1, 1] * toe[1] + Gf[1, 2] * toe[2]
    dz = Gf[2, 0] * toe[0] + Gf[2, 1] * toe[1] + Gf[2, 2] * toe[2]
    for r in range(3):
        for c in range(3):
            W[r, c] = Gf[r, c]
    r2 = dx * dx + dy * dy + dz * dz
    want = ground_height(ramps, Pf[0] + dx, Pf[2] + dz) - Pf[1] - TOE_DEPTH
    hl = math.sqrt(dx * dx + dz * dz)
    if dy >= want or r2 <= 0.0 or hl <= 0.0 or want * want >= r2:
        return False
    scale = math.sqrt(r2 - want * want) / hl
    # the ground again under where the toe goes (on a ramp it has moved along it)
    want = ground_height(ramps, Pf[0] + dx * scale, Pf[2] + dz * scale) - Pf[1] - TOE_DEPTH
    if dy >= want or want * want >= r2:
        return False
    scale = math.sqrt(r2 - want * want) / hl
    ex, ey, ez = dx * scale, want, dz * scale
    # the turn from d to e: about d x e by the angle between them (Rodrigues)
    ax, ay, az = dy * ez - dz * ey, dz * ex - dx * ez, dx * ey - dy * ex
    s = math.sqrt(ax * ax + ay * ay + az * az)
    if s <= 0.0:
        return False
    c = (dx * ex + dy * ey + dz * ez) / r2
    sn = s / r2
    if math.atan2(sn, c) > max_turn:
        c, sn = math.cos(max_turn), math.sin(max_turn)
    ax, ay, az = ax / s, ay / s, az / s
    t = 1.0 - c
    R00, R01, R02 = c + ax * ax * t, ax * ay * t - az * sn, ax * az * t + ay * sn
    R10, R11, R12 = ay * ax * t + az * sn, c + ay * ay * t, ay * az * t - ax * sn
    R20, R21, R22 = az * ax * t - ay * sn, az * ay * t + ax * sn, c + az * az * t
    for k in range(3):
        g0, g1, g2 = Gf[0, k], Gf[1, k], Gf[2, k]
        W[0, k] = R00 * g0 + R01 * g1 + R02 * g2
        W[1, k] = R10 * g0 + R11 * g1 + R12 * g2
        W[2, k] = R20 * g0 + R21 * g1 + R22 * g2
    return True
