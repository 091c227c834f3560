"""A renderable body: shaded capsule bones and joint spheres in one mesh.

The body is built once, in the bones' own frames: every vertex belongs to one
joint (its *owner*) and is stored in that joint's local frame. Posing is then
one vectorised transform of all vertices by their owners' world rotations and
positions (from forward kinematics), written into a single
:class:`pyvista.PolyData` -- one actor, whatever the number of bones.

- A bone from joint ``p`` to its child ``j`` is a tapered cylinder from the
  origin to ``offsets[j]`` in ``p``'s frame, owned by ``p``; an end site of a
  leaf joint ``j`` is one from the origin to ``end_sites[j]`` owned by ``j``.
- Each joint is a sphere, as wide as the widest bone end meeting there, so
  cylinders and spheres read as capsules.
- Radii follow the body part (torso, neck, head, tail, legs) and scale with
  the hip height; parts come from a :class:`~quadsim.skeleton.character.Character`'s
  chains or, for a bare skeleton (a BVH file), from the joint names.

Only :meth:`BodyMesh.polydata` and :meth:`BodyMesh.update` touch pyvista; the
geometry itself is numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadsim.frames import LEGS, Y

__all__ = ["BODY_COLORS", "BodyMesh", "body_radii", "body_scale"]

#: Body colour (RGB in [0, 1]) by character identifier or species word.
BODY_COLORS = {
    "leopard": (0.86, 0.64, 0.30),
    "leopard_cub": (0.90, 0.74, 0.45),
    "dog_cub": (0.62, 0.44, 0.28),
    "horse": (0.50, 0.30, 0.18),
}
DEFAULT_COLOR = (0.70, 0.66, 0.60)

# Radius of each part as a fraction of the hip height: (at the part's start, at its end).
_RADIUS = {
    "torso": (0.17, 0.23),
    "neck": (0.12, 0.085),
    "head": (0.085, 0.05),
    "tail": (0.045, 0.014),
    "girdle": (0.08, 0.07),
    "leg": (0.085, 0.028),
}
# Shade of each part relative to the body colour.
_SHADE = {"torso": 1.0, "neck": 1.0, "head": 1.03, "tail": 0.92, "girdle": 1.0, "leg": 0.86}


def _roles(skeleton, character=None) -> tuple[list[str], np.ndarray]:
    """Body part of each joint's outgoing bones, and its position along the part (0 to 1).

    With a character its chains decide; otherwise the joint names do
    (``spine``/``pelvis``/``chest``, ``neck``, ``head``, ``tail`` and the leg
    prefixes ``LF_``, ``RF_``, ``LH_``, ``RH_``).
    """
    J = skeleton.n_joints
    role = ["torso"] * J
    along = np.zeros(J)

    def mark(idx, name):
        idx = list(idx)
        n = max(len(idx) - 1, 1)
        for k, j in enumerate(idx):
            role[j] = name
            along[j] = k / n

    if character is not None:
        mark(character.spine, "torso")
        mark(character.neck, "neck")
        role[character.head] = "head"
        mark(character.tail, "tail")
        for leg in character.legs:
            mark(leg.chain, "leg")
        return role, along
    names = [n.lower() for n in skeleton.names]
    groups: dict[str, list[int]] = {}
    for j, n in enumerate(names):
        if any(n.startswith(p.lower() + "_") for p in LEGS):
            key = "leg:" + n[:2]
        elif "tail" in n:
            key = "tail"
        elif "neck" in n:
            key = "neck"
        elif "head" in n or "skull" in n:
            key = "head"
        else:
            key = "torso"
        groups.setdefault(key, []).append(j)
    for key, idx in groups.items():
        mark(idx, key.split(":")[0])
    return role, along


def body_scale(skeleton, character=None) -> float:
    """Length scale of the body: the hip height (m)."""
    if character is not None:
        return float(character.hip_height)
    P = skeleton.rest_positions
    h = float(np.ptp(P[:, Y])) if len(P) > 1 else 1.0
    return max(0.75 * h, 1e-3)


def body_radii(skeleton, character=None, *, thickness: float = 1.0) -> tuple[np.ndarray,
                                                                             np.ndarray]:
    """Radius at the start and at the end of each joint's outgoing bones.

    Parameters
    ----------
    skeleton : Skeleton
    character : Character, optional
        Its chains name the parts; without it the joint names do.
    thickness : float
        Multiplies every radius.

    Returns
    -------
    r_start, r_end : ndarray, shape (J,)
        Metres. The bones from joint ``j`` to its children start at
        ``r_start[j]``; an end site of ``j`` runs from ``r_start[j]`` to
        ``r_end[j]``.
    """
    role, along = _roles(skeleton, character)
    h = body_scale(skeleton, character)
    lo = np.array([_RADIUS[r][0] for r in role])
    hi = np.array([_RADIUS[r][1] for r in role])
    r0 = (lo + (hi - lo) * along) * h * thickness
    r1 = r0.copy()
    # the end of a joint's bone is the start of its child's, within one part
    for j in range(1, skeleton.n_joints):
        p = skeleton.parents[j]
        if role[p] == role[j]:
            r1[p] = r0[j]
    # girdle links (spine to scapula or hip) are the limb's top, slimmer than the torso
    if character is not None:
        for leg in character.legs:
            top = leg.chain[0]
            r0[top] = 0.75 * _RADIUS["leg"][0] * h * thickness
    ends = np.array([_RADIUS[r][1] for r in role]) * h * thickness
    leaf = np.array([len(c) == 0 for c in skeleton.children])
    r1 = np.where(leaf, np.minimum(r0, ends), r1)
    return r0, r1


def _frames(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors perpendicular to each unit direction ``d`` (n, 3)."""
    helper = np.where(np.abs(d[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(d, helper)
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    v = np.cross(d, u)
    return u, v


def _sphere_template(n_lat: int, n_lon: int) -> tuple[np.ndarray, np.ndarray]:
    """A unit UV sphere: points (n, 3) and triangles (m, 3)."""
    lat = np.linspace(0.0, np.pi, n_lat + 1)[1:-1]
    lon = np.linspace(0.0, 2 * np.pi, n_lon, endpoint=False)
    ring = np.stack([np.sin(lat)[:, None] * np.cos(lon), np.cos(lat)[:, None] * np.ones_like(lon),
                     np.sin(lat)[:, None] * np.sin(lon)], axis=-1).reshape(-1, 3)
    pts = np.vstack([[0.0, 1.0, 0.0], ring, [0.0, -1.0, 0.0]])
    n_ring = len(lat)
    k = np.arange(n_lon)
    k1 = (k + 1) % n_lon
    tris = [np.stack([np.zeros(n_lon, int), 1 + k1, 1 + k], axis=-1)]
    for r in range(n_ring - 1):
        a, b = 1 + r * n_lon, 1 + (r + 1) * n_lon
        tris.append(np.stack([a + k, a + k1, b + k1], axis=-1))
        tris.append(np.stack([a + k, b + k1, b + k], axis=-1))
    last = len(pts) - 1
    a = 1 + (n_ring - 1) * n_lon
    tris.append(np.stack([np.full(n_lon, last), a + k, a + k1], axis=-1))
    return pts, np.vstack(tris)


@dataclass(frozen=True, eq=False)
class BodyMesh:
    """Triangles of a body in its joints' local frames, posed by forward kinematics.

    Build it with :meth:`from_character` or :meth:`from_skeleton`.

    Attributes
    ----------
    points : ndarray, shape (V, 3)
        Vertex positions in their owner joint's frame (m).
    normals : ndarray, shape (V, 3)
        Unit vertex normals in the owner's frame.
    owner : ndarray of int, shape (V,)
        Joint whose world transform moves each vertex.
    faces : ndarray of int, shape (F, 3)
        Triangles (vertex indices).
    colors : ndarray of uint8, shape (V, 3)
        RGB per vertex.
    n_joints : int
    focus : ndarray of int, shape (k,)
        The trunk's joints (not the legs or the tail): cameras aim at their mean.
    """

    points: np.ndarray
    normals: np.ndarray
    owner: np.ndarray
    faces: np.ndarray
    colors: np.ndarray
    n_joints: int
    focus: np.ndarray

    @classmethod
    def from_character(cls, character, *, sides: int = 8, thickness: float = 1.0,
                       color=None) -> BodyMesh:
        """The body of a character: its chains name the parts, its id picks the colour."""
        if color is None:
            color = BODY_COLORS.get(character.id, DEFAULT_COLOR)
        return cls._build(character.skeleton, character, sides, thickness, color)

    @classmethod
    def from_skeleton(cls, skeleton, *, sides: int = 8, thickness: float = 1.0,
                      color=None) -> BodyMesh:
        """The body of a bare skeleton; parts are guessed from the joint names."""
        return cls._build(skeleton, None, sides, thickness, color or DEFAULT_COLOR)

    @classmethod
    def _build(cls, skeleton, character, sides, thickness, color) -> BodyMesh:
        if int(sides) < 3:
            raise ValueError(f"`sides` must be at least 3, got {sides!r}")
        sides = int(sides)
        role, _ = _roles(skeleton, character)
        r0, r1 = body_radii(skeleton, character, thickness=thickness)
        base = np.clip(np.asarray(color, dtype=float).reshape(3), 0.0, 1.0)
        shade = np.array([_SHADE[r] for r in role])

        # bones: (owner, end point in the owner's frame, start radius, end radius, shade)
        J = skeleton.n_joints
        child = np.arange(1, J)
        own = list(skeleton.parents[child])
        ends = list(skeleton.offsets[child])
        ra = list(r0[skeleton.parents[child]])
        rb = list(r0[child])
        sh = list(shade[child])
        for name, off in skeleton.end_sites.items():
            j = skeleton.index(name)
            own.append(j)
            ends.append(off)
            ra.append(r0[j])
            rb.append(r1[j])
            sh.append(shade[j])
        own = np.asarray(own, dtype=np.int64)
        ends = np.asarray(ends, dtype=float).reshape(-1, 3)
        ra, rb, sh = (np.asarray(x, dtype=float) for x in (ra, rb, sh))
        length = np.linalg.norm(ends, axis=-1)
        keep = length > 1e-9
        own, ends, ra, rb, sh, length = (x[keep] for x in (own, ends, ra, rb, sh, length))
        d = ends / length[:, None]
        u, v = _frames(d)
        ang = 2 * np.pi * np.arange(sides) / sides
        circ = (np.cos(ang)[None, :, None] * u[:, None, :]
                + np.sin(ang)[None, :, None] * v[:, None, :])           # (B, S, 3)
        ring0 = ra[:, None, None] * circ
        ring1 = ends[:, None, :] + rb[:, None, None] * circ
        slope = ((ra - rb) / length)[:, None, None]
        nrm = circ + slope * d[:, None, :]
        nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
        B = len(own)
        bone_pts = np.concatenate([ring0, ring1], axis=1).reshape(-1, 3)   # (B * 2S, 3)
        bone_nrm = np.concatenate([nrm, nrm], axis=1).reshape(-1, 3)
        bone_own = np.repeat(own, 2 * sides)
        bone_shade = np.repeat(sh, 2 * sides)
        k = np.arange(sides)
        k1 = (k + 1) % sides
        quad = np.concatenate([np.stack([k, k1, sides + k1], -1),
                               np.stack([k, sides + k1, sides + k], -1)])  # (2S, 3)
        bone_faces = (quad[None] + (2 * sides * np.arange(B))[:, None, None]).reshape(-1, 3)

        # joint spheres: as wide as the widest bone end meeting at the joint
        rad = r0.copy()
        np.maximum.at(rad, np.asarray(skeleton.parents[child]), r0[skeleton.parents[child]])
        np.maximum.at(rad, child, r0[child])
        rad = np.maximum(rad, r1 * (np.array([len(c) == 0 for c in skeleton.children])))
        n_lat, n_lon = max(4, sides // 2), sides
        sp, st = _sphere_template(n_lat, n_lon)
        nv = len(sp)
        sph_pts = (rad[:, None, None] * sp[None]).reshape(-1, 3)
        sph_nrm = np.broadcast_to(sp, (J, nv, 3)).reshape(-1, 3)
        sph_own = np.repeat(np.arange(J), nv)
        sph_shade = np.repeat(shade, nv)
        sph_faces = (st[None] + (len(bone_pts) + nv * np.arange(J))[:, None, None]).reshape(-1, 3)

        points = np.vstack([bone_pts, sph_pts])
        normals = np.vstack([bone_nrm, sph_nrm])
        owner = np.concatenate([bone_own, sph_own])
        faces = np.vstack([bone_faces, sph_faces]).astype(np.int64)
        rgb = np.clip(np.concatenate([bone_shade, sph_shade])[:, None] * base, 0.0, 1.0)
        colors = np.round(rgb * 255).astype(np.uint8)
        focus = np.array([j for j, r in enumerate(role) if r not in ("leg", "tail")],
                         dtype=np.int64)
        if len(focus) == 0:
            focus = np.arange(J)
        for a in (points, normals, owner, faces, colors, focus):
            a.setflags(write=False)
        return cls(points, normals, owner, faces, colors, J, focus)

    @property
    def n_points(self) -> int:
        return len(self.points)

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
        Go = G[self.owner]
        pts = np.einsum("vij,vj->vi", Go, self.points) + P[self.owner]
        nrm = np.einsum("vij,vj->vi", Go, self.normals)
        return pts, nrm

    def polydata(self, world_rotations=None, world_positions=None):
        """A :class:`pyvista.PolyData` of the body, in the given pose if any.

        Point data: ``"Normals"`` (active normals) and ``"rgb"`` (uint8 colours;
        add it with ``scalars="rgb", rgb=True``). Without a pose every vertex
        is at the origin until :meth:`update` poses the mesh in place.
        """
        import pyvista as pv

        faces = np.hstack([np.full((len(self.faces), 1), 3), self.faces]).ravel()
        mesh = pv.PolyData(np.zeros((self.n_points, 3)), faces=faces)
        mesh.point_data["rgb"] = np.asarray(self.colors)
        mesh.point_data["Normals"] = np.zeros((self.n_points, 3))
        mesh.point_data.active_normals_name = "Normals"
        if world_rotations is not None:
            self.update(mesh, world_rotations, world_positions)
        return mesh

    def update(self, mesh, world_rotations, world_positions) -> None:
        """Pose ``mesh`` (from :meth:`polydata`) in place: one array write for all bones."""
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
