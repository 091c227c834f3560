"""Write quadsim's motion into the user's own glTF model.

:func:`write_into_model` takes the model a :class:`~quadsim.io.rig.Rig` was
read from and one or more motions of :meth:`Rig.skeleton`, and writes a
``.glb`` holding the user's model as it was -- meshes, materials, textures,
skin, joint names, rest pose and its own animations -- with each motion
added as a named animation of the rig's joints:

- every joint's rotation, as the world-space change quadsim's skeleton made
  (:meth:`Rig.local_rotations`), so the rig's bone axes are kept;
- the root joint's translation, in the frame of the node above it and in
  the file's units;
- the rest translation and scale, held for the whole motion, of every joint
  whose translation or scale the model's own animations key (a Fox's hip),
  so that a viewer switching from one of the user's animations to quadsim's
  does not keep the other's hip where it left it (Blender keeps the pose of
  channels the new action does not key).

The output is one self-contained binary file: every buffer (data URIs,
``.bin`` files, a ``.glb`` chunk) is gathered into the binary chunk, images
(data URIs, or files beside a ``.gltf``) are embedded as buffer views, and ``byteStride`` is kept only on
buffer views that hold vertex attributes (the glTF specification forbids it
elsewhere; some exporters write it), so the file validates even when its
source did not.
"""

from __future__ import annotations

import mimetypes
import os
from pathlib import Path

import numpy as np

from quadsim.errors import InputError
from quadsim.io.atomic import atomic_write_bytes
from quadsim.io.rig import Rig
from quadsim.kinematics.rotations import quaternions_from_matrices

__all__ = ["world_changes", "write_into_model"]

_FLOAT = 5126  # glTF componentType FLOAT


class _Blob:
    """A growing binary chunk with 4-byte aligned pieces."""

    def __init__(self) -> None:
        self.parts: list[bytes] = []
        self.size = 0

    def add(self, data: bytes) -> int:
        pad = (-self.size) % 4
        if pad:
            self.parts.append(b"\0" * pad)
            self.size += pad
        start = self.size
        self.parts.append(data)
        self.size += len(data)
        return start

    def bytes(self) -> bytes:
        out = b"".join(self.parts)
        return out + b"\0" * ((-len(out)) % 4)


def _data_uri(uri: str) -> tuple[bytes, str]:
    """The bytes and media type of a ``data:`` URI (RFC 2397)."""
    import base64
    from urllib.parse import unquote_to_bytes

    head, _, payload = uri[5:].partition(",")
    mime = head.split(";", 1)[0] or "text/plain"
    if head.endswith(";base64"):
        return base64.b64decode(payload), mime
    return unquote_to_bytes(payload), mime


def _buffer_bytes(g, path: Path, k: int) -> bytes:
    buf = g.buffers[k]
    if buf.uri is None:
        data = g.binary_blob()
        if data is None:
            raise InputError(f"{path}: buffer {k} has no data")
        return bytes(data)
    if buf.uri.startswith("data:"):
        return _data_uri(buf.uri)[0]
    f = path.parent / buf.uri
    if not f.is_file():
        raise InputError(f"{path}: buffer {k} refers to {buf.uri!r}, which is not beside it")
    return f.read_bytes()


def _gather(g, path: Path) -> _Blob:
    """Every buffer view's bytes into one chunk; views re-pointed; strides checked."""
    import pygltflib

    buffers = [_buffer_bytes(g, path, k) for k in range(len(g.buffers))]
    blob = _Blob()
    vertex_views = set()
    for mesh in g.meshes:
        for prim in mesh.primitives:
            for name, acc in vars(prim.attributes).items():
                if acc is not None and not name.startswith("_"):
                    vertex_views.add(g.accessors[acc].bufferView)
            for target in prim.targets or []:
                fields = target if isinstance(target, dict) else vars(target)
                for acc in fields.values():
                    if isinstance(acc, int):
                        vertex_views.add(g.accessors[acc].bufferView)
    for i, view in enumerate(g.bufferViews):
        data = buffers[view.buffer][(view.byteOffset or 0):(view.byteOffset or 0)
                                    + view.byteLength]
        view.buffer = 0
        view.byteOffset = blob.add(data)
        if i not in vertex_views:
            view.byteStride = None
    for image in g.images or []:
        if image.uri is None:
            continue
        if image.uri.startswith("data:"):
            data, mime = _data_uri(image.uri)
        else:
            f = path.parent / image.uri
            if not f.is_file():
                raise InputError(f"{path}: image {image.uri!r} is not beside it")
            data = f.read_bytes()
            mime = mimetypes.guess_type(image.uri)[0] or "image/png"
        g.bufferViews.append(pygltflib.BufferView(buffer=0, byteOffset=blob.add(data),
                                                  byteLength=len(data)))
        image.bufferView = len(g.bufferViews) - 1
        image.mimeType = image.mimeType or mime
        image.uri = None
    return blob


