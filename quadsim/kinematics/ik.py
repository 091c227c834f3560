"""Inverse kinematics for quadruped legs.

A leg is a chain of joints from the top of the leg (scapula or hip) to the
foot contact joint. Below the top joint every bone lies in the leg's
sagittal plane at rest, so a leg moves in a plane that the top joint swings
sideways (abduction about the body's forward axis). In that plane the chain
is solved as

* **pre** bones (above the two-bone pair, e.g. the cat's scapula): they swing
  with the leg by a fixed fraction of the leg's angle;
* the **two-bone pair** (shoulder-elbow-wrist, hip-knee-hock): solved exactly
  by the law of cosines, the middle joint bending forward (knee) or back
  (elbow) as the character file says;
* **post** bones (metatarsus, cannon, pastern, hoof): at their rest angle
  to the *world* vertical, turned with the leg by a fraction of its swing
  angle (the heel rises as the leg sweeps back), plus a fold while the foot
  is in swing.

Reachable targets are reached exactly. An unreachable target gives the
closest pose along the line to it (the pair straightened, never NaN).

All functions are vectorised over any leading batch shape.

In-plane angles are measured from the downward direction towards forward
(+Z), in radians: a bone of length ``l`` at angle ``phi`` spans
``(down, forward) = l (cos phi, sin phi)``. A rotation about +X by ``theta``
turns a bone at angle ``phi`` to ``phi - theta``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from quadsim.kinematics.rotations import matrices_about_axis
from quadsim.skeleton.character import Character, LegSpec

_EPS = 1e-9


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

    @property
    def n_bones(self) -> int:
        return self.lengths.shape[-1]


def stack_leg_geometries(geoms) -> LegGeometry:
    """Several legs as one :class:`LegGeometry` with a trailing leg axis B.

    The legs must have the same number of bones and the same pair bone.
    The result's ``chain`` has shape (B, n + 1), ``parent`` is an int array
    (B,), ``top_offset`` (B, 3), the per-bone arrays (B, n) and the scalars
    (B,). :func:`solve_leg` takes it like a single leg; the batch shape of
    its inputs must then end with B. Equal to solving each leg alone.
    """
    geoms = list(geoms)
    first = geoms[0]
    if any(g.n_bones != first.n_bones or g.pair != first.pair for g in geoms):
        raise ValueError("stacked legs need the same number of bones and the same pair")

    def st(name, dtype=float):
        return np.array([getattr(g, name) for g in geoms], dtype=dtype)

    return LegGeometry(
        chain=st("chain", int), parent=st("parent", int), top_offset=st("top_offset"),
        lengths=st("lengths"), rest_angles=st("rest_angles"), pair=first.pair,
        bend=st("bend"), fold=st("fold"), pre_gain=st("pre_gain"),
        post_gain=st("post_gain"), toe_angle=st("toe_angle"),
        rest_leg_angle=st("rest_leg_angle"), lower=st("lower"), upper=st("upper"))


def leg_geometry(character: Character, leg: LegSpec, *,
                 fold_fraction: float = 0.55) -> LegGeometry:
    """Build a leg's :class:`LegGeometry` from the character description.

    The fold direction of each post bone comes from the character's joint
    limits: a joint folds towards the side of its larger flexion range (a
    hock folds its metatarsus forward, a carpus its cannon back), by
    ``fold_fraction`` of that range, capped at 75 degrees.
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
        lo, hi = character.limits.get(joint, (np.radians(-30.0), np.radians(30.0)))
        # positive rotation about +X swings the bone backwards: angle -= theta
        big = hi if abs(hi) >= abs(lo) else lo
        fold[k] = -np.sign(big) * min(abs(big) * fold_fraction, np.radians(75.0))
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
        pre_gain=leg.pre_gain, post_gain=leg.post_gain, toe_angle=toe,
        rest_leg_angle=float(np.arctan2(rel[2], -rel[1])), lower=lower, upper=upper,
    )


def _solve_pair(geom: LegGeometry, phi, qd, qf, down_t, fwd_t):
    """Solve the two-bone pair in place in ``phi`` given the pre and post bones.

    The pair runs from Q (below the pre bones) to C (the target less the
    post bones). Returns how far the foot falls short of the target (m).
    """
    L = geom.lengths
    k0 = geom.pair
    post = slice(k0 + 2, None)
    cd = down_t - (L[..., post] * np.cos(phi[..., post])).sum(axis=-1)
    cf = fwd_t - (L[..., post] * np.sin(phi[..., post])).sum(axis=-1)
    l1, l2 = L[..., k0], L[..., k0 + 1]
    vd, vf = cd - qd, cf - qf
    r_true = np.hypot(vd, vf)
    # np.minimum(np.maximum(...)) is np.clip without its per-call overhead
    r = np.minimum(np.maximum(r_true, np.abs(l1 - l2) + 1e-6), l1 + l2 - 1e-6)
    gam = np.arctan2(vf, vd)
    cos_delta = np.minimum(np.maximum((l1 * l1 + r * r - l2 * l2) / (2.0 * l1 * r), -1.0), 1.0)
    phi[..., k0] = gam + geom.bend * np.arccos(cos_delta)
    bd = qd + l1 * np.cos(phi[..., k0])
    bf = qf + l1 * np.sin(phi[..., k0])
    phi[..., k0 + 1] = np.arctan2(qf + r * np.sin(gam) - bf, qd + r * np.cos(gam) - bd)
    return np.abs(r_true - r)


