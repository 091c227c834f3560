"""The glTF body: quadsim's one procedural body mesh (:mod:`quadsim.mesh`).

:func:`body_mesh` returns the skinned body of a skeleton in its rest (bind)
pose, in world coordinates, ready for a glTF skin (:mod:`quadsim.io.gltf`):
the same mesh the preview and ``render`` pose by linear blend skinning. The
shape comes from the profile of the shipped character whose skeleton this is
(matched up to scale), else from the default quadruped profile; a skeleton
that is not a quadruped's gets a smooth tube around every bone.

Weights: at most four influences per vertex, by decreasing weight, each row
summing to 1; unused slots hold joint 0 with weight 0, as glTF validators
expect.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadsim.mesh import skinned_body
from quadsim.skeleton.skeleton import Skeleton

__all__ = ["BodyMesh", "body_mesh"]


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


def body_mesh(skeleton: Skeleton, *, profile=None) -> BodyMesh:
    """The procedural body of a skeleton at rest, skinned with smooth weights.

    Parameters
    ----------
    skeleton : Skeleton
    profile : quadsim.mesh.Profile, optional
        The body's shape (default: found from the skeleton, see
        :func:`quadsim.mesh.profile_for`).

    Returns
    -------
    BodyMesh
    """
    b = skinned_body(skeleton, profile)
    return BodyMesh(b.positions, b.normals, b.joints, b.weights, b.triangles)
