"""A user's rig read from glTF: the skin's joints, their rest transforms, the unit.

The first step of adopting a user's quadruped. :func:`read_gltf_rig` reads a
``.gltf`` (embedded or external buffers) or ``.glb`` file with
:mod:`pygltflib` and returns the :class:`Rig` of one skin: its joints in
parent-before-child order, each joint's rest transform relative to its
parent (a real rig's rest rotations and bone axes kept as they are) and in
the world (the nodes above the skin included), and the mesh it deforms.

:meth:`Rig.skeleton` gives the quadsim :class:`~quadsim.skeleton.skeleton.Skeleton`
standing where the rig stands: identity rest rotations, each joint's offset
its rest world position minus its parent's, in metres. A pose of that
skeleton carries over to the rig as world-space rotation changes
(:meth:`Rig.local_rotations`), so the rig's own rest pose, bone axes and
names stay untouched.

glTF is +Y up with metres as its unit, but exporters often leave the model
in centimetres (the Khronos Fox stands 79 units tall) or in Blender's +Z up:
the up and forward axes are found from the rig's shape
(:func:`~quadsim.io.rig_structure.detect_frame`), the unit from the standing
height along the up axis (:func:`guess_unit`), and both are reported. The
rig keeps its own frame and unit (:attr:`Rig.rest_world`); :attr:`Rig.axes`
turns it into quadsim's (+Y up, +Z forward, +X left).

:func:`quadsim.io.adopt.read_rig` reads either kind of file: glTF here, BVH
hierarchies with :func:`quadsim.io.bvh_rig.read_bvh_rig`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from quadsim.errors import InputError
from quadsim.io.rig_structure import detect_frame
from quadsim.kinematics.rotations import matrices_from_quaternions
from quadsim.skeleton.skeleton import Skeleton

__all__ = ["UNITS", "Rig", "foot_indices", "guess_unit", "read_gltf_rig"]

#: Length units a rig may be in, as metres per unit.
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
#: Plausible standing heights of a quadruped in metres (a mouse to a giraffe).
STANDING_HEIGHT = (0.03, 6.0)


@dataclass(frozen=True, eq=False)
class Rig:
    """One skin of a glTF file.

    Attributes
    ----------
    path : Path
        The file.
    names : tuple of str, length J
        Joint names, parents before children (unnamed joints get ``joint<N>``).
    nodes : ndarray of int, shape (J,)
        Each joint's node index in the file.
    parents : ndarray of int, shape (J,)
        Parent joint of each joint, -1 for the skin's top joint(s) -- which
        must be a single root.
    rest_local : ndarray, shape (J, 4, 4)
        Each joint's rest transform relative to its parent joint (the top
        joint's relative to the world, the nodes above it folded in), in the
        file's units.
    rest_world : ndarray, shape (J, 4, 4)
        Each joint's rest transform in the world, in the file's units.
    unit : str
        The unit judged from the standing height: ``"m"``, ``"cm"`` or ``"mm"``.
    vertex_count : int
        Vertices of the meshes this skin deforms.
    above : ndarray, shape (4, 4)
        World transform of the node above the root joint (identity when the
        root joint is a top node), in the file's units.
    axes : ndarray, shape (3, 3)
        Rotation from the rig's world to quadsim's: rows are the rig's left,
        up and forward directions.
    up, forward : str
        The rig's up and forward axes (``"+Y"``, ``"-Y"``...), for reports.
    frame_found : bool
        False when the axes could not be told from the shape (+Y up assumed).
    end_sites : dict of str to ndarray
        Bone tips of leaf joints in the joint's frame, file units (BVH).
    rotation_orders : tuple of str
        Each joint's rotation channel order (BVH; empty for glTF).
    """

    path: Path
    names: tuple[str, ...]
    nodes: np.ndarray
    parents: np.ndarray
    rest_local: np.ndarray
    rest_world: np.ndarray
    unit: str
    vertex_count: int
    above: np.ndarray
    axes: np.ndarray = field(default_factory=lambda: np.eye(3))
    up: str = "+Y"
    forward: str = "+Z"
    frame_found: bool = True
    end_sites: dict = field(default_factory=dict)
    rotation_orders: tuple = ()

    @property
    def is_bvh(self) -> bool:
        """Read from a BVH hierarchy (no mesh, identity rest rotations)."""
        return self.path.suffix.lower() == ".bvh"

    @property
    def scale(self) -> float:
        """Metres per file unit."""
        return UNITS[self.unit]

    @property
    def rest_positions(self) -> np.ndarray:
        """Rest world position of every joint in quadsim's frame (m), shape (J, 3)."""
        return self.rest_world[:, :3, 3] @ self.axes.T * self.scale

    def rig_frame(self, rotations: np.ndarray) -> np.ndarray:
        """World rotations (..., 3, 3) in quadsim's frame expressed in the rig's frame."""
        return self.axes.T @ rotations @ self.axes

    @property
    def rest_rotations(self) -> np.ndarray:
        """Rest world rotation of every joint, shape (J, 3, 3) (scale removed)."""
        M = self.rest_world[:, :3, :3]
        return M / np.linalg.norm(M, axis=1, keepdims=True)

    def skeleton(self) -> Skeleton:
        """The quadsim skeleton standing where the rig stands (identity rest rotations, m)."""
        P = self.rest_positions
        off = P.copy()
        off[1:] = P[1:] - P[self.parents[1:]]
        return Skeleton(self.names, self.parents, off)

    def local_rotations(self, world: np.ndarray) -> np.ndarray:
        """The rig's own local joint rotations for world rotations of :meth:`skeleton`.

        Parameters
        ----------
        world : ndarray, shape (..., J, 3, 3)
            World rotations of the quadsim skeleton's joints (identity at rest).

        Returns
        -------
        ndarray, shape (..., J, 3, 3)
            Each rig joint's rotation relative to its parent such that the rig
            joint turns by the same world rotation as the skeleton's joint:
            ``W_j = world_j R0_j`` with ``R0_j`` its rest world rotation
            (``world_j`` taken into the rig's frame).
        """
        W = self.rig_frame(world) @ self.rest_rotations
        out = np.empty_like(W)
        out[..., 0, :, :] = W[..., 0, :, :]
        p = self.parents[1:]
        out[..., 1:, :, :] = np.swapaxes(W[..., p, :, :], -1, -2) @ W[..., 1:, :, :]
        return out


