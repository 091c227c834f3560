"""Leg placement for clip editing: analytic two-bone IK that keeps the lower leg.

:func:`place_feet` turns each leg's two-bone pair (the character's IK joint
and the joint below it) so that the foot joint reaches a target, leaving the
joints above the pair and the bones below its middle joint as they were -- the
clip's pastern and hoof angles survive the edit. :func:`pin_stance` uses it to
hold every foot still, on the ground, through each of its contacts.
"""

from __future__ import annotations

import numpy as np

from ..kinematics.rotations import matrices_from_axis_angles, quaternions_from_matrices
from ..skeleton.character import Character
from ..skeleton.motion import Motion

LATERAL = np.array([1.0, 0.0, 0.0])


def place_feet(character: Character, motion: Motion, targets, legs=(0, 1, 2, 3)) -> np.ndarray:
    """Local rotations putting each foot on its target.

    Parameters
    ----------
    character : Character
    motion : Motion
        The motion to edit (root positions and rotations), T frames.
    targets : array-like, shape (T, 4, 3)
        World position wanted for each foot joint (m), leg order LF, RF, LH, RH.
    legs : sequence of int
        The legs to move; the others keep their rotations.

    Returns
    -------
    rotations : ndarray, shape (T, J, 4)
        Unreachable targets are approached as far as the pair allows.
    """
    targets = np.asarray(targets, dtype=float)
    skel = motion.skeleton
    Wr = motion.world_rotations()
    Wp = motion.world_positions()
    local = np.array(motion.local_matrices)
    for i in legs:
        leg = character.legs[i]
        top = int(leg.chain[leg.ik_start])
        mid = int(leg.chain[leg.ik_start + 1])
        A, B, F = Wp[:, top], Wp[:, mid], Wp[:, leg.foot]
        tgt = targets[:, i]
        u, w = A - B, F - B
        l1 = np.linalg.norm(u, axis=-1)
        l2 = np.linalg.norm(w, axis=-1)
        d = np.clip(np.linalg.norm(tgt - A, axis=-1), np.abs(l1 - l2) + 1e-6, l1 + l2 - 1e-6)
        n = np.cross(u, w)
        nn = np.linalg.norm(n, axis=-1, keepdims=True)
        n = np.where(nn > 1e-9, n / np.maximum(nn, 1e-12), LATERAL)
        beta0 = np.arccos(np.clip(np.sum(u * w, -1) / (l1 * l2), -1.0, 1.0))
        beta1 = np.arccos(np.clip((l1 ** 2 + l2 ** 2 - d ** 2) / (2 * l1 * l2), -1.0, 1.0))
        Rm = matrices_from_axis_angles(n, beta1 - beta0)
        a = np.einsum("tij,tj->ti", Rm, w) + B - A
        b = tgt - A
        a = a / np.linalg.norm(a, axis=-1, keepdims=True)
        b = b / np.maximum(np.linalg.norm(b, axis=-1, keepdims=True), 1e-12)
        ax = np.cross(a, b)
        s = np.linalg.norm(ax, axis=-1)
        ang = np.arctan2(s, np.sum(a * b, -1))
        ax = np.where(s[:, None] > 1e-12, ax / np.maximum(s, 1e-12)[:, None], n)
        Rs = matrices_from_axis_angles(ax, ang)
        Wtop = Rs @ Wr[:, top]
        Wmid = Rs @ Rm @ Wr[:, mid]
        local[:, top] = np.swapaxes(Wr[:, skel.parents[top]], -1, -2) @ Wtop
        local[:, mid] = np.swapaxes(Wtop, -1, -2) @ Wmid
    return quaternions_from_matrices(local)


def stance_targets(feet: np.ndarray, contacts: np.ndarray, ground: float = 0.0) -> np.ndarray:
    """Foot targets holding each contact still at its first frame's place, on the ground.

    Parameters
    ----------
    feet : ndarray, shape (T, 4, 3)
    contacts : ndarray of bool, shape (T, 4)
    ground : float

    Returns
    -------
    targets : ndarray, shape (T, 4, 3)
        ``feet`` outside contacts.
    """
    tgt = np.array(feet, dtype=float)
    for i in range(4):
        c = contacts[:, i]
        if not c.any():
            continue
        edges = np.diff(np.concatenate([[0], c.astype(int), [0]]))
        starts, ends = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
        for s, e in zip(starts, ends):
            mid = (s + e - 1) // 2
            tgt[s:e, i, 0] = feet[mid, i, 0]
            tgt[s:e, i, 2] = feet[mid, i, 2]
            tgt[s:e, i, 1] = ground + max(0.0, float(np.min(feet[s:e, i, 1]) - ground))
    return tgt


def pin_stance(character: Character, motion: Motion, contacts, ground: float = 0.0) -> Motion:
    """The motion with every foot held still through each of its contacts."""
    contacts = np.asarray(contacts, dtype=bool)
    tgt = stance_targets(motion.foot_positions(), contacts, ground)
    rot = place_feet(character, motion, tgt)
    return Motion(motion.skeleton, motion.fps, motion.root_positions, rot,
                  foot_joints=motion.foot_joints)


__all__ = ["pin_stance", "place_feet", "stance_targets"]
