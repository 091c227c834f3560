"""From a skeleton and a profile to primitives: short tapered tubes with weights.

Each part of a :class:`~quadsim.mesh.profiles.Profile` follows a chain of the
skeleton at rest (:func:`chains`). A chain is a polyline of joint positions
whose edges are the bones, each moved by its *owner* joint (the bone's parent
joint), plus an owner for its straight extensions before the start and past
the end. A part is sampled along its chain into short segments; every
segment is a :class:`Primitives` row: its two centres, its frame, its
half-widths and half-depths at both ends, its colour and the joint weights of
its two ends.

Joint weights along a chain: the owner of a bone has weight 1 along the
bone's middle and hands over to the next bone's owner with a smoothstep over
:data:`HANDOVER` of a bone around the joint, 1/2 each at the joint, so the
skin bends smoothly at every joint.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from quadsim.frames import X, Y, Z
from quadsim.mesh.profiles import PARTS, Blob, Part, Profile
from quadsim.skeleton.anatomy import find_anatomy
from quadsim.skeleton.skeleton import Skeleton

__all__ = ["Chain", "Primitives", "bone_primitives", "chains", "primitives"]

#: Fraction of a bone, centred on each joint, over which the weight passes from
#: one bone's owner to the next (smoothstep; 1/2 each at the joint).
HANDOVER = 0.6
#: Longest segment a part is cut into (hip heights).
SEGMENT = 0.1


@dataclass(frozen=True)
class Chain:
    """A polyline through the skeleton at rest.

    Attributes
    ----------
    points : ndarray, shape (n, 3)
        Rest positions (m).
    owners : ndarray of int, shape (n + 1,)
        Owner of the extension before the start, of each of the ``n - 1``
        edges, and of the extension past the end.
    start, end : int
        Indices of the points at ``t = 0`` and ``t = 1``.
    level : bool
        Extend straight and level (the trunk) rather than along the end edges.
    """

    points: np.ndarray
    owners: np.ndarray
    start: int
    end: int
    level: bool = False


class Primitives(NamedTuple):
    """``P`` tapered segments with elliptic (or boxier) sections.

    a, b : (P, 3) centres of the ends (m); axis : (P, 3) unit a to b;
    across, up : (P, 3) unit section axes; length : (P,) (m);
    width, depth : (P, 2) half-sizes at a and b (m); power : (P,);
    rgb : (P, 3); weights : (P, 2, J) joint weights at a and b;
    part : (P,) index of the part's chain in :data:`~quadsim.mesh.profiles.PARTS`;
    group : (P,) one number per tube (a part along one chain, or one blob): a
    tube is the plain union of its segments, tubes melt into each other.
    """

    a: np.ndarray
    b: np.ndarray
    axis: np.ndarray
    across: np.ndarray
    up: np.ndarray
    length: np.ndarray
    width: np.ndarray
    depth: np.ndarray
    power: np.ndarray
    rgb: np.ndarray
    weights: np.ndarray
    part: np.ndarray
    group: np.ndarray


def _tail_chain(skel: Skeleton, anat, kids) -> list[int]:
    """The tail: from the leaf furthest back (not a foot or the head) up to the trunk."""
    P = skel.rest_positions
    trunk = set(anat.spine)
    used = set(anat.feet) | {anat.head}
    for leg in anat.legs:
        used |= set(leg)
    leaves = [j for j in range(skel.n_joints) if not kids[j] and j not in used]
    leaves = [j for j in leaves if P[j, Z] < P[anat.pelvis, Z]]
    if not leaves:
        return []
    j = min(leaves, key=lambda k: P[k, Z])
    out = []
    while j >= 0 and j not in trunk and j not in used:
        out.append(j)
        j = int(skel.parents[j])
    if j < 0:
        return []
    out.append(j)
    return out[::-1]


def _tip(skel: Skeleton, j: int, fallback: np.ndarray) -> np.ndarray:
    P = skel.rest_positions
    off = skel.end_sites.get(skel.names[j])
    if off is None or np.linalg.norm(off) < 1e-9:
        return P[j] + fallback
    return P[j] + off


def chains(skel: Skeleton, h: float) -> dict[str, list[Chain]]:
    """The chains of every part name in :data:`~quadsim.mesh.profiles.PARTS`.

    Parameters
    ----------
    skel : Skeleton
    h : float
        Hip height (m): sets the length of made-up end bones.

    Raises
    ------
    ValueError
        When the skeleton is not a quadruped's (:func:`find_anatomy`).
    """
    anat = find_anatomy(skel)
    P = skel.rest_positions
    par = skel.parents
    kids = skel.children
    fwd = np.zeros(3)
    fwd[Z] = 1.0
    spine = list(anat.spine)
    out: dict[str, list[Chain]] = {}
    own = [spine[0]] + spine[:-1] + [spine[-1]]
    out["trunk"] = [Chain(P[spine], np.array(own), 0, len(spine) - 1, level=True)]
    # neck: withers up to the head joint, then the head's tip
    neck = []
    j = anat.head
    while j >= 0 and j != anat.withers:
        neck.append(j)
        j = int(par[j])
    neck = [anat.withers] + neck[::-1]
    head_dir = P[anat.head] - P[int(par[anat.head])]
    head_dir = head_dir / max(np.linalg.norm(head_dir), 1e-9) * 0.5 * h
    tip = _tip(skel, anat.head, head_dir)
    pts = np.vstack([P[neck], tip])
    before = spine[-2] if len(spine) > 1 else spine[-1]
    own = [before] + neck + [anat.head]
    out["neck"] = [Chain(pts, np.array(own), 0, len(neck) - 1)]
    out["head"] = [Chain(pts, np.array(own), len(neck) - 1, len(neck))]
    for name, legs in (("fore", anat.legs[:2]), ("hind", anat.legs[2:])):
        leg_chains, foot_chains = [], []
        for leg in legs:
            girdle = int(par[leg[0]])
            toe = _tip(skel, leg[-1], 0.12 * h * fwd)
            pts = np.vstack([P[girdle], P[list(leg)], toe])
            own = [girdle, girdle] + list(leg) + [leg[-1]]
            n = len(pts)
            leg_chains.append(Chain(pts, np.array(own), 1, n - 2))
            foot_chains.append(Chain(pts, np.array(own), n - 2, n - 1))
        out[f"{name}_leg"] = leg_chains
        out[f"{name}_foot"] = foot_chains
    tail = _tail_chain(skel, anat, kids)
    if len(tail) >= 2:
        last = tail[-1]
        d = P[last] - P[tail[-2]]
        tip = _tip(skel, last, d / max(np.linalg.norm(d), 1e-9) * 0.1 * h)
        pts = np.vstack([P[tail], tip])
        own = [tail[0]] + tail + [last]
        out["tail"] = [Chain(pts, np.array(own), 1, len(pts) - 1)]
    else:
        out["tail"] = []
    return out


# ------------------------------------------------------------- along a chain
def _arc(points: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])


def _along(chain: Chain, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points (k, 3) at ``t`` along the chain and their chain coordinates (k,).

    The chain coordinate is the fractional point index (``i + f`` on the edge
    from point ``i``), extended linearly past both ends.
    """
    pts = chain.points
    s = _arc(pts)
    s0, s1 = s[chain.start], s[chain.end]
    span = max(s1 - s0, 1e-9)
    q = s0 + np.asarray(t, dtype=float) * span
    n = len(pts)
    out = np.empty((len(q), 3))
    coord = np.empty(len(q))
    first = pts[1] - pts[0] if n > 1 else np.array([0.0, 0.0, 1.0])
    last = pts[-1] - pts[-2] if n > 1 else np.array([0.0, 0.0, 1.0])
    if chain.level:                       # the trunk goes on level, forward and back
        chord = pts[chain.end] - pts[chain.start]
        flat = chord.copy()
        flat[Y] = 0.0
        first = last = flat if np.linalg.norm(flat) > 1e-9 else chord
    first = first / max(np.linalg.norm(first), 1e-12)
    last = last / max(np.linalg.norm(last), 1e-12)
    for k, qk in enumerate(q):
        if qk <= 0.0:
            out[k] = pts[0] + qk * first
            coord[k] = qk / max(s[1] - s[0], 1e-9) if n > 1 else 0.0
        elif qk >= s[-1]:
            out[k] = pts[-1] + (qk - s[-1]) * last
            coord[k] = n - 1 + (qk - s[-1]) / max(s[-1] - s[-2], 1e-9)
        else:
            i = int(np.searchsorted(s, qk, side="right") - 1)
            f = (qk - s[i]) / max(s[i + 1] - s[i], 1e-12)
            out[k] = pts[i] + f * (pts[i + 1] - pts[i])
            coord[k] = i + f
    return out, coord