def _accessor(g, blob: _Blob, array: np.ndarray, kind: str, with_range: bool = False) -> int:
    import pygltflib

    a = np.ascontiguousarray(array, dtype=np.float32)
    g.bufferViews.append(pygltflib.BufferView(buffer=0, byteOffset=blob.add(a.tobytes()),
                                              byteLength=a.nbytes))
    acc = pygltflib.Accessor(bufferView=len(g.bufferViews) - 1, componentType=_FLOAT,
                             count=len(a), type=kind)
    if with_range:
        acc.min = [float(x) for x in np.atleast_1d(a.min(axis=0))]
        acc.max = [float(x) for x in np.atleast_1d(a.max(axis=0))]
    g.accessors.append(acc)
    return len(g.accessors) - 1


def _unique(names: list[str], taken: set[str]) -> list[str]:
    out = []
    for n in names:
        cand, k = n, 2
        while cand in taken:
            cand, k = f"{n}_{k}", k + 1
        taken.add(cand)
        out.append(cand)
    return out


def world_changes(rig: Rig, motion, root_offset) -> tuple[np.ndarray, np.ndarray]:
    """The rig joints' world rotation changes from rest, shape (T, J, 3, 3), and the top
    joint's world position, shape (T, 3), both in the rig's own frame (file units), for a
    motion of a skeleton that shares joint names with the rig.

    A rig joint the motion has turns by the motion joint's world rotation; one it
    lacks turns with its nearest ancestor the motion has, and the joints above the
    motion's root keep their rest rotations, the top one moved so that the motion's
    root joint lands at the motion's root position plus ``root_offset`` (m, quadsim's
    frame).
    """
    mine = {n: k for k, n in enumerate(motion.skeleton.names)}
    G = motion.world_rotations()
    T = motion.n_frames
    root_name = motion.skeleton.names[0]
    if root_name not in rig.names:
        raise InputError(f"the motion's root joint {root_name!r} is not a joint of "
                         f"{rig.path.name}")
    source = np.full(len(rig.names), -1)
    for j, n in enumerate(rig.names):
        if n in mine:
            source[j] = mine[n]
        elif rig.parents[j] >= 0:
            source[j] = source[rig.parents[j]]
    D = np.broadcast_to(np.eye(3), (T, len(rig.names), 3, 3)).copy()
    has = source >= 0
    D[:, has] = G[:, source[has]]
    r = rig.names.index(root_name)
    P0 = rig.rest_positions
    top = np.asarray(motion.root_positions, float) + root_offset - (P0[r] - P0[0])
    return rig.rig_frame(D), (top @ rig.axes) / rig.scale


def _held_rest(g, rig: Rig) -> list[tuple[int, str, np.ndarray]]:
    """(node, "translation" or "scale", rest value (3,)) for every joint whose translation
    or scale one of the model's own animations keys (the top joint's translation is
    quadsim's own channel)."""
    keyed = {(c.target.node, c.target.path) for a in g.animations for c in a.channels
             if c.target is not None and c.target.node is not None}
    out = []
    for k, node in enumerate(rig.nodes):
        nd = g.nodes[node]
        for target, default in (("translation", 0.0), ("scale", 1.0)):
            if (node, target) in keyed and (k, target) != (0, "translation"):
                rest = getattr(nd, target)
                out.append((int(node), target,
                            np.asarray(rest if rest is not None else [default] * 3, float)))
    return out


