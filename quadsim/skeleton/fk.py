"""Forward kinematics over any batch of frames (and characters), as one compiled loop."""

from __future__ import annotations

import weakref

import numpy as np
from numba import njit

from quadsim.kinematics.chains import fk_joint
from quadsim.skeleton.skeleton import Skeleton


def forward_kinematics(
    skeleton: Skeleton, local_rotations: np.ndarray, root_positions: np.ndarray,
    joints: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """World rotations and positions of every joint (or of some).

    Parameters
    ----------
    skeleton : Skeleton
    local_rotations : array-like, shape (..., J, 3, 3)
        Rotation of each joint relative to its parent (the root's is its world
        orientation).
    root_positions : array-like, shape (..., 3)
        World position of the root joint (m).
    joints : array-like of int, shape (M,), optional
        Only these joints, which must include the parent of each (so the
        root): the trunk a leg hangs from, say. Default: all J.

    Returns
    -------
    world_rotations : ndarray, shape (..., J, 3, 3) (or (..., M, 3, 3))
    world_positions : ndarray, shape (..., J, 3) (or (..., M, 3))

    Notes
    -----
    The frames (or characters) are walked by a compiled loop
    (:func:`_fk_frames`), each joint after its parent.
    """
    L = np.asarray(local_rotations, dtype=float)
    J = skeleton.n_joints
    if L.shape[-3:] != (J, 3, 3):
        raise ValueError(f"`local_rotations` has shape {L.shape}, expected (..., {J}, 3, 3)")
    root = np.asarray(root_positions, dtype=float)
    batch = np.broadcast_shapes(L.shape[:-3], root.shape[:-1])
    B = int(np.prod(batch, dtype=np.int64))
    sel, up, off = skeleton_plan(skeleton, joints)
    M = len(sel)
    Lb = np.ascontiguousarray(np.broadcast_to(L, batch + (J, 3, 3)).reshape(B, J, 3, 3))
    rb = np.ascontiguousarray(np.broadcast_to(root, batch + (3,)).reshape(B, 3))
    G = np.empty((B, M, 3, 3))
    P = np.empty((B, M, 3))
    _fk_frames(sel, up, off, Lb, rb, G, P)
    return G.reshape(batch + (M, 3, 3)), P.reshape(batch + (M, 3))


@njit(cache=True)
def _fk_frames(sel, up, off, L, root, G, P):
    """Forward kinematics of B poses: joint ``sel[m]`` (m >= 1) from its parent at
    position ``up[m]`` of ``sel`` and its offset ``off[m]``; ``sel[0]`` is the root."""
    for b in range(L.shape[0]):
        for r in range(3):
            for c in range(3):
                G[b, 0, r, c] = L[b, sel[0], r, c]
            P[b, 0, r] = root[b, r]
        for m in range(1, sel.shape[0]):
            fk_joint(up[m], m, off[m], L[b, sel[m]], G[b], P[b])


#: per skeleton: its forward kinematics plans, by joint subset
_PLANS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def skeleton_plan(skeleton: Skeleton, joints=None) -> tuple:
    """The joints forward kinematics visits and how, cached per skeleton.

    Returns the joint indices ``sel`` (M,) in increasing order (a parent
    before its children), each one's parent as a position in ``sel`` (``up``,
    (M,), -1 for the root) and its rest offset (``off``, (M, 3), m).
    """
    key = None if joints is None else tuple(int(j) for j in joints)
    plans = _PLANS.setdefault(skeleton, {})
    hit = plans.get(key)
    if hit is not None:
        return hit
    J = skeleton.n_joints
    if joints is None:
        sel = np.arange(J, dtype=np.int64)
    else:
        sel = np.unique(np.asarray(joints, dtype=np.int64))
        if sel[0] != 0 or not np.all(np.isin(skeleton.parents[sel[1:]], sel)):
            raise ValueError("`joints` must hold the root and the parent of each joint")
    where = np.full(J, -1, dtype=np.int64)
    where[sel] = np.arange(len(sel))
    up = np.where(sel > 0, where[np.maximum(skeleton.parents[sel], 0)], -1).astype(np.int64)
    off = np.ascontiguousarray(skeleton.offsets[sel], dtype=float)
    out = plans[key] = (sel, up, off)
    return out


def end_site_positions(
    skeleton: Skeleton, world_rotations: np.ndarray, world_positions: np.ndarray
) -> dict[str, np.ndarray]:
    """World positions of the end sites, each of shape (..., 3)."""
    out = {}
    for name, off in skeleton.end_sites.items():
        j = skeleton.index(name)
        out[name] = world_positions[..., j, :] + world_rotations[..., j, :, :] @ off
    return out