def guess_unit(standing_height: float) -> str:
    """The unit in which ``standing_height`` (file units) is a quadruped's height.

    Metres when it is within :data:`STANDING_HEIGHT`, else centimetres, else
    millimetres.

    Raises
    ------
    InputError
        When no unit makes it a plausible height.
    """
    for unit, k in UNITS.items():
        if STANDING_HEIGHT[0] <= standing_height * k <= STANDING_HEIGHT[1]:
            return unit
    raise InputError(f"a rig {standing_height:.3g} units tall is no quadruped in metres, "
                     "centimetres or millimetres")


def _node_matrix(node) -> np.ndarray:
    M = np.eye(4)
    if node.matrix is not None:
        return np.asarray(node.matrix, dtype=float).reshape(4, 4).T  # column-major
    if node.scale is not None:
        M[:3, :3] = np.diag(node.scale)
    if node.rotation is not None:
        x, y, z, w = node.rotation
        M[:3, :3] = matrices_from_quaternions(np.array([w, x, y, z], dtype=float)) @ M[:3, :3]
    if node.translation is not None:
        M[:3, 3] = node.translation
    return M


def foot_indices(names, feet, path) -> list[int] | None:
    """Indices of the feet given by name, or None; :class:`InputError` for unknown names."""
    if feet is None:
        return None
    missing = [f for f in feet if f not in names]
    if missing:
        raise InputError(f"{path}: no joint named {', '.join(map(repr, missing))} "
                         "(the feet given by hand)")
    return [list(names).index(f) for f in feet]


def read_gltf_rig(path, skin: int = 0, feet=None) -> Rig:
    """Read the rig of skin ``skin`` from a ``.gltf`` or ``.glb`` file.

    Raises
    ------
    InputError
        For a missing or unreadable file, a file without skins, a skin index
        out of range, or a skin whose joints do not form one tree.
    """
    import pygltflib

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    try:
        g = pygltflib.GLTF2().load(str(path))
    except Exception as e:  # pygltflib raises many kinds on bad files
        raise InputError(f"{path}: not a readable glTF file ({type(e).__name__}: {e})") from None
    if g is None or not g.skins:
        raise InputError(f"{path}: the file has no skin (no rigged mesh) to adopt")
    if not 0 <= skin < len(g.skins):
        raise InputError(f"{path}: skin {skin} does not exist; the file has "
                         f"{len(g.skins)} skin(s)")
    joints = list(g.skins[skin].joints)
    parent_node = {c: i for i, n in enumerate(g.nodes) for c in (n.children or [])}
    world = {}

    def world_of(i):
        if i not in world:
            p = parent_node.get(i)
            M = _node_matrix(g.nodes[i])
            world[i] = M if p is None else world_of(p) @ M
        return world[i]

    in_skin = set(joints)

    def joint_parent(i):
        p = parent_node.get(i)
        while p is not None and p not in in_skin:
            p = parent_node.get(p)
        return p

    # parents before children: order by depth in the node tree
    def depth(i):
        d, p = 0, parent_node.get(i)
        while p is not None:
            d, p = d + 1, parent_node.get(p)
        return d

    order = sorted(joints, key=lambda i: (depth(i), joints.index(i)))
    roots = [i for i in order if joint_parent(i) is None]
    if len(roots) != 1:
        names = ", ".join(str(g.nodes[i].name or i) for i in roots)
        raise InputError(f"{path}: skin {skin} has {len(roots)} top joints ({names}); a rig "
                         "needs one root joint above all the others")
    index = {n: k for k, n in enumerate(order)}
    parents = np.array([-1 if joint_parent(i) is None else index[joint_parent(i)]
                        for i in order], dtype=np.int64)
    W = np.stack([world_of(i) for i in order])
    L = W.copy()
    L[1:] = np.linalg.inv(W[parents[1:]]) @ W[1:]
    names = tuple(g.nodes[i].name or f"joint{i}" for i in order)
    if len(set(names)) != len(names):
        seen: set[str] = set()
        names = tuple(n if not (n in seen or seen.add(n)) else f"{n}.{k}"
                      for k, n in enumerate(names))
    verts = 0
    for i, n in enumerate(g.nodes):
        if n.skin == skin and n.mesh is not None:
            for prim in g.meshes[n.mesh].primitives:
                verts += g.accessors[prim.attributes.POSITION].count
    frame = detect_frame(W[:, :3, 3], names, parents, foot_indices(names, feet, path))
    up = parent_node.get(order[0])
    return Rig(path=path, names=names, nodes=np.array(order, dtype=np.int64), parents=parents,
               rest_local=L, rest_world=W, unit=guess_unit(frame.height), vertex_count=verts,
               above=np.eye(4) if up is None else world_of(up), axes=frame.axes,
               up=frame.up, forward=frame.forward, frame_found=frame.found)