def write_into_model(rig: Rig, motions, path: str | os.PathLike, *, names=None,
                     root_offset=(0.0, 0.0, 0.0)) -> Path:
    """Write the rig's model with ``motions`` added as named animations.

    Parameters
    ----------
    rig : Rig
        The rig, read from the model file (:func:`~quadsim.io.rig.read_gltf_rig`).
    motions : Motion or sequence of Motion
        Motions of a skeleton whose joints are rig joints by name (``rig.skeleton()``,
        or an adopted one rooted lower with joints of its own); rig joints it
        lacks follow their nearest ancestor it has.
    path : str or path-like
        The ``.glb`` to write (whole or not at all).
    names : sequence of str, optional
        Animation names; default ``quadsim`` (one motion) or ``quadsim_1``, ...
        Names the model already uses get a ``_2``, ``_3`` suffix.
    root_offset : array-like, shape (3,)
        Where the rig's joint of the motion's root stands relative to the
        motion's root position (m) -- an adopted skeleton stands with the
        rig's ground at y = 0.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        For a motion of another skeleton, an empty motion, or a model that
        cannot be read.
    """
    import pygltflib

    from quadsim.skeleton.motion import Motion

    motions = [motions] if isinstance(motions, Motion) else list(motions)
    if not motions:
        raise InputError("give at least one motion to write into the model")
    for m in motions:
        if m.skeleton.names[0] not in rig.names:
            raise InputError(f"a motion of another skeleton cannot animate {rig.path.name}: "
                             "make it from the rig's own skeleton (Rig.skeleton() or the "
                             "adopted character)")
        if m.n_frames < 1:
            raise InputError("a motion with no frame cannot be written")
    if names is None:
        names = ["quadsim"] if len(motions) == 1 else \
            [f"quadsim_{k + 1}" for k in range(len(motions))]
    names = list(names)
    if len(names) != len(motions):
        raise InputError(f"{len(names)} animation name(s) for {len(motions)} motion(s)")
    try:
        g = pygltflib.GLTF2().load(str(rig.path))
    except Exception as e:
        raise InputError(f"{rig.path}: not a readable glTF file ({e})") from None
    blob = _gather(g, rig.path)
    g.animations = list(g.animations or [])
    held = _held_rest(g, rig)
    names = _unique(names, {a.name for a in g.animations if a.name})
    above = rig.above
    above_rot = above[:3, :3] / np.linalg.norm(above[:3, :3], axis=0, keepdims=True)
    inv_above = np.linalg.inv(above)
    offset = np.asarray(root_offset, dtype=float)
    for motion, name in zip(motions, names):
        D, top = world_changes(rig, motion, offset)                  # (T, J, 3, 3), (T, 3)
        W = D @ rig.rest_rotations
        L = W.copy()
        p = rig.parents[1:]
        L[:, 1:] = np.swapaxes(W[:, p], -1, -2) @ W[:, 1:]
        L[:, 0] = above_rot.T @ W[:, 0]                              # root: in the node above
        q = quaternions_from_matrices(L)                             # (T, J, 4) w, x, y, z
        q = np.concatenate([q[..., 1:], q[..., :1]], axis=-1)        # glTF: x, y, z, w
        t = top @ inv_above[:3, :3].T + inv_above[:3, 3]
        times = np.arange(motion.n_frames, dtype=float) / motion.fps
        time_acc = _accessor(g, blob, times, "SCALAR", with_range=True)
        samplers, channels = [], []

        def channel(node, target, values, kind):
            samplers.append(pygltflib.AnimationSampler(
                input=time_acc, output=_accessor(g, blob, values, kind),
                interpolation="LINEAR"))
            channels.append(pygltflib.AnimationChannel(
                sampler=len(samplers) - 1,
                target=pygltflib.AnimationChannelTarget(node=int(node), path=target)))

        channel(rig.nodes[0], "translation", t, "VEC3")
        for j, node in enumerate(rig.nodes):
            channel(node, "rotation", q[:, j], "VEC4")
        for node, target, rest in held:
            channel(node, target, np.tile(rest, (motion.n_frames, 1)), "VEC3")
        g.animations.append(pygltflib.Animation(name=name, samplers=samplers,
                                                channels=channels))
    data = blob.bytes()
    g.buffers = [pygltflib.Buffer(byteLength=len(data))]
    g.set_binary_blob(data)
    out = Path(path)
    return atomic_write_bytes(out, b"".join(g.save_to_bytes()))