def _weights(chain: Chain, coord: np.ndarray, n_joints: int) -> np.ndarray:
    """Joint weights (k, J) at chain coordinates: smoothstep hand-over between edge owners."""
    n = len(chain.points)
    centres = np.arange(-1, n) + 0.5              # extension before, edges, extension past
    c = np.clip(coord, -0.5, n - 0.5)
    x = np.clip((0.5 + 0.5 * HANDOVER - np.abs(c[:, None] - centres[None, :])) / HANDOVER,
                0.0, 1.0)
    hat = x * x * (3.0 - 2.0 * x)
    hat /= np.maximum(hat.sum(axis=1, keepdims=True), 1e-12)
    W = np.zeros((len(coord), n_joints))
    for e, owner in enumerate(chain.owners):
        W[:, owner] += hat[:, e]
    return W


def _frames(tangent: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Across (the body's left, +X, made perpendicular) and up axes for unit tangents."""
    left = np.zeros(3)
    left[X] = 1.0
    across = left - (tangent @ left)[:, None] * tangent
    bad = np.linalg.norm(across, axis=1) < 1e-6
    if bad.any():
        alt = np.zeros(3)
        alt[Y] = 1.0
        across[bad] = alt - (tangent[bad] @ alt)[:, None] * tangent[bad]
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    up = np.cross(tangent, across)
    return across, up


def _tangents(chain: Chain, t: np.ndarray, h: float) -> np.ndarray:
    s = _arc(chain.points)
    span = max(s[chain.end] - s[chain.start], 1e-9)
    dt = 0.25 * SEGMENT * h / span
    a, _ = _along(chain, t - dt)
    b, _ = _along(chain, t + dt)
    d = b - a
    return d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)


def _part_rows(part: Part, chain: Chain, h: float, base_rgb, n_joints: int) -> list:
    sec = part.sections
    ts = np.array([s.t for s in sec])
    s = _arc(chain.points)
    span = max(s[chain.end] - s[chain.start], 1e-9)
    n_seg = max(2, int(np.ceil((ts[-1] - ts[0]) * span / (SEGMENT * h))))
    t = np.linspace(ts[0], ts[-1], n_seg + 1)
    t = np.unique(np.concatenate([t, ts]))
    pos, coord = _along(chain, t)
    tan = _tangents(chain, t, h)
    _, up = _frames(tan)
    width = (np.interp(t, ts, [x.width for x in sec]) + part.grow) * h
    depth = (np.interp(t, ts, [x.depth for x in sec]) + part.grow) * h
    lift = np.interp(t, ts, [x.lift for x in sec]) * h
    if part.chain.endswith("_foot"):                 # feet keep their soles on the ground
        lift = lift + part.grow * h
    centre = pos + lift[:, None] * up
    W = _weights(chain, coord, n_joints)
    rgb = np.asarray(part.rgb if part.rgb is not None else np.asarray(base_rgb) * part.tone)
    rows = []
    for i in range(len(t) - 1):
        rows.append((centre[i], centre[i + 1], (width[i], width[i + 1]),
                     (depth[i], depth[i + 1]), part.power, rgb, W[i:i + 2],
                     PARTS.index(part.chain)))
    return rows


def _blob_rows(blob: Blob, chain: Chain, h: float, base_rgb, n_joints: int) -> list:
    t = np.array([blob.t])
    pos, coord = _along(chain, t)
    tan = _tangents(chain, t, h)
    across, up = _frames(tan)
    W = _weights(chain, coord, n_joints)
    rgb = np.asarray(blob.rgb if blob.rgb is not None else np.asarray(base_rgb) * blob.tone)
    rows = []
    for sign in ((1.0, -1.0) if blob.mirror else (1.0,)):
        ends = []
        for off in (blob.start, blob.end):
            o = np.asarray(off, dtype=float) * h
            ends.append(pos[0] + sign * o[0] * across[0] + o[1] * up[0] + o[2] * tan[0])
        rows.append((ends[0], ends[1], (blob.radius_start[0] * h, blob.radius_end[0] * h),
                     (blob.radius_start[1] * h, blob.radius_end[1] * h), 2.0, rgb,
                     np.vstack([W, W]), PARTS.index(blob.chain)))
    return rows


def primitives(skel: Skeleton, profile: Profile, h: float) -> Primitives:
    """The profile's parts and blobs laid along the skeleton at rest."""
    ch = chains(skel, h)
    J = skel.n_joints
    rows = []
    group = 0
    for part in profile.parts:
        for chain in ch.get(part.chain, []):
            rows += [r + (group,) for r in _part_rows(part, chain, h, profile.color, J)]
            group += 1
    for blob in profile.blobs:
        for chain in ch.get(blob.chain, []):
            for r in _blob_rows(blob, chain, h, profile.color, J):
                rows.append(r + (group,))
                group += 1
    return _pack(rows)


def _pack(rows: list) -> Primitives:
    a = np.array([r[0] for r in rows])
    b = np.array([r[1] for r in rows])
    d = b - a
    length = np.linalg.norm(d, axis=1)
    axis = d / np.maximum(length, 1e-12)[:, None]
    axis[length < 1e-9] = (0.0, 0.0, 1.0)
    across, up = _frames(axis)
    return Primitives(a, b, axis, across, up, length,
                      np.array([r[2] for r in rows]), np.array([r[3] for r in rows]),
                      np.array([r[4] for r in rows], dtype=float),
                      np.array([r[5] for r in rows], dtype=float),
                      np.array([r[6] for r in rows]),
                      np.array([r[7] for r in rows], dtype=np.int64),
                      np.array([r[8] for r in rows], dtype=np.int64))


def bone_primitives(skel: Skeleton, radius: float, rgb) -> Primitives:
    """A round tube of ``radius`` (m) around every bone, for a skeleton of any shape.

    Each bone moves rigidly with its parent joint; all rows are labelled as
    the trunk.
    """
    P = skel.rest_positions
    J = skel.n_joints
    rows = []
    bones = [(int(skel.parents[j]), P[j]) for j in range(1, J)]
    bones += [(skel.index(n), P[skel.index(n)] + off) for n, off in skel.end_sites.items()]
    for owner, end in bones:
        W = np.zeros((2, J))
        W[:, owner] = 1.0
        rows.append((P[owner], end, (radius, radius), (radius, radius), 2.0,
                     np.asarray(rgb, dtype=float), W, PARTS.index("trunk"), len(rows)))
    if not rows:
        W = np.zeros((2, J))
        W[:, 0] = 1.0
        rows.append((P[0], P[0], (radius, radius), (radius, radius), 2.0,
                     np.asarray(rgb, dtype=float), W, PARTS.index("trunk"), 0))
    return _pack(rows)
