"""Leg placement for clip editing: analytic two-bone IK that keeps the lower leg.

:func:`place_feet` turns each leg's two-bone pair (the character's IK joint
and the joint below it) so that the foot joint reaches a target, leaving the
joints above the pair and the bones below its middle joint as they were -- the
clip's pastern and hoof angles survive the edit. The IK itself is
:func:`two_bone`, batched over any leading axes, each item the one compiled
two-bone step :func:`quadsim.kinematics.chains.two_bone_row` that the frame
loops of :func:`place_feet` and of the data-driven controller run.
:func:`pin_stance` uses it to hold every foot still, on the ground, through
each of its contacts: at the contact's middle (looped clips) or where the
foot landed (edited motion such as a gait transition, the swing easing onto
and off the held place, :func:`stance_targets`). :func:`reach_drop` says how
far the root must come down for a held foot beyond its leg's reach.
"""

from __future__ import annotations

import numpy as np

from ..kinematics.chains import two_bone_rows
from ..kinematics.rotations import quaternions_from_matrices
from ..skeleton.character import Character
from ..skeleton.motion import Motion
from .place_kernel import place_feet_rows



def two_bone(A: np.ndarray, B: np.ndarray, F: np.ndarray, W_parent: np.ndarray,
             W_top: np.ndarray, W_mid: np.ndarray, targets: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
    """Analytic two-bone IK: local rotations of a pair's two joints putting the foot on a target.

    The middle joint bends about the pair's plane normal until the top-to-foot
    distance is the top-to-target distance (clamped to what the bones
    reach), then the top joint swings the whole pair onto the target. The
    bones below the middle joint keep their local angles. The arrays
    broadcast over their leading axes (frames, legs, or both), so one call
    moves any batch; each item is the compiled
    :func:`quadsim.kinematics.chains.two_bone_row`, the one the controller runs.

    Parameters
    ----------
    A, B, F : ndarray, shape (..., 3)
        World positions of the top joint, the middle joint and the foot (m).
    W_parent : ndarray, shape (..., 3, 3)
        World rotation of the top joint's parent.
    W_top, W_mid : ndarray, shape (..., 3, 3)
        World rotations of the top and middle joints.
    targets : ndarray, shape (..., 3)
        Wanted foot positions (m); unreachable ones are approached as far as the pair allows.

    Returns
    -------
    L_top, L_mid : ndarray, shape (..., 3, 3)
        New local rotations of the top and middle joints.

    Notes
    -----
    The pair bends about the normal of the top-middle-foot plane, on the side
    the pose bends to. A pose passing through straight (a fore leg reaching
    forward in its swing) flips that side: where the target then asks for
    another bend than the pose's, the result jumps by twice the change of bend,
    so callers keep such targets at the pose's own distance.
    """
    vecs = [np.asarray(x, dtype=float) for x in (A, B, F, targets)]
    mats = [np.asarray(x, dtype=float) for x in (W_parent, W_top, W_mid)]
    lead = np.broadcast_shapes(*(v.shape[:-1] for v in vecs), *(m.shape[:-2] for m in mats))
    n = int(np.prod(lead, dtype=np.int64))
    A_, B_, F_, T_ = (np.ascontiguousarray(np.broadcast_to(v, lead + (3,))).reshape(n, 3)
                      for v in vecs)
    Wp, Wt, Wm = (np.ascontiguousarray(np.broadcast_to(m, lead + (3, 3))).reshape(n, 3, 3)
                  for m in mats)
    L_top = np.empty((n, 3, 3))
    L_mid = np.empty((n, 3, 3))
    two_bone_rows(A_, B_, F_, Wp, Wt, Wm, T_, L_top, L_mid)
    return L_top.reshape(lead + (3, 3)), L_mid.reshape(lead + (3, 3))


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

    Notes
    -----
    Each frame and leg is :func:`two_bone`; the loop over frames is compiled
    (:func:`quadsim.horse.place_kernel.place_feet_rows`).
    """
    targets = np.ascontiguousarray(targets, dtype=float)
    skel = motion.skeleton
    local = np.array(motion.local_matrices, dtype=float, order="C")
    rows = np.array([[i, leg.chain[leg.ik_start], leg.chain[leg.ik_start + 1], leg.foot]
                     for i, leg in ((i, character.legs[i]) for i in legs)],
                    dtype=np.int64).reshape(-1, 4)
    q = np.empty(local.shape[:2] + (4,))
    place_feet_rows(np.asarray(skel.parents, dtype=np.int64), np.asarray(skel.offsets, float),
                    local, np.ascontiguousarray(motion.root_positions, dtype=float), rows,
                    targets, q)
    return q


def _runs(c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Starts and (exclusive) ends of the True runs of a 1-D bool array."""
    edges = np.diff(np.concatenate([[0], c.astype(np.int8), [0]]))
    return np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]


