"""A quadruped's structure found from its skeleton alone: legs, girdles, spine, head.

Motion measured the way a viewer sees it needs to know which joints are the
feet, where the trunk runs and where the head is -- for any skeleton, a BVH
of unknown naming included. :func:`find_anatomy` reads it from the tree and
the rest pose only:

- the **feet** are the four lowest leaf joints at rest (each near the ground:
  within :data:`FOOT_BAND` of the skeleton's height); fore feet are the two
  further forward (+Z), left ones further to +X; each foot's **toe tip** is its
  bone's end site (the foot joint itself when the file has none);
- each leg climbs from its foot to the joint where it leaves the trunk (the
  first ancestor with other children); those branch joints are the
  **pelvis** (hind girdle) and the **withers** (fore girdle);
- the **spine** is the chain from the pelvis to the withers, its middle joint
  the **mid-spine** (by length along the chain);
- the **head** is the remaining leaf furthest forward; its pitch is read
  along its bone (to its end site, or from its parent).

A skeleton with fewer than four legs, legs that join the trunk at the same
joint fore and hind, or no joint ahead of the withers raises ``ValueError``
naming what is missing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadsim.frames import LEGS, X, Y, Z
from quadsim.skeleton.skeleton import Skeleton

__all__ = ["FOOT_BAND", "Anatomy", "find_anatomy"]

#: An end joint is a foot when its rest height above the lowest end joint is at
#: most this fraction of the skeleton's height (a tail tip or a head hangs higher).
FOOT_BAND = 0.25


@dataclass(frozen=True)
class Anatomy:
    """Where the parts of a quadruped are in its skeleton (joint indices).

    Attributes
    ----------
    feet : tuple of int, length 4
        Foot joints, LF, RF, LH, RH.
    toe_offsets : ndarray, shape (4, 3)
        Each foot's toe tip in the foot joint's frame (m); zeros without end sites.
    legs : tuple of tuple of int
        Each leg's chain from the joint below the girdle down to the foot.
    pelvis, withers, mid_spine : int
        Hind girdle, fore girdle and the spine joint between them.
    spine : tuple of int
        The chain from the pelvis to the withers, both included.
    head : int
        The head joint.
    head_tip : ndarray, shape (3,)
        The head's end site in its frame (m), or None-like zeros with
        ``head_from_parent`` True when the skeleton has none.
    head_from_parent : bool
        Read the head's direction from its parent joint to it.
    hip_height : float
        Rest height of the hind leg tops above the hind feet (m): the ``h``
        of the Froude number.
    names : tuple of str
        The skeleton's joint names (for reports).
    """

    feet: tuple[int, ...]
    toe_offsets: np.ndarray
    legs: tuple[tuple[int, ...], ...]
    pelvis: int
    withers: int
    mid_spine: int
    spine: tuple[int, ...]
    head: int
    head_tip: np.ndarray
    head_from_parent: bool
    hip_height: float
    names: tuple[str, ...]


def _children(parents: np.ndarray) -> list[list[int]]:
    kids: list[list[int]] = [[] for _ in range(len(parents))]
    for j in range(1, len(parents)):
        kids[int(parents[j])].append(j)
    return kids


def _path_up(parents: np.ndarray, j: int) -> list[int]:
    out = [j]
    while parents[out[-1]] >= 0:
        out.append(int(parents[out[-1]]))
    return out


def find_anatomy(skeleton: Skeleton, foot_joints=None) -> Anatomy:
    """The :class:`Anatomy` of ``skeleton``.

    Parameters
    ----------
    skeleton : Skeleton
    foot_joints : sequence of str, length 4, optional
        The foot joints LF, RF, LH, RH when known (a character names them);
        found from the rest pose otherwise.

    Raises
    ------
    ValueError
        When the skeleton does not have a quadruped's structure.
    """
    parents = skeleton.parents
    kids = _children(parents)
    P = skeleton.rest_positions
    leaves = [j for j in range(skeleton.n_joints) if not kids[j]]
    if foot_joints is not None:
        feet = list(skeleton.indices(tuple(foot_joints)))
    else:
        floor = min(P[j, Y] for j in leaves)
        reach = FOOT_BAND * (P[:, Y].max() - floor)
        near = [j for j in leaves if P[j, Y] - floor <= reach]
        if len(near) < 4:
            raise ValueError(f"a quadruped skeleton needs four legs ending in feet near the "
                             f"ground at rest; this one has {len(near)}: "
                             f"{', '.join(skeleton.names[j] for j in near)}")
        low = sorted(near, key=lambda j: (P[j, Y], j))[:4]
        by_z = sorted(low, key=lambda j: -P[j, Z])
        fore = sorted(by_z[:2], key=lambda j: -P[j, X])
        hind = sorted(by_z[2:], key=lambda j: -P[j, X])
        feet = [fore[0], fore[1], hind[0], hind[1]]
    legs, girdles = [], []
    for f in feet:
        chain = [f]
        while parents[chain[-1]] >= 0 and len(kids[int(parents[chain[-1]])]) == 1:
            chain.append(int(parents[chain[-1]]))
        top = chain[-1]
        if parents[top] < 0:
            raise ValueError(f"leg of {skeleton.names[f]!r} never joins a trunk")
        girdles.append(int(parents[top]))
        legs.append(tuple(reversed(chain)))
    fore_g, hind_g = girdles[0], girdles[2]
    if girdles[1] != fore_g or girdles[3] != hind_g:
        raise ValueError("the left and right legs join the trunk at different joints: "
                         f"{', '.join(f'{n} at {skeleton.names[g]}' for n, g in zip(LEGS, girdles))}")
    if fore_g == hind_g:
        raise ValueError(f"all four legs join the trunk at {skeleton.names[fore_g]!r}; "
                         "a quadruped's fore and hind legs hang from different girdles")
    up_f, up_h = _path_up(parents, fore_g), _path_up(parents, hind_g)
    if hind_g in up_f:
        spine = list(reversed(up_f[:up_f.index(hind_g) + 1]))
    elif fore_g in up_h:
        spine = up_h[:up_h.index(fore_g) + 1]
    else:
        common = next(j for j in up_f if j in up_h)
        spine = up_h[:up_h.index(common)] + list(reversed(up_f[:up_f.index(common) + 1]))
    seg = np.linalg.norm(np.diff(P[spine], axis=0), axis=1)
    along = np.concatenate([[0.0], np.cumsum(seg)])
    mid = spine[int(np.argmin(np.abs(along - 0.5 * along[-1])))] if len(spine) > 2 \
        else spine[0]
    used = set(feet) | {j for leg in legs for j in leg} | set(spine)
    ahead = [j for j in leaves if j not in used and fore_g in _path_up(parents, j)]
    if not ahead:
        raise ValueError(f"no head: no end joint hangs ahead of the withers "
                         f"({skeleton.names[fore_g]!r})")
    head = max(ahead, key=lambda j: (P[j, Z], -j))
    name = skeleton.names[head]
    tip = skeleton.end_sites.get(name)
    toes = np.array([skeleton.end_sites.get(skeleton.names[f], np.zeros(3)) for f in feet],
                    dtype=float)
    hind_top = [leg[0] for leg in legs[2:]]
    hip_h = float(np.mean(P[hind_top, Y] - P[list(feet[2:]), Y]))
    return Anatomy(feet=tuple(int(f) for f in feet), toe_offsets=toes,
                   legs=tuple(legs), pelvis=int(hind_g), withers=int(fore_g),
                   mid_spine=int(mid), spine=tuple(int(j) for j in spine), head=int(head),
                   head_tip=np.zeros(3) if tip is None else np.asarray(tip, float),
                   head_from_parent=tip is None or not np.any(tip),
                   hip_height=hip_h, names=skeleton.names)
