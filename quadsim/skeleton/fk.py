"""Forward kinematics, vectorised over any batch of frames (and characters)."""

from __future__ import annotations

import weakref

import numpy as np

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
    """
    L = np.asarray(local_rotations, dtype=float)
    J = skeleton.n_joints
    if L.shape[-3:] != (J, 3, 3):
        raise ValueError(f"`local_rotations` has shape {L.shape}, expected (..., {J}, 3, 3)")
    root = np.asarray(root_positions, dtype=float)
    batch = np.broadcast_shapes(L.shape[:-3], root.shape[:-1])
    B = int(np.prod(batch, dtype=np.int64))
    sel, levels = skeleton_levels(skeleton, joints)
    M = len(sel)
    # structure of arrays: element (r, c) of every joint's matrix, joints then
    # batch trailing, so each level's products run over long contiguous rows
    Lb = np.broadcast_to(L, batch + (J, 3, 3)).reshape(B, J, 3, 3)
    if M < J:
        Lb = Lb[:, sel]
    Ls = np.ascontiguousarray(Lb.transpose(2, 3, 1, 0))  # (3, 3, M, B)
    G = np.empty((3, 3, M, B))
    P = np.empty((3, M, B))
    G[:, :, 0] = Ls[:, :, 0]
    P[:, 0] = np.broadcast_to(root, batch + (3,)).reshape(B, 3).T
    for idx, par, off in levels:
        Gp = G[:, :, par]
        G[:, :, idx] = np.einsum("ikjb,klj b->iljb".replace(" ", ""), Gp, Ls[:, :, idx])
        P[:, idx] = P[:, par] + np.einsum("ikjb,kjb->ijb", Gp, off)
    return (G.transpose(3, 2, 0, 1).reshape(batch + (M, 3, 3)),
            P.transpose(2, 1, 0).reshape(batch + (M, 3)))


#: per skeleton: its forward kinematics plans, by joint subset
_LEVELS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def skeleton_levels(skeleton: Skeleton, joints=None) -> tuple:
    """The joints forward kinematics visits and its plan, cached per skeleton.

    Returns the joint indices ``sel`` (M,) and, per depth level below the
    root, the level's positions in ``sel``, its parents' positions and the
    offsets as a (3, n, 1) array.
    """
    key = None if joints is None else tuple(int(j) for j in joints)
    plans = _LEVELS.setdefault(skeleton, {})
    hit = plans.get(key)
    if hit is not None:
        return hit
    J = skeleton.n_joints
    if joints is None:
        sel = np.arange(J)
    else:
        sel = np.unique(np.asarray(joints, dtype=np.int64))
        if sel[0] != 0 or not np.all(np.isin(skeleton.parents[sel[1:]], sel)):
            raise ValueError("`joints` must hold the root and the parent of each joint")
    where = np.full(J, -1)
    where[sel] = np.arange(len(sel))
    levels = []
    for idx in skeleton.depth_levels[1:]:
        idx = idx[where[idx] >= 0]
        if len(idx):
            levels.append((where[idx], where[skeleton.parents[idx]],
                           skeleton.offsets[idx].T[:, :, None].copy()))
    out = plans[key] = (sel, tuple(levels))
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