def _smoothstep(x: np.ndarray) -> np.ndarray:
    """``3x^2 - 2x^3`` on [0, 1] (zero slope at both ends), clipped outside."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


#: A foot lower than this (m) next to a contact is brought to rest along the
#: ground at the contact (see :func:`stance_targets`); from it up, fully free.
SKID_HEIGHT = 0.01


def _low(h: float) -> float:
    """1 for a foot on the ground, falling linearly to 0 at :data:`SKID_HEIGHT`."""
    return float(np.clip(1.0 - h / SKID_HEIGHT, 0.0, 1.0))


def stance_targets(feet: np.ndarray, contacts: np.ndarray, ground: float = 0.0, *,
                   anchor: str = "mid", ramp: int = 0, clear: bool = False) -> np.ndarray:
    """Foot targets holding each contact still, on the ground.

    Parameters
    ----------
    feet : ndarray, shape (T, 4, 3)
        Foot positions (m), legs LF, RF, LH, RH.
    contacts : ndarray of bool, shape (T, 4)
    ground : float
        Ground height (m).
    anchor : {"mid", "touchdown"}
        Where a contact is held: ``"mid"`` at the foot's place on the
        contact's middle frame, at the lowest height it reaches in the contact
        (not below the ground) -- for looped clips, where the contact is
        already nearly still; ``"touchdown"`` at its place on the contact's
        first frame, on the ground -- for edited motion (a transition) whose
        feet slip under the body: the foot stays where it landed.
    ramp : int
        Frames over which the swing joins each contact: before a touchdown
        at frame ``b`` the target is ``p + s (c + k u (b - f))``, ``p`` the
        foot on frame ``f``, ``c`` the contact's correction (hold minus foot)
        on frame ``b``, ``u`` the foot's step along the ground into frame
        ``b``, ``s`` a smoothstep from 0 (``ramp + 1`` frames away) to 1 (at
        the contact), and ``k`` 1 when the foot comes in along the ground,
        falling to 0 when it comes in from :data:`SKID_HEIGHT` or higher;
        after a lift-off likewise. The foot thus joins its held place without
        a jump, a foot that would skid along the ground into or out of the
        contact is brought to rest there, and a swing that lands from above
        is only shifted by the fading correction (the ramp is shortened to
        half a swing shorter than two ramps). 0: no correction outside
        contacts.
    clear : bool
        With ``ramp``: a foot out of contact that would dip under the ground
        is lifted over it by a smooth bump (at least the dip on every frame).

    Returns
    -------
    targets : ndarray, shape (T, 4, 3)
        ``feet`` where no correction applies.
    """
    if anchor not in ("mid", "touchdown"):
        raise ValueError(f"anchor must be 'mid' or 'touchdown', got {anchor!r}")
    feet = np.asarray(feet, dtype=float)
    contacts = np.asarray(contacts, dtype=bool)
    T = len(feet)
    tgt = np.array(feet, dtype=float)
    frames = np.arange(T)
    for i in range(4):
        starts, ends = _runs(contacts[:, i])
        if not len(starts):
            continue
        off = np.zeros((T, 3))
        held = np.zeros((T, 3))
        for s, e in zip(starts, ends):
            if anchor == "mid":
                k = (s + e - 1) // 2
                y = ground + max(0.0, float(np.min(feet[s:e, i, 1]) - ground))
            else:
                k, y = s, ground
            hold = np.array([feet[k, i, 0], y, feet[k, i, 2]])
            held[s:e] = hold
            off[s:e] = hold - feet[s:e, i]
        if ramp > 0:
            # the swings between contacts (and before the first, after the last)
            g0 = np.concatenate([[0], ends])
            g1 = np.concatenate([starts, [T]])
            for a, b in zip(g0, g1):
                if b <= a:
                    continue
                f = frames[a:b]
                r = ramp if (a == 0 or b == T) else min(ramp, (b - a) / 2.0)
                w = np.zeros((b - a, 3))
                if a > 0:      # leave the contact that ends at a (its last frame a - 1)
                    v = (feet[a, i] - feet[a - 1, i]) * _low(feet[a, i, 1] + off[a - 1, 1] - ground)
                    v[1] = 0.0
                    d = off[a - 1] - v * (f - a + 1)[:, None]
                    w += d * _smoothstep(1.0 - (f - a + 1) / (r + 1))[:, None]
                if b < T:      # arrive at the contact that starts at b
                    v = (feet[b, i] - feet[b - 1, i]) * _low(feet[b - 1, i, 1] + off[b, 1] - ground)
                    v[1] = 0.0
                    d = off[b] + v * (b - f)[:, None]
                    w += d * _smoothstep(1.0 - (b - f) / (r + 1))[:, None]
                off[a:b] = w
        tgt[:, i] = np.where(contacts[:, i, None], held, feet[:, i] + off)
        if clear and ramp > 0:
            # a swing that dips under the ground is lifted by a smooth bump
            dip = np.where(contacts[:, i], 0.0, np.maximum(ground - tgt[:, i, 1], 0.0))
            tgt[:, i, 1] += np.where(contacts[:, i], 0.0, _smooth_cover(dip, max(ramp // 3, 1)))
    return tgt


def reach_drop(character: Character, motion: Motion, targets, contacts, *, slack: float = 0.001,
               smooth: int = 4) -> np.ndarray:
    """How far to lower the root so that every held foot can reach its target.

    A leg's two-bone pair reaches ``(1 - slack)`` of its length from its top
    joint (the bones below the pair as they are on that frame); a held target
    beyond that asks for the root to come down until the target is in reach
    (the largest of the held legs). The drops are then spread smoothly in
    time -- a running maximum over ``2 smooth`` frames either side, then two
    running means over ``smooth`` frames either side -- so that the result is
    at least the need on every frame and has no jumps.

    Parameters
    ----------
    character : Character
    motion : Motion
        T frames.
    targets : array-like, shape (T, 4, 3)
        Foot targets (m), as from :func:`stance_targets`.
    contacts : array-like of bool, shape (T, 4)
        The feet held on each frame (only these count).
    slack : float
        Fraction of the leg's length kept in reserve (a straight leg is a
        singular pose for the IK).
    smooth : int
        Frames of the smoothing.

    Returns
    -------
    drop : ndarray, shape (T,)
        Metres, >= 0.
    """
    targets = np.asarray(targets, dtype=float)
    contacts = np.asarray(contacts, dtype=bool)
    Wp = motion.world_positions()
    T = len(Wp)
    need = np.zeros(T)
    for i, leg in enumerate(character.legs):
        top = int(leg.chain[leg.ik_start])
        mid = int(leg.chain[leg.ik_start + 1])
        A = Wp[:, top]
        R = (np.linalg.norm(Wp[:, mid] - A, axis=-1)
             + np.linalg.norm(Wp[:, leg.foot] - Wp[:, mid], axis=-1)) * (1.0 - slack)
        d = targets[:, i] - A
        hd2 = d[:, 0] ** 2 + d[:, 2] ** 2
        v = -d[:, 1]                                   # how far the target is below the top
        ok = hd2 < R ** 2
        dy = np.where(ok, v - np.sqrt(np.maximum(R ** 2 - hd2, 0.0)), 0.0)
        need = np.maximum(need, np.where(contacts[:, i] & ok, np.maximum(dy, 0.0), 0.0))
    return _smooth_cover(need, smooth)


def _smooth_cover(x: np.ndarray, k: int) -> np.ndarray:
    """A smooth curve at least ``x`` (T,) on every frame: running max over ``2k``
    frames either side, then two running means over ``k`` either side."""
    if not x.any() or k <= 0:
        return x
    k = int(k)
    pad = np.pad(x, 2 * k, mode="edge")
    out = np.lib.stride_tricks.sliding_window_view(pad, 4 * k + 1).max(axis=-1)
    for _ in range(2):
        pad = np.pad(out, k, mode="edge")
        out = np.lib.stride_tricks.sliding_window_view(pad, 2 * k + 1).mean(axis=-1)
    return out


def pin_stance(character: Character, motion: Motion, contacts, ground: float = 0.0, *,
               anchor: str = "mid", ramp: int = 0) -> Motion:
    """The motion with every foot held still through each of its contacts.

    Parameters
    ----------
    character : Character
    motion : Motion
        T frames.
    contacts : array-like of bool, shape (T, 4)
        Which feet to hold, per frame.
    ground : float
        Ground height (m).
    anchor, ramp
        As in :func:`stance_targets`.

    Returns
    -------
    Motion
        Same root; leg rotations changed by :func:`place_feet`.
    """
    contacts = np.asarray(contacts, dtype=bool)
    tgt = stance_targets(motion.foot_positions(), contacts, ground, anchor=anchor, ramp=ramp)
    rot = place_feet(character, motion, tgt)
    return Motion(motion.skeleton, motion.fps, motion.root_positions, rot,
                  foot_joints=motion.foot_joints)



def keep_foot_attitude(character: Character, source: Motion, rotations: np.ndarray) -> np.ndarray:
    """Rotations with each foot bone turned back to its world attitude in ``source``.

    :func:`place_feet` keeps the bones below each pair's middle joint at their
    local angles, so when it swings a leg's pair the hoof (or paw) tilts with
    the lower leg: a hind leg moved in by 7 % tips its hoof about 9 deg and the
    toe tip 12 mm into the ground while the foot joint stays on its target.
    This turns each foot joint (the hoof) so that its world rotation is the
    one it had in ``source`` -- only the foot bone's end (the toe tip) moves;
    every joint position is unchanged.

    Parameters
    ----------
    character : Character
    source : Motion
        T frames: the motion before the edit (its feet's attitude is kept).
    rotations : ndarray, shape (T, J, 4)
        The edited local rotations (on ``source``'s skeleton and root).

    Returns
    -------
    ndarray, shape (T, J, 4)
        ``rotations`` with the four foot joints' local rotations replaced.
    """
    edited = Motion(source.skeleton, source.fps, source.root_positions, rotations,
                    foot_joints=source.foot_joints)
    want = source.world_rotations()
    have = edited.world_rotations()
    parents = source.skeleton.parents
    out = np.array(rotations, dtype=float)
    for leg in character.legs:
        f = leg.foot
        local = np.einsum("tji,tjk->tik", have[:, parents[f]], want[:, f])   # W_p^T W_f
        out[:, f] = quaternions_from_matrices(local)
    return out

__all__ = ["keep_foot_attitude", "pin_stance", "place_feet", "reach_drop", "stance_targets", "two_bone"]
