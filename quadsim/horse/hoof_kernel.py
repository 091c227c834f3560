"""The data-driven horse's hooves in swing, compiled: the tuck its clips are baked without.

The horse's clips are baked from the procedural horse with its hooves untucked
(``tools/bake_horse_clips.py``: played slower than it was baked, a tucked hoof's toe
dipped into the ground). :func:`tuck_hooves` tucks a swinging hoof at playback, on
the placed pose, by the procedural leg IK's carry
(:func:`~quadsim.kinematics.legs.leg_geometry`'s ``carry``, ``[locomotion]
digit_flex_deg``): as far as the clip's own swing folds the digit and as far as the
foot's target is up, so a hoof near the ground is not turned toe down into it.
The rig's ``tuck_joints``, ``tuck_turns`` and ``tuck_scales``
(:class:`~quadsim.horse.bundles.PlaceRig`) describe each leg's digit; angles in
radians, lengths in metres.
"""

from __future__ import annotations

import math

from numba import njit

from ..kinematics.chains import mul_into
from .ground_kernel import ground_height


@njit(cache=True, inline="always")
def tuck_hooves(rig, ramps, tgt, contacts, L, G, P):
    """A swinging hoof tucks up behind its cannon as the procedural horse's does
    (``L`` of the digits' joints updated): the clips are baked untucked, so the
    digit is turned here by the procedural IK's carry, in proportion to the swing's
    fold read from the clip's own first digit joint and to how far the foot's target
    is up (fully from the rig's tuck height, none on the ground: a tucked hoof
    hangs its toe below its joint, and a clip played slower than it was baked
    brings the hoof lower in its swing). Run on the placed pose, the feet's held
    attitudes settled: a lifting hoof eased from its planted attitude is carried by
    the digit's turn; the world rotations ``G`` (J, 3, 3) and positions ``P`` (J, 3)
    of the turned digits and of the joints below their feet are updated."""
    parents, offsets = rig.parents, rig.offsets
    for i in range(4):
        j0 = rig.tuck_joints[i, 0]
        if j0 < 0 or contacts[i]:
            continue
        per_fold, full_height, standing = (rig.tuck_scales[i, 0], rig.tuck_scales[i, 1],
                                           rig.tuck_scales[i, 2])
        fold = math.atan2(L[j0, 2, 1], L[j0, 1, 1]) / per_fold
        up = (tgt[i, 1] - ground_height(ramps, tgt[i, 0], tgt[i, 2]) - standing) / full_height
        f = min(max(fold, 0.0), 1.0) * min(max(up, 0.0), 1.0)
        if f <= 0.0:
            continue
        for m in range(rig.tuck_joints.shape[1]):
            j = rig.tuck_joints[i, m]
            if j < 0:
                break
            c, s = math.cos(rig.tuck_turns[i, m] * f), math.sin(rig.tuck_turns[i, m] * f)
            for r in range(3):  # L_j R_x(turn f)
                a1, a2 = L[j, r, 1], L[j, r, 2]
                L[j, r, 1] = c * a1 + s * a2
                L[j, r, 2] = c * a2 - s * a1
            if m > 0:  # the digit's joints below its first move with it
                _follow(parents, offsets, G, P, j)
            mul_into(G[parents[j]], L[j], G[j])
        for m in range(rig.below.shape[1]):  # and so do the joints below the foot
            j = rig.below[i, m]
            if j < 0:
                break
            _follow(parents, offsets, G, P, j)
            mul_into(G[parents[j]], L[j], G[j])


@njit(cache=True, inline="always")
def _follow(parents, offsets, G, P, j):
    """Joint ``j``'s world position from its parent's (``P`` updated)."""
    p = parents[j]
    for r in range(3):
        P[j, r] = P[p, r] + G[p, r, 0] * offsets[j, 0] + G[p, r, 1] * offsets[j, 1] \
            + G[p, r, 2] * offsets[j, 2]
