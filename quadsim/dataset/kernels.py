"""Compiled steps of making a sweep's clips in batches.

:func:`quaternions_and_kinematics` turns one step of a batch's posed local
rotation matrices into what each clip's :class:`~quadsim.skeleton.motion.Motion`
holds and what measuring it needs: the unit quaternions the motion stores,
and the forward kinematics *of those quaternions* (world positions, and
the world rotations of the joints the measuring needs), while the step's matrices are still in the CPU's cache. It runs
the very kernels a lone motion runs --
:func:`~quadsim.kinematics.rotations.quaternion_from_matrix`, then
:func:`~quadsim.kinematics.rotations.matrix_from_quaternion` and
:func:`~quadsim.kinematics.chains.fk_joint` as
:meth:`Motion.world_positions <quadsim.skeleton.motion.Motion.world_positions>`
does -- element by element, so every number is the same to the last bit
(tests hold it).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from quadsim.kinematics.chains import fk_joint
from quadsim.kinematics.rotations import matrix_from_quaternion, quaternion_from_matrix

__all__ = ["quaternions_and_kinematics"]


@njit(cache=True)
def _step_rows(local, root, sel, up, off, keep, q, G, P, M, W):
    for b in range(local.shape[0]):
        for j in range(local.shape[1]):
            quaternion_from_matrix(local[b, j], q[b, j])
            matrix_from_quaternion(q[b, j], M[j])
        for r in range(3):
            for c in range(3):
                W[0, r, c] = M[sel[0], r, c]
            P[b, 0, r] = root[b, r]
        for m in range(1, sel.shape[0]):
            fk_joint(up[m], m, off[m], M[sel[m]], W, P[b])
        for k in range(keep.shape[0]):
            for r in range(3):
                for c in range(3):
                    G[b, k, r, c] = W[keep[k], r, c]


def quaternions_and_kinematics(local: np.ndarray, root: np.ndarray, plan: tuple,
                               keep: np.ndarray, q: np.ndarray, G: np.ndarray,
                               P: np.ndarray) -> None:
    """One frame of N poses: their quaternions and the forward kinematics of those.

    Parameters
    ----------
    local : ndarray, shape (N, J, 3, 3)
        Local rotation matrices (the root's its world orientation).
    root : ndarray, shape (N, 3)
        Root joint world positions (m).
    plan : tuple
        :func:`quadsim.skeleton.fk.skeleton_plan` of the skeleton (all joints).
    keep : ndarray of int, shape (K,)
        The joints whose world rotations are written to ``G`` (those the
        measuring needs: writing every joint's would cost more than finding
        them).
    q : ndarray, shape (N, J, 4)
        Written: :func:`~quadsim.kinematics.rotations.quaternions_from_matrices`
        of ``local`` (``w >= 0``).
    G : ndarray, shape (N, K, 3, 3)
        Written: world rotations of the joints ``keep``, from the matrices of ``q``.
    P : ndarray, shape (N, J, 3)
        Written: world positions of the joints (m), from the matrices of ``q``.

    The outputs may be strided views (one frame of clip-major arrays).
    """
    sel, up, off = plan
    J = local.shape[1]
    _step_rows(np.ascontiguousarray(local, dtype=float), np.ascontiguousarray(root, dtype=float),
               sel, up, off, np.asarray(keep, dtype=np.int64), q, G, P,
               np.empty((J, 3, 3)), np.empty((J, 3, 3)))
