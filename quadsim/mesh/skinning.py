"""Skin weights and linear blend skinning, vectorised over the vertices.

The bind pose is the skeleton's rest pose, where every joint's rotation is
the identity: a vertex ``x`` at rest moves with joint ``j`` to
``G_j (x - B_j) + P_j`` (``B_j`` the joint's rest position, ``G_j`` and
``P_j`` its world rotation and position). Linear blend skinning sums these
over the vertex's influences with its weights; :class:`Skin` does it for all
vertices: the blended 3x4 transform of every vertex (one sparse product of
the weights with the joints' transforms, scipy), then one batched
matrix-vector product.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MIN_SHARE", "Skin", "top_weights"]

#: Influences below this fraction of a vertex's largest weight are dropped.
MIN_SHARE = 0.02


def top_weights(W: np.ndarray, n: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """The ``n`` largest weights of each row, renormalised to sum to 1.

    Parameters
    ----------
    W : ndarray, shape (V, J)
        Non-negative weights, not all zero in a row.
    n : int

    Weights below :data:`MIN_SHARE` of the row's largest are dropped.

    Returns
    -------
    joints : ndarray of int, shape (V, 4)
        By decreasing weight; slots of zero weight hold joint 0.
    weights : ndarray, shape (V, 4)
        Zero-padded to four slots.
    """
    W = np.asarray(W, dtype=float)
    n = min(n, W.shape[1])
    order = np.argsort(-W, axis=1, kind="stable")[:, :n]
    w = np.take_along_axis(W, order, axis=1)
    w = np.where(w > MIN_SHARE * w[:, :1], w, 0.0)
    w /= w.sum(axis=1, keepdims=True)
    order = np.where(w > 0, order, 0)
    if n < 4:
        pad = 4 - n
        order = np.pad(order, ((0, 0), (0, pad)))
        w = np.pad(w, ((0, 0), (0, pad)))
    return order.astype(np.int64), w


@dataclass(frozen=True, eq=False)
class Skin:
    """Linear blend skinning of a rest mesh.

    Attributes
    ----------
    rest_points, rest_normals : ndarray, shape (V, 3)
    joints : ndarray of int, shape (V, 4)
    weights : ndarray, shape (V, 4)
        Each row sums to 1; unused slots 0.
    bind : ndarray, shape (J, 3)
        Joint rest positions (m).
    matrix : scipy.sparse.csr_matrix, shape (V, J)
        The same weights as a sparse matrix: one product blends the joints'
        transforms for every vertex.
    """

    rest_points: np.ndarray
    rest_normals: np.ndarray
    joints: np.ndarray
    weights: np.ndarray
    bind: np.ndarray
    matrix: object

    @classmethod
    def from_influences(cls, points, normals, joints, weights, bind) -> Skin:
        """From per-vertex influences (V, 4) and the joints' rest positions (J, 3)."""
        from scipy.sparse import csr_matrix

        joints = np.asarray(joints, dtype=np.int64)
        weights = np.asarray(weights, dtype=float)
        bind = np.asarray(bind, dtype=float)
        V, k = joints.shape
        M = csr_matrix((weights.ravel(), (np.repeat(np.arange(V), k), joints.ravel())),
                       shape=(V, len(bind)))
        M.eliminate_zeros()
        return cls(np.asarray(points, dtype=float), np.asarray(normals, dtype=float),
                   joints, weights, bind, M)

    def pose(self, world_rotations, world_positions) -> tuple[np.ndarray, np.ndarray]:
        """Skinned vertex positions (V, 3) and unit normals (V, 3) for one pose.

        Parameters
        ----------
        world_rotations : ndarray, shape (J, 3, 3)
        world_positions : ndarray, shape (J, 3)
        """
        G = np.asarray(world_rotations, dtype=float)
        P = np.asarray(world_positions, dtype=float)
        t = P - np.einsum("jab,jb->ja", G, self.bind)
        A = self.matrix @ np.concatenate([G.reshape(-1, 9), t], axis=1)   # (V, 12)
        x, n = self.rest_points, self.rest_normals
        pts = A[:, 9:] + A[:, 0:9:3] * x[:, :1] + A[:, 1:9:3] * x[:, 1:2] \
            + A[:, 2:9:3] * x[:, 2:]
        nrm = A[:, 0:9:3] * n[:, :1] + A[:, 1:9:3] * n[:, 1:2] + A[:, 2:9:3] * n[:, 2:]
        nrm /= np.maximum(np.sqrt(np.einsum("vi,vi->v", nrm, nrm)), 1e-12)[:, None]
        return pts, nrm
