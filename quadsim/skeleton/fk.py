"""Forward kinematics, vectorised over any batch of frames (and characters)."""

from __future__ import annotations

import numpy as np

from quadsim.skeleton.skeleton import Skeleton


def forward_kinematics(
    skeleton: Skeleton, local_rotations: np.ndarray, root_positions: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """World rotations and positions of every joint.

    Parameters
    ----------
    skeleton : Skeleton
    local_rotations : array-like, shape (..., J, 3, 3)
        Rotation of each joint relative to its parent (the root's is its world
        orientation).
    root_positions : array-like, shape (..., 3)
        World position of the root joint (m).

    Returns
    -------
    world_rotations : ndarray, shape (..., J, 3, 3)
    world_positions : ndarray, shape (..., J, 3)
    """
    L = np.asarray(local_rotations, dtype=float)
    J = skeleton.n_joints
    if L.shape[-3:] != (J, 3, 3):
        raise ValueError(f"`local_rotations` has shape {L.shape}, expected (..., {J}, 3, 3)")
    root = np.asarray(root_positions, dtype=float)
    batch = np.broadcast_shapes(L.shape[:-3], root.shape[:-1])
    L = np.broadcast_to(L, batch + (J, 3, 3))
    G = np.empty(batch + (J, 3, 3))
    P = np.empty(batch + (J, 3))
    G[..., 0, :, :] = L[..., 0, :, :]
    P[..., 0, :] = root
    offsets = skeleton.offsets
    parents = skeleton.parents
    for idx in skeleton.depth_levels[1:]:
        par = parents[idx]
        Gp = G[..., par, :, :]
        G[..., idx, :, :] = Gp @ L[..., idx, :, :]
        P[..., idx, :] = P[..., par, :] + np.einsum("...ij,...j->...i", Gp, offsets[idx])
    return G, P


def end_site_positions(
    skeleton: Skeleton, world_rotations: np.ndarray, world_positions: np.ndarray
) -> dict[str, np.ndarray]:
    """World positions of the end sites, each of shape (..., 3)."""
    out = {}
    for name, off in skeleton.end_sites.items():
        j = skeleton.index(name)
        out[name] = world_positions[..., j, :] + world_rotations[..., j, :, :] @ off
    return out
