"""A renderable body: quadsim's one procedural mesh, posed by linear blend skinning.

The mesh is :func:`quadsim.mesh.skinned_body` (the same as the glTF
export's): a smooth skin around the skeleton, shaped by the character's
profile, with up to four joint influences per vertex. Posing is linear blend
skinning of the rest mesh (:class:`quadsim.mesh.Skin`): one matrix product
blends the joints' transforms per vertex, one batched product moves the
vertices and normals, written into a single :class:`pyvista.PolyData` -- one
actor, whatever the number of bones.

Only :meth:`BodyMesh.polydata` and :meth:`BodyMesh.update` touch pyvista; the
geometry itself is numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadsim.frames import Y
from quadsim.mesh import Skin, skinned_body
from quadsim.mesh.profiles import BODY_COLORS, DEFAULT_COLOR, profile_for_id

__all__ = ["BODY_COLORS", "BodyMesh", "body_scale"]


def body_scale(skeleton, character=None) -> float:
    """Length scale of the body: the hip height (m)."""
    if character is not None:
        return float(character.hip_height)
    P = skeleton.rest_positions
    h = float(np.ptp(P[:, Y])) if len(P) > 1 else 1.0
    return max(0.75 * h, 1e-3)


def _focus(skeleton) -> np.ndarray:
    """The trunk's, neck's and head's joints (cameras aim at their mean)."""
    from quadsim.skeleton.anatomy import find_anatomy

    try:
        a = find_anatomy(skeleton)
    except ValueError:
        return np.arange(skeleton.n_joints)
    out = set(a.spine) | {a.head}
    j = a.head
    while j >= 0 and j != a.withers:
        out.add(j)
        j = int(skeleton.parents[j])
    return np.array(sorted(out), dtype=np.int64)


@dataclass(frozen=True, eq=False)
class BodyMesh:
    """The skinned body of a skeleton, posed by forward kinematics and blend skinning.

    Build it with :meth:`from_character` or :meth:`from_skeleton`.

    Attributes
    ----------
    points : ndarray, shape (V, 3)
        Vertex positions at rest, in the world (m).
    normals : ndarray, shape (V, 3)
        Unit vertex normals at rest.
    joints : ndarray of int, shape (V, 4)
        Influences of each vertex, by decreasing weight.
    weights : ndarray, shape (V, 4)
        Their weights, each row summing to 1.
    faces : ndarray of int, shape (F, 3)
        Triangles (vertex indices).
    colors : ndarray of uint8, shape (V, 3)
        RGB per vertex.
    n_joints : int
    focus : ndarray of int, shape (k,)
        The trunk's joints (not the legs or the tail): cameras aim at their mean.
    skin : Skin
        The blend skinning of :attr:`points`.
    """

    points: np.ndarray
    normals: np.ndarray
    joints: np.ndarray
    weights: np.ndarray
    faces: np.ndarray
    colors: np.ndarray
    n_joints: int
    focus: np.ndarray
    skin: Skin

    @classmethod
    def from_character(cls, character, *, color=None) -> BodyMesh:
        """The body of a character: its id picks the profile and the colour."""
        return cls._build(character.skeleton, profile_for_id(character.id), color)

    @classmethod
    def from_skeleton(cls, skeleton, *, color=None) -> BodyMesh:
        """The body of a bare skeleton: the shipped character's if it is one, else generic."""
        return cls._build(skeleton, None, color)

    @classmethod
    def _build(cls, skeleton, profile, color) -> BodyMesh:
        body = skinned_body(skeleton, profile)
        rgb = np.asarray(body.colors, dtype=float)
        if color is not None:
            from quadsim.mesh.profiles import PROFILES

            base = PROFILES.get(body.profile)
            base = np.asarray(base.color if base is not None else DEFAULT_COLOR)
            want = np.clip(np.asarray(color, dtype=float).reshape(3), 0.0, 1.0)
            rgb = rgb * want / np.maximum(base, 1e-3)
        colors = np.round(np.clip(rgb, 0.0, 1.0) * 255).astype(np.uint8)
        focus = _focus(skeleton)
        skin = Skin.from_influences(body.positions, body.normals, body.joints, body.weights,
                                    skeleton.rest_positions)
        colors.setflags(write=False)
        focus.setflags(write=False)
        return cls(body.positions, body.normals, body.joints, body.weights, body.triangles,
                   colors, skeleton.n_joints, focus, skin)

    @property
    def n_points(self) -> int:
        return len(self.points)

    @property
    def owner(self) -> np.ndarray:
        """The joint of largest weight of each vertex, shape (V,)."""
        return self.joints[:, 0]

    def posed(self, world_rotations, world_positions) -> tuple[np.ndarray, np.ndarray]:
        """Vertex positions and normals in the world for one pose.

        Parameters
        ----------
        world_rotations : array-like, shape (J, 3, 3)
        world_positions : array-like, shape (J, 3)

        Returns
        -------
        points, normals : ndarray, shape (V, 3)
        """
        G = np.asarray(world_rotations, dtype=float)
        P = np.asarray(world_positions, dtype=float)
        if G.shape != (self.n_joints, 3, 3):
            raise ValueError(f"`world_rotations` has shape {G.shape}, "
                             f"expected ({self.n_joints}, 3, 3)")
        if P.shape != (self.n_joints, 3):
            raise ValueError(f"`world_positions` has shape {P.shape}, "
                             f"expected ({self.n_joints}, 3)")
        return self.skin.pose(G, P)

    def polydata(self, world_rotations=None, world_positions=None):
        """A :class:`pyvista.PolyData` of the body, in the given pose if any.

        Point data: ``"Normals"`` (active normals) and ``"rgb"`` (uint8 colours;
        add it with ``scalars="rgb", rgb=True``). Without a pose the mesh is
        at rest until :meth:`update` poses it in place.
        """
        import pyvista as pv

        faces = np.hstack([np.full((len(self.faces), 1), 3), self.faces]).ravel()
        mesh = pv.PolyData(np.array(self.points), faces=faces)
        mesh.point_data["rgb"] = np.asarray(self.colors)
        mesh.point_data["Normals"] = np.array(self.normals)
        mesh.point_data.active_normals_name = "Normals"
        if world_rotations is not None:
            self.update(mesh, world_rotations, world_positions)
        return mesh

    def update(self, mesh, world_rotations, world_positions) -> None:
        """Pose ``mesh`` (from :meth:`polydata`) in place: one array write for all vertices."""
        pts, nrm = self.posed(world_rotations, world_positions)
        mesh.points[:] = pts
        mesh.point_data["Normals"][:] = nrm
        mesh.GetPoints().Modified()
        mesh.GetPointData().GetNormals().Modified()
        mesh.Modified()

    def bounds(self, world_rotations, world_positions) -> np.ndarray:
        """Axis-aligned bounds of the posed body, ``[[xmin, ymin, zmin], [xmax, ymax, zmax]]``."""
        pts, _ = self.posed(world_rotations, world_positions)
        return np.stack([pts.min(axis=0), pts.max(axis=0)])
