"""Legs as the IK sees them: each leg's bones, rest angles, folds and limits.

:class:`LegGeometry` describes one leg of a character for the inverse kinematics
(:mod:`quadsim.kinematics.ik`), :func:`leg_geometry` works it out from the
character file, and :func:`pack_legs` lays legs out as the compiled kernel's
arrays. Conventions as in :mod:`quadsim.kinematics.ik`: in-plane angles are
measured from the downward direction towards forward (+Z), in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from quadsim.skeleton.character import Character, LegSpec

__all__ = ["DEFAULT_FOLD_LIMITS", "MAX_FOLD", "LegGeometry", "leg_geometry", "pack_legs"]

#: A post joint with no limits in the character file folds within these (rad).
DEFAULT_FOLD_LIMITS = (math.radians(-30.0), math.radians(30.0))
#: Largest fold of a post bone (rad).
MAX_FOLD = math.radians(75.0)


@dataclass(frozen=True, eq=False)
class LegGeometry:
    """Precomputed, immutable description of one leg for the IK.

    Attributes
    ----------
    chain : ndarray of int, shape (n + 1,)
        Joint indices, top to foot.
    parent : int
        Index of the top joint's parent (a spine joint).
    top_offset : ndarray, shape (3,)
        Offset of the top joint in the parent's frame (m).
    lengths : ndarray, shape (n,)
        Bone lengths, bone ``k`` from ``chain[k]`` to ``chain[k + 1]`` (m).
    rest_angles : ndarray, shape (n,)
        In-plane rest angle of each bone (rad).
    pair : int
        Bone index of the pair's upper bone (the pair is ``pair``, ``pair + 1``).
    bend : float
        +1 if the pair's middle joint points forward, -1 if back.
    fold : ndarray, shape (n,)
        In-plane angle added to each post bone at full swing fold (rad).
    carry : ndarray, shape (n,)
        In-plane angle each digit bone is drawn turned by at full swing fold
        on top of its ``fold``, which the pair does not make up for (rad): the
        digit folds with the bone above it and flexes at its own joint; 0
        above the digit.
    foot_carry : float
        In-plane angle the foot is drawn turned by at full swing fold (rad):
        the last digit bone's whole fold (a hoof turns with its pasterns); 0
        where the leg has no digit.
    tuck_height : float
        How high (m) a swinging foot's target must be for its digit to tuck
        fully: the digit's length and the foot's to its toe tip (a hoof tucked
        back hangs its toe below its joint); lower, the tuck is scaled down
        with the height (0 where the leg has no carry).
    sink : ndarray, shape (n,)
        In-plane angle added to each digit bone (the post bones below the
        first) under a load of the body's weight (rad): ``[locomotion]
        fetlock_sink_deg``, towards the ground; 0 elsewhere.
    pre_gain : float
        Fraction of the leg's swing angle taken by each pre bone.
    post_gain : float
        Fraction of the leg's swing angle taken by each post bone.
    toe_angle : float
        In-plane rest angle of the foot joint's end site (rad).
    rest_leg_angle : float
        In-plane angle from the top joint to the foot at rest (rad).
    lower, upper : ndarray, shape (n,)
        Flexion limits (rad) of the joint that turns each bone (``chain[k]``),
        relative to rest; infinite where the character gives none. The post
        joints are kept inside theirs.
    """

    chain: np.ndarray
    parent: int
    top_offset: np.ndarray
    lengths: np.ndarray
    rest_angles: np.ndarray
    pair: int
    bend: float
    fold: np.ndarray
    carry: np.ndarray
    foot_carry: float
    tuck_height: float
    sink: np.ndarray
    pre_gain: float
    post_gain: float
    toe_angle: float
    rest_leg_angle: float
    lower: np.ndarray
    upper: np.ndarray

    @cached_property
    def limited(self) -> bool:
        """Whether any post joint has a finite flexion limit."""
        return bool(np.any(np.isfinite(self.lower[..., self.pair + 2:]))
                    or np.any(np.isfinite(self.upper[..., self.pair + 2:])))

    @cached_property
    def pair_min_span(self) -> float:
        """Shortest span (m) of the two-bone pair with its middle joint (``chain[pair
        + 1]``) inside its flexion limit, bent the way the pair bends (0 where that
        joint has no limit on that side). A swinging foot is not drawn closer."""
        k = self.pair
        l1, l2 = float(self.lengths[k]), float(self.lengths[k + 1])
        # the lower bone's in-plane angle from the upper's at a rotation rel of the
        # middle joint; the pair bent by ``bend`` turns it by a sign of -bend
        turns = [(self.rest_angles[k + 1] - self.rest_angles[k]) - rel
                 for rel in (self.lower[k + 1], self.upper[k + 1]) if np.isfinite(rel)]
        turns = [abs(d) for d in turns if d * -self.bend > 0.0]
        if not turns:
            return 0.0
        d = min(max(turns), math.pi)
        return float(math.sqrt(max(l1 * l1 + l2 * l2 + 2.0 * l1 * l2 * math.cos(d), 0.0)))

    @property
    def n_bones(self) -> int:
        return self.lengths.shape[-1]


def leg_geometry(character: Character, leg: LegSpec, *,
                 fold_fraction: float = 0.55) -> LegGeometry:
    """Build a leg's :class:`LegGeometry` from the character description.

    The fold direction of each post bone comes from the character's joint
    limits: a joint folds towards the side of its larger flexion range (a
    hock folds its metatarsus forward, a carpus its cannon back), by
    ``fold_fraction`` of that range, capped at 75 degrees. The digit bones
    (the post bones below the first) sink by the character's
    ``[locomotion] fetlock_sink_deg``, forward (their lower ends turn
    towards the ground ahead of the fetlock).
    """
    sk = character.skeleton
    chain = np.asarray(leg.chain)
    offs = sk.offsets[chain[1:]]
    where = f"{character.path or character.id}: legs.{leg.name}"
    if np.any(np.abs(offs[:, 0]) > 1e-9):
        bad = [sk.names[j] for j, o in zip(chain[1:], offs) if abs(o[0]) > 1e-9]
        raise ValueError(f"{where}: joints below the top of a leg must have a zero X offset "
                         f"(the leg's plane); not so for {', '.join(bad)}")
    lengths = np.linalg.norm(offs, axis=-1)
    if np.any(lengths < 1e-6):
        raise ValueError(f"{where}: a bone of zero length")
    rest = np.arctan2(offs[:, 2], -offs[:, 1])
    n = len(lengths)
    fold = np.zeros(n)
    for k in range(leg.ik_start + 2, n):
        joint = int(chain[k])
        lo, hi = character.limits.get(joint, DEFAULT_FOLD_LIMITS)
        # positive rotation about +X swings the bone backwards: angle -= theta
        big = hi if abs(hi) >= abs(lo) else lo
        fold[k] = -np.sign(big) * min(abs(big) * fold_fraction, MAX_FOLD)
    # a digit below a bone that folds back (a carpus folding the cannon back) is drawn
    # folded with it and flexed further back at its own joint ([locomotion]
    # digit_flex_deg): the hoof tucks up behind the cannon
    carry = np.zeros(n)
    d0 = leg.ik_start + 3
    flex = math.radians(float(character.locomotion.get("digit_flex_deg", 0.0)))
    if d0 < n and flex > 0.0 and fold[d0 - 1] < 0.0:
        carry[d0:] = fold[d0 - 1] - flex - fold[d0:]
    sink = np.zeros(n)
    sink[leg.ik_start + 3:] = math.radians(float(character.locomotion.get("fetlock_sink_deg",
                                                                           0.0)))
    foot = sk.names[chain[-1]]
    end = sk.end_sites.get(foot, np.array([0.0, 0.0, 1.0]))
    toe = float(np.arctan2(end[2], -end[1]))
    rel = offs.sum(0)
    lower = np.full(n, -np.inf)
    upper = np.full(n, np.inf)
    for k in range(n):
        lim = character.limits.get(int(chain[k]))
        if lim is not None:
            lower[k], upper[k] = lim
    return LegGeometry(
        chain=chain, parent=int(sk.parents[chain[0]]), top_offset=sk.offsets[chain[0]].copy(),
        lengths=lengths, rest_angles=rest, pair=leg.ik_start, bend=leg.bend, fold=fold,
        carry=carry, foot_carry=float(fold[-1] + carry[-1]) if carry.any() else 0.0,
        tuck_height=float(lengths[d0:].sum() + np.linalg.norm(end)) if carry.any() else 0.0,
        sink=sink, pre_gain=leg.pre_gain, post_gain=leg.post_gain, toe_angle=toe,
        rest_leg_angle=float(np.arctan2(rel[2], -rel[1])), lower=lower, upper=upper,
    )


def pack_legs(legs) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Legs' :class:`LegGeometry` as the kernel's ``leg_int``, ``leg_top``,
    ``leg_bones`` and ``leg_scal`` arrays, L legs.

    ``leg_int`` (L, 4 + n_max + 1) holds the number of bones n, the pair's
    upper bone, the top joint's parent, whether the post joints are limited
    (0/1) and the chain's joint indices; ``leg_top`` (L, 3) the top joint's
    offset (m); ``leg_bones`` (L, 8, n_max) the bone lengths (m), rest
    angles, full-fold angles, lower and upper flexion limits (rad), the
    rest angles' cosines and sines, the full-load sink angles and the drawn
    digit's carried fold angles (rad); ``leg_scal`` (L, 8) the bend sign, pre
    and post gains, toe angle, rest leg angle, the foot's carried fold angle
    (rad), the tuck height (m) and the pair's shortest span in swing (m).
    """
    n_max = max(g.n_bones for g in legs)
    leg_int = np.zeros((len(legs), 4 + n_max + 1), dtype=np.int64)
    leg_top = np.zeros((len(legs), 3))
    leg_bones = np.zeros((len(legs), 9, n_max))
    leg_scal = np.zeros((len(legs), 8))
    for i, g in enumerate(legs):
        n = g.n_bones
        leg_int[i, :4] = n, g.pair, g.parent, int(g.limited)
        leg_int[i, 4:4 + n + 1] = g.chain
        leg_top[i] = g.top_offset
        for r, arr in enumerate((g.lengths, g.rest_angles, g.fold, g.lower, g.upper,
                                 np.cos(g.rest_angles), np.sin(g.rest_angles), g.sink,
                                 g.carry)):
            leg_bones[i, r, :n] = arr
        leg_scal[i] = (g.bend, g.pre_gain, g.post_gain, g.toe_angle, g.rest_leg_angle,
                       g.foot_carry, g.tuck_height, g.pair_min_span)
    return leg_int, leg_top, leg_bones, leg_scal