def solve_leg(geom: LegGeometry, parent_rot: np.ndarray, parent_pos: np.ndarray,
              target: np.ndarray, fold: np.ndarray | float = 0.0,
              toe_pitch: np.ndarray | float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations that put a leg's foot joint on a target.

    Parameters
    ----------
    geom : LegGeometry
        One leg, or several stacked by :func:`stack_leg_geometries` (then
        every batch shape below ends with their number B).
    parent_rot : array-like, shape (..., 3, 3)
        World rotation of the top joint's parent.
    parent_pos : array-like, shape (..., 3)
        World position of the top joint's parent (m).
    target : array-like, shape (..., 3)
        World position wanted for the foot joint (m).
    fold : array-like, shape (...)
        Swing fold of the post bones, 0 (planted) to 1 (fully folded).
    toe_pitch : array-like, shape (...)
        Rotation of the toes/hoof from level (rad), positive tips them down.

    Returns
    -------
    local : ndarray, shape (..., n + 1, 3, 3)
        Local rotation of each chain joint, top to foot.
    reached : ndarray, shape (...)
        Distance from the target to the foot actually reached (m); 0 for a
        reachable target.
    """
    Rp = np.asarray(parent_rot, dtype=float)
    Pp = np.asarray(parent_pos, dtype=float)
    tgt = np.asarray(target, dtype=float)
    batch = np.broadcast_shapes(Rp.shape[:-2], Pp.shape[:-1], tgt.shape[:-1],
                                np.shape(fold), np.shape(toe_pitch))
    RpT = np.swapaxes(Rp, -1, -2)
    top = Pp + np.einsum("...ij,...j->...i", Rp, geom.top_offset)
    d = np.einsum("...ij,...j->...i", RpT, tgt - top)
    d = np.broadcast_to(d, batch + (3,))
    # abduction about the parent's forward axis brings the target into the plane
    # (a target above the top joint swings the plane past horizontal: the
    # leg then points at it, and `reached` reports the true miss)
    a = np.arctan2(d[..., 0], -d[..., 1])
    ca, sa = np.cos(a), np.sin(a)
    down_t = -(d[..., 1] * ca - d[..., 0] * sa)  # -(y') with y' = -x sin a + y cos a
    fwd_t = d[..., 2]
    # world down in the leg plane
    g = np.broadcast_to(RpT[..., 1, :] * -1.0, batch + (3,))  # R^T (0,-1,0)
    gy = -g[..., 0] * sa + g[..., 1] * ca
    phi_down = np.arctan2(g[..., 2], -gy)

    L = geom.lengths
    A0 = geom.rest_angles
    n = geom.n_bones
    k0 = geom.pair
    phi = np.empty(batch + (n,))
    # pre bones swing with the leg
    alpha = np.arctan2(fwd_t, down_t)
    qd = np.zeros(batch)
    qf = np.zeros(batch)
    for k in range(k0):
        phi[..., k] = A0[..., k] + geom.pre_gain * (alpha - geom.rest_leg_angle)
        qd = qd + L[..., k] * np.cos(phi[..., k])
        qf = qf + L[..., k] * np.sin(phi[..., k])
    # post bones: rest angle to the world vertical, turned with the leg, plus
    # the swing fold
    fold = np.asarray(fold, dtype=float)
    for k in range(k0 + 2, n):
        phi[..., k] = (A0[..., k] + phi_down + geom.post_gain * (alpha - geom.rest_leg_angle)
                       + geom.fold[..., k] * fold)
    reached = _solve_pair(geom, phi, qd, qf, down_t, fwd_t)
    # keep the post joints inside their limits relative to the bone above,
    # then solve the pair again for the moved post bones (twice: the second
    # pass corrects the small change the re-solved pair makes)
    for _ in range(2 if geom.limited else 0):
        for k in range(k0 + 2, n):
            rel = (A0[..., k] - phi[..., k]) - (A0[..., k - 1] - phi[..., k - 1])
            rel = np.minimum(np.maximum(rel, geom.lower[..., k]), geom.upper[..., k])
            phi[..., k] = A0[..., k] - (A0[..., k - 1] - phi[..., k - 1]) - rel
        reached = _solve_pair(geom, phi, qd, qf, down_t, fwd_t)

    theta = A0 - phi  # cumulative rotation about +X of each chain joint
    toe_phi = phi_down + np.pi / 2 + np.asarray(toe_pitch, dtype=float)
    theta_foot = geom.toe_angle - toe_phi
    cum = np.concatenate([theta, theta_foot[..., None]], axis=-1)
    rel = np.concatenate([cum[..., :1], np.diff(cum, axis=-1)], axis=-1)
    local = matrices_about_axis(0, rel)
    local[..., 0, :, :] = matrices_about_axis(2, a) @ local[..., 0, :, :]
    return local, reached
