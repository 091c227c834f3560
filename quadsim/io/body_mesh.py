"""A simple procedural body for any skeleton: a capsule around every bone.

The body is built in the skeleton's rest (bind) pose, in world coordinates,
and skinned to the joints with smooth weights, ready for a glTF skin
(:mod:`quadsim.io.gltf`). It needs only a :class:`~quadsim.skeleton.skeleton.Skeleton`:

- **Bones.** One capsule per parent-to-child bone (joint ``p`` to joint ``j``,
  moved by ``p``'s rotation) and one per non-empty end site (moved by the leaf).
  Bones shorter than :data:`MIN_BONE` are skipped.
- **Sizes** come from the rest pose. The *trunk* is the joints whose subtree
  holds at least two feet (leaf joints near the lowest rest height): the
  spine from the pelvis to the withers. Its radius is :data:`TRUNK_FRACTION`
  of the trunk's mean height above the feet; bones between two trunk joints
  get it. Other bones get a radius from their length (:data:`LIMB_FRACTION`),
  bounded by fractions of the trunk radius; joint names containing ``neck``,
  ``head`` or ``tail`` (quadsim's naming) get the neck, head and tail sizes.
- **Weights.** A vertex at fraction ``s`` along its bone (0 at the bone's
  start, 1 at its end) belongs to the bone's joint, blended smoothly towards
  the next joint over the last half of the bone (up to 1/2 at the end) and
  towards the previous joint over the first half (up to 1/2 at the start), so
  the body bends smoothly at every joint. At most three influences per vertex;
  unused slots hold joint 0 with weight 0, as glTF validators expect.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadsim.frames import Y
from quadsim.skeleton.skeleton import Skeleton

__all__ = ["BodyMesh", "body_mesh"]

#: Bones shorter than this are not given a capsule (m).
MIN_BONE = 1e-6
#: Trunk capsule radius as a fraction of the trunk's mean height above the feet.
TRUNK_FRACTION = 0.2
#: Radius of other bones as a fraction of their length, and its bounds as
#: fractions of the trunk radius.
LIMB_FRACTION = 0.18
LIMB_BOUNDS = (0.12, 0.3)
#: Radii of name-hinted bones as fractions of the trunk radius.
NECK_FRACTION = 0.45
HEAD_FRACTION = 0.4
TAIL_BOUNDS = (0.05, 0.15)
#: Leaves within this fraction of the rest height span above the lowest joint are feet.
FOOT_FRACTION = 0.1


@dataclass(frozen=True, eq=False)
class BodyMesh:
    """A skinned triangle mesh in the skeleton's bind pose.

    Attributes
    ----------
    positions : ndarray, shape (V, 3)
        Vertex positions in world coordinates at rest (m).
    normals : ndarray, shape (V, 3)
        Unit outward normals.
    joints : ndarray of int, shape (V, 4)
        Joint indices of up to four influences per vertex.
    weights : ndarray, shape (V, 4)
        Influence weights, each row summing to 1; unused slots are 0 with joint 0.
    triangles : ndarray of int, shape (F, 3)
        Vertex indices, counter-clockwise seen from outside.
    """

    positions: np.ndarray
    normals: np.ndarray
    joints: np.ndarray
    weights: np.ndarray
    triangles: np.ndarray


def body_mesh(skeleton: Skeleton, *, segments: int = 12, cap_rings: int = 4,
              body_rings: int = 4) -> BodyMesh:
    """Capsules around the bones of a skeleton at rest, skinned with smooth weights.

    Parameters
    ----------
    skeleton : Skeleton
    segments : int
        Vertices around each capsule (>= 3).
    cap_rings : int
        Rings in each hemispherical end cap, the equator included (>= 1).
    body_rings : int
        Sections along the cylinder between the caps (>= 1).

    Returns
    -------
    BodyMesh
        Empty arrays when the skeleton has no bone longer than :data:`MIN_BONE`.
    """
    for name, v, lo in (("segments", segments, 3), ("cap_rings", cap_rings, 1),
                        ("body_rings", body_rings, 1)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
            raise ValueError(f"`{name}` must be an integer >= {lo}, got {v!r}")
    bones = _bones(skeleton)
    unit = _unit_capsule(int(segments), int(cap_rings), int(body_rings))
    parts = [_place(unit, *bone) for bone in bones]
    if not parts:
        return BodyMesh(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 4), dtype=np.int64),
                        np.zeros((0, 4)), np.zeros((0, 3), dtype=np.int64))
    pos, nrm, jnt, wgt, tri = [], [], [], [], []
    base = 0
    for p, n, j, w, t in parts:
        pos.append(p)
        nrm.append(n)
        jnt.append(j)
        wgt.append(w)
        tri.append(t + base)
        base += len(p)
    return BodyMesh(np.concatenate(pos), np.concatenate(nrm), np.concatenate(jnt),
                    np.concatenate(wgt), np.concatenate(tri))


# ------------------------------------------------------------------- bones
def _bones(skel: Skeleton) -> list[tuple]:
    """``(start, end, radius, prev, owner, next)`` for every capsule.

    ``owner`` moves the bone; ``prev`` (its parent, or -1) and ``next`` (the
    joint at the bone's end, or -1 for an end site) blend in at the ends.
    """
    P = skel.rest_positions
    parents = skel.parents
    names = [n.lower() for n in skel.names]
    J = skel.n_joints
    low = P[:, Y].min()
    span = max(P[:, Y].max() - low, 1e-9)
    leaves = [j for j in range(J) if not skel.children[j]]
    feet = [j for j in leaves if P[j, Y] - low <= FOOT_FRACTION * span]
    n_feet = np.zeros(J, dtype=np.int64)
    for f in feet:
        j = f
        while j >= 0:
            n_feet[j] += 1
            j = int(parents[j])
    trunk = n_feet >= 2
    height = np.mean(P[trunk, Y] - low) if trunk.any() else span
    r_trunk = TRUNK_FRACTION * max(height, 1e-9)

    def radius(length, hint):
        if "head" in hint:
            return HEAD_FRACTION * r_trunk
        if "neck" in hint:
            return NECK_FRACTION * r_trunk
        lo, hi = TAIL_BOUNDS if "tail" in hint else LIMB_BOUNDS
        return float(np.clip(LIMB_FRACTION * length, lo * r_trunk, hi * r_trunk))

    out = []
    for j in range(1, J):
        p = int(parents[j])
        a, b = P[p], P[j]
        length = float(np.linalg.norm(b - a))
        if length < MIN_BONE:
            continue
        # a bone ending at the head is the top of the neck
        hint = names[j].replace("head", "neck")
        r = r_trunk if trunk[p] and trunk[j] else radius(length, hint)
        out.append((a, b, r, int(parents[p]), p, j))
    for name, off in skel.end_sites.items():
        j = skel.index(name)
        length = float(np.linalg.norm(off))
        if length < MIN_BONE:
            continue
        r = r_trunk if trunk[j] else radius(length, names[j])
        out.append((P[j], P[j] + off, r, int(parents[j]), j, -1))
    return out


# ---------------------------------------------------------------- geometry
def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _unit_capsule(segments: int, cap_rings: int, body_rings: int) -> dict:
    """A capsule template along +Z from 0 to 1 with unit radius, in profile form.

    Returns the ring profile (axial offset in radii, axial fraction of the
    length, ring radius, normal's axial and radial parts) and the triangles of
    a closed surface with a pole vertex at each end.
    """
    phi_lo = -np.pi / 2 + np.arange(1, cap_rings + 1) * (np.pi / 2) / cap_rings   # to 0
    phi_hi = np.arange(0, cap_rings) * (np.pi / 2) / cap_rings                     # from 0
    mid = np.arange(1, body_rings) / body_rings
    # rings: (offset along the axis in radii, fraction of the length, cos, sin)
    rings = ([(np.sin(f), 0.0, np.cos(f), np.sin(f)) for f in phi_lo]
             + [(0.0, m, 1.0, 0.0) for m in mid]
             + [(np.sin(f), 1.0, np.cos(f), np.sin(f)) for f in phi_hi])
    rings = np.array(rings)
    n_rings = len(rings)
    ang = 2.0 * np.pi * np.arange(segments) / segments
    # vertex 0: bottom pole, then rings of `segments`, then the top pole
    ring_start = 1 + segments * np.arange(n_rings)
    top = 1 + segments * n_rings
    k = np.arange(segments)
    k1 = (k + 1) % segments
    tris = [np.stack([np.zeros(segments, dtype=np.int64), ring_start[0] + k1,
                      ring_start[0] + k], axis=-1)]
    for r in range(n_rings - 1):
        a, b = ring_start[r], ring_start[r + 1]
        tris.append(np.stack([a + k, a + k1, b + k1], axis=-1))
        tris.append(np.stack([a + k, b + k1, b + k], axis=-1))
    tris.append(np.stack([ring_start[-1] + k, ring_start[-1] + k1,
                          np.full(segments, top)], axis=-1))
    return {"rings": rings, "angles": ang, "triangles": np.concatenate(tris)}


def _frame(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing the unit ``d`` to a right-handed frame."""
    helper = np.array([0.0, 1.0, 0.0]) if abs(d[Y]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(helper, d)
    u /= np.linalg.norm(u)
    return u, np.cross(d, u)


def _place(unit: dict, a, b, r, prev, owner, nxt):
    """Vertices, normals, joints, weights and triangles of one capsule."""
    axis = b - a
    length = float(np.linalg.norm(axis))
    d = axis / length
    u, v = _frame(d)
    rings, ang = unit["rings"], unit["angles"]
    off, frac, cos_, sin_ = rings.T
    # radial unit vectors around the ring, (S, 3)
    radial = np.cos(ang)[:, None] * u + np.sin(ang)[:, None] * v
    centre = a + (frac * length + off * r)[:, None] * d                  # (R, 3)
    pos = centre[:, None, :] + (r * cos_)[:, None, None] * radial        # (R, S, 3)
    nrm = cos_[:, None, None] * radial + sin_[:, None, None] * d         # (R, S, 3)
    s = np.repeat(frac, len(ang))
    pos = np.concatenate([[a - r * d], pos.reshape(-1, 3), [b + r * d]])
    nrm = np.concatenate([[-d], nrm.reshape(-1, 3), [d]])
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    s = np.concatenate([[0.0], s, [1.0]])
    w_prev = 0.5 * _smoothstep((0.5 - s) / 0.5) if prev >= 0 else np.zeros_like(s)
    w_next = 0.5 * _smoothstep((s - 0.5) / 0.5) if nxt >= 0 else np.zeros_like(s)
    w_own = 1.0 - w_prev - w_next
    V = len(s)
    joints = np.zeros((V, 4), dtype=np.int64)
    weights = np.zeros((V, 4))
    joints[:, 0] = owner
    weights[:, 0] = w_own
    for slot, (jid, w) in enumerate(((prev, w_prev), (nxt, w_next)), start=1):
        used = w > 0
        joints[used, slot] = jid
        weights[used, slot] = w[used]
    return pos, nrm, joints, weights, unit["triangles"].copy()
