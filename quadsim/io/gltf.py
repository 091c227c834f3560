"""glTF 2.0 binary (``.glb``) export: a skinned body and its animations.

What a file written by :func:`write_glb` holds:

- **Axes and units**: glTF's own (+Y up, +Z forward, metres), which are
  quadsim's, so nothing is converted. Lengths are always metres.
- **Nodes**: one per joint, in the skeleton's joint order (node ``j`` is joint
  ``j``), named after the joint, with the joint's rest offset as its
  translation and no rest rotation (quadsim's rest pose has identity local
  rotations). Node 0, the root joint, is a scene root; so is the body node.
- **Skin**: every joint node, in joint order, with inverse bind matrices
  (float32 ``MAT4``, column-major) of the rest pose: the inverse of each
  joint's rest world transform.
- **Body** (``body=True``): one mesh of capsules around the bones (see
  :mod:`quadsim.io.body_mesh`), skinned to the joints (``JOINTS_0``
  unsigned byte or short ``VEC4``, ``WEIGHTS_0`` float ``VEC4`` summing to 1),
  with ``POSITION`` (with min and max), ``NORMAL`` and triangle indices, on a
  node with no transform at the scene root, as the specification asks.
- **Animations**: one per motion, each with a rotation channel on every joint
  node (quaternions in glTF's ``(x, y, z, w)`` order, signs made continuous
  over time so that interpolation takes the short way) and a translation
  channel on the root node (the root's world position). Key times are
  ``frame / fps`` from 0, stored as float32 with exact min and max. The
  sampling is ``LINEAR`` (slerp between frames), ``STEP`` or
  ``CUBICSPLINE`` (Catmull-Rom tangents, per second).
- **Ground root** (``ground_root=True``, for game engines' root motion): one more
  node, ``root``, the scene root and the skin's last joint (identity bind), standing
  on the ground under the root joint and turned to its heading: its translation is
  the root joint's ``(x, 0, z)``, its rotation the heading about +Y (the motion's
  ``extras["heading"]``, rad; 0 without it); the root joint's keys are then relative
  to it. Joint ``j`` is still node ``j``.
- **Precision**: every number is float32. Joint world positions rebuilt from
  the file match the motion's within about ``1e-7`` times the distance from
  the origin (m), so within 1e-4 m for roots up to a few hundred metres away.

Every buffer view starts on a 4-byte boundary; the file is written to a
temporary file in the destination folder and then moved into place.
"""

from __future__ import annotations

import json
import os
import struct
from pathlib import Path

import numpy as np

from quadsim.errors import InputError
from quadsim.io.atomic import atomic_write_bytes
from quadsim.io.body_mesh import body_mesh
from quadsim.kinematics.rotations import quaternion_multiply
from quadsim.skeleton.motion import Motion

__all__ = ["SAMPLINGS", "write_glb"]

#: Animation sampler interpolations ``write_glb`` can write.
SAMPLINGS = ("LINEAR", "STEP", "CUBICSPLINE")

_GLB_MAGIC = 0x46546C67  # b"glTF"
_CHUNK_JSON = 0x4E4F534A
_CHUNK_BIN = 0x004E4942
_FLOAT, _UBYTE, _USHORT, _UINT = 5126, 5121, 5123, 5125
_COMPONENT = {_FLOAT: np.float32, _UBYTE: np.uint8, _USHORT: np.uint16, _UINT: np.uint32}
_TYPES = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4", 16: "MAT4"}
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
#: Largest offset between two motions' skeletons' bone offsets that still counts as the same (m).
_SAME_SKELETON_TOL = 1e-9


def write_glb(motions, path: str | os.PathLike, *, body: bool = True, names=None,
              sampling: str = "LINEAR", ground_root: bool = False) -> Path:
    """Write one or more motions of a skeleton as a glTF 2.0 binary file.

    Parameters
    ----------
    motions : Motion or sequence of Motion
        Motions of the same skeleton (same joint names, parents and offsets);
        each becomes one named animation. Each needs at least one frame.
    path : str or path-like
        Destination (``.glb`` by convention). An existing file is replaced only
        once the new one is complete.
    body : bool
        Add the procedural skinned body mesh (default). Without it the file
        holds the skeleton, its skin and the animations only.
    names : sequence of str, optional
        Animation names, one per motion. Default: the steady gaits each motion
        goes through, joined by ``+`` (``"walk+trot"``), or ``clip0``,
        ``clip1``, ... for motions without gait labels; repeated names get a
        ``_2``, ``_3`` suffix.
    sampling : {"LINEAR", "STEP", "CUBICSPLINE"}
        Interpolation between frames stored in the animation samplers.
    ground_root : bool
        Add the ``root`` node on the ground (see the module's notes).

    Returns
    -------
    Path
        The path written.

    Raises
    ------
    InputError
        No motion, motions of different skeletons, an empty motion, a bad
        ``names`` or ``sampling``, or a destination that cannot be written.
    """
    motions = _check_motions(motions)
    sampling = _check_sampling(sampling)
    names = _animation_names(motions, names)
    skel = motions[0].skeleton
    b = _Builder()

    J = skel.n_joints
    nodes = []
    for j in range(J):
        node = {"name": skel.names[j], "translation": _floats(skel.offsets[j])}
        kids = list(skel.children[j])
        if kids:
            node["children"] = kids
        nodes.append(node)
    rest = skel.rest_positions
    ibm = np.broadcast_to(np.eye(4), (J, 4, 4)).copy()
    ibm[:, :3, 3] = -rest
    skin = {"name": "skeleton", "joints": list(range(J)), "skeleton": 0}
    scene_nodes = [0]
    if ground_root:
        nodes.append({"name": "root", "children": [0]})
        ibm = np.concatenate([ibm, np.eye(4)[None]])
        skin["joints"].append(J)
        skin["skeleton"] = scene_nodes[0] = J
    # column-major: the transpose of each matrix, flattened row by row
    skin["inverseBindMatrices"] = b.accessor(
        np.ascontiguousarray(ibm.transpose(0, 2, 1)).reshape(len(ibm), 16), _FLOAT,
        name="inverse bind matrices")
    gltf: dict = {
        "asset": {"version": "2.0", "generator": _generator()},
        "scene": 0,
        "nodes": nodes,
        "skins": [skin],
    }
    if body:
        mesh = _mesh(b, skel)
        if mesh is not None:
            gltf["meshes"] = [mesh]
            gltf["materials"] = [{
                "name": "body",
                "pbrMetallicRoughness": {"baseColorFactor": [0.76, 0.6, 0.38, 1.0],
                                         "metallicFactor": 0.0, "roughnessFactor": 0.8},
            }]
            nodes.append({"name": "body", "mesh": 0, "skin": 0})
            scene_nodes.append(len(nodes) - 1)
    gltf["scenes"] = [{"name": "quadsim", "nodes": scene_nodes}]
    gltf["animations"] = [_animation(b, m, name, sampling, J if ground_root else None)
                          for m, name in zip(motions, names)]
    gltf["accessors"] = b.accessors
    gltf["bufferViews"] = b.views
    blob = b.blob()
    gltf["buffers"] = [{"byteLength": len(blob)}]
    data = _glb(gltf, blob)
    path = Path(path)
    atomic_write_bytes(path, data)
    return path


# --------------------------------------------------------------- checking
def _check_motions(motions) -> list[Motion]:
    if isinstance(motions, Motion):
        motions = [motions]
    try:
        motions = list(motions)
    except TypeError:
        raise InputError(f"`motions` must be a Motion or a sequence of Motions, "
                         f"got {type(motions).__name__}") from None
    if not motions:
        raise InputError("`motions` is empty: give at least one Motion")
    for i, m in enumerate(motions):
        if not isinstance(m, Motion):
            raise InputError(f"`motions[{i}]` is a {type(m).__name__}, expected a Motion")
        if len(m) == 0:
            raise InputError(f"`motions[{i}]` has no frames")
    s0 = motions[0].skeleton
    for i, m in enumerate(motions[1:], start=1):
        s = m.skeleton
        if s is s0:
            continue
        if (s.names != s0.names or not np.array_equal(s.parents, s0.parents)
                or np.max(np.abs(s.offsets - s0.offsets)) > _SAME_SKELETON_TOL):
            raise InputError(f"`motions[{i}]` animates another skeleton than `motions[0]`; "
                             "one file holds animations of one skeleton")
    return motions


def _check_sampling(sampling) -> str:
    s = str(sampling).upper() if isinstance(sampling, str) else None
    if s not in SAMPLINGS:
        raise InputError(f"`sampling` = {sampling!r}; allowed: {', '.join(SAMPLINGS)}")
    return s


def _animation_names(motions: list[Motion], names) -> list[str]:
    if names is None:
        base = []
        for i, m in enumerate(motions):
            gaits = []
            for g in (m.gaits if m.gaits is not None else []):
                g = str(g)
                if g and "->" not in g and g not in gaits:
                    gaits.append(g)
            base.append("+".join(gaits) or f"clip{i}")
    else:
        if isinstance(names, str):
            names = [names]
        base = list(names)
        if len(base) != len(motions):
            raise InputError(f"`names` has {len(base)} name(s) for {len(motions)} motion(s)")
        for i, n in enumerate(base):
            if not isinstance(n, str) or not n:
                raise InputError(f"`names[{i}]` must be a non-empty string, got {n!r}")
    out: list[str] = []
    for n in base:
        cand, k = n, 1
        while cand in out:
            k += 1
            cand = f"{n}_{k}"
        out.append(cand)
    return out


# --------------------------------------------------------------- contents
def _mesh(b: _Builder, skel) -> dict | None:
    body = body_mesh(skel)
    V = len(body.positions)
    if V == 0:
        return None
    J = skel.n_joints
    pos = b.accessor(body.positions, _FLOAT, target=_ARRAY_BUFFER, bounds=True,
                     name="body positions")
    nrm32 = body.normals.astype(np.float32)
    nrm32 /= np.linalg.norm(nrm32, axis=-1, keepdims=True)
    nrm = b.accessor(nrm32, _FLOAT, target=_ARRAY_BUFFER, name="body normals")
    jtype = _UBYTE if J <= 256 else _USHORT
    jnt = b.accessor(body.joints, jtype, target=_ARRAY_BUFFER, name="body joints")
    wgt = b.accessor(_normalised_weights(body.weights), _FLOAT, target=_ARRAY_BUFFER,
                     name="body weights")
    itype = _USHORT if V < 0xFFFF else _UINT  # 0xFFFF is the primitive restart value
    idx = b.accessor(body.triangles.reshape(-1), itype, target=_ELEMENT_ARRAY_BUFFER,
                     name="body triangles")
    return {"name": "body", "primitives": [{
        "attributes": {"POSITION": pos, "NORMAL": nrm, "JOINTS_0": jnt, "WEIGHTS_0": wgt},
        "indices": idx, "material": 0, "mode": 4}]}


def _normalised_weights(w: np.ndarray) -> np.ndarray:
    """Float32 weights whose rows sum to 1 as closely as float32 allows."""
    w32 = w.astype(np.float32)
    w32 /= w32.sum(axis=-1, keepdims=True, dtype=np.float32)
    rows = np.arange(len(w32))
    big = np.argmax(w32, axis=-1)
    w32[rows, big] += np.float32(1.0) - w32.sum(axis=-1, dtype=np.float32)
    return w32


def _continuous_xyzw(q_wxyz: np.ndarray) -> np.ndarray:
    """Quaternions (T, J, 4) reordered to (x, y, z, w), signs continuous over T."""
    q = np.asarray(q_wxyz, dtype=float)[..., [1, 2, 3, 0]]
    if len(q) > 1:
        flip = np.sum(q[1:] * q[:-1], axis=-1) < 0
        sign = np.where(np.cumsum(flip, axis=0) % 2 == 1, -1.0, 1.0)
        q[1:] *= sign[..., None]
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _tangents(values: np.ndarray, dt: float) -> np.ndarray:
    """Catmull-Rom tangents (per second) of values sampled every ``dt``, shape kept."""
    if len(values) < 2:
        return np.zeros_like(values)
    m = np.empty_like(values)
    m[1:-1] = (values[2:] - values[:-2]) / (2.0 * dt)
    m[0] = (values[1] - values[0]) / dt
    m[-1] = (values[-1] - values[-2]) / dt
    return m


def _on_ground(motion: Motion) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The ground root's translations (T, 3) and (w, x, y, z) rotations (T, 4), and the
    root joint's translations (T, 3) and rotations (T, 4) relative to it."""
    root = np.asarray(motion.root_positions, dtype=float)
    T = len(root)
    yaw = np.asarray(motion.extras.get("heading", np.zeros(T)), dtype=float).reshape(T)
    ground = root * np.array([1.0, 0.0, 1.0])
    half = 0.5 * yaw
    q_yaw = np.stack([np.cos(half), np.zeros(T), np.sin(half), np.zeros(T)], axis=-1)
    c, s = np.cos(yaw), np.sin(yaw)
    d = root - ground
    local = np.stack([c * d[:, 0] - s * d[:, 2], d[:, 1], s * d[:, 0] + c * d[:, 2]], -1)
    inv = q_yaw * np.array([1.0, -1.0, -1.0, -1.0])
    return ground, q_yaw, local, quaternion_multiply(inv, motion.rotations[:, 0])


def _animation(b: _Builder, motion: Motion, name: str, sampling: str,
               ground: int | None = None) -> dict:
    T, J = motion.rotations.shape[:2]
    times = (np.arange(T) / motion.fps).astype(np.float32)
    if T > 1 and np.any(np.diff(times) <= 0):
        raise InputError(f"animation {name!r}: {T} frames at {motion.fps:g} fps give key "
                         "times that float32 cannot tell apart; split the motion")
    if sampling == "CUBICSPLINE" and T < 2:
        raise InputError(f"animation {name!r}: CUBICSPLINE sampling needs at least 2 frames")
    t_acc = b.accessor(times, _FLOAT, bounds=True, name=f"{name} times")
    rotations, root = motion.rotations, motion.root_positions
    if ground is not None:
        g_pos, g_rot, root, first = _on_ground(motion)
        rotations = np.concatenate([first[:, None], rotations[:, 1:]], axis=1)
    quats = _continuous_xyzw(rotations)

    def output(values: np.ndarray, label: str) -> int:
        if sampling == "CUBICSPLINE":
            tan = _tangents(values, 1.0 / motion.fps)
            values = np.stack([tan, values, tan], axis=1).reshape(3 * T, -1)
        v32 = values.astype(np.float32)
        if label == "rotation":
            v32 = _unit_float32(v32, sampling)
        return b.accessor(v32, _FLOAT, name=f"{name} {label}")

    samplers, channels = [], []
    for j in range(J):
        samplers.append({"input": t_acc, "output": output(quats[:, j], "rotation"),
                         "interpolation": sampling})
        channels.append({"sampler": j, "target": {"node": j, "path": "rotation"}})
    samplers.append({"input": t_acc, "output": output(root, "translation"),
                     "interpolation": sampling})
    channels.append({"sampler": J, "target": {"node": 0, "path": "translation"}})
    if ground is not None:
        for path, values in (("translation", g_pos), ("rotation", _continuous_xyzw(g_rot))):
            samplers.append({"input": t_acc, "output": output(values, path),
                             "interpolation": sampling})
            channels.append({"sampler": len(samplers) - 1,
                             "target": {"node": ground, "path": path}})
    return {"name": name, "samplers": samplers, "channels": channels,
            "extras": {"fps": motion.fps, "frames": T}}


def _unit_float32(q32: np.ndarray, sampling: str) -> np.ndarray:
    """Renormalise float32 quaternion keys (the values of cubic keys, not the tangents)."""
    if sampling == "CUBICSPLINE":
        keys = q32.reshape(-1, 3, 4)
        vals = keys[:, 1].astype(np.float64)
        keys[:, 1] = (vals / np.linalg.norm(vals, axis=-1, keepdims=True)).astype(np.float32)
        return keys.reshape(-1, 4)
    q = q32.astype(np.float64)
    return (q / np.linalg.norm(q, axis=-1, keepdims=True)).astype(np.float32)


# ------------------------------------------------------------ binary form
class _Builder:
    """Collects accessors and buffer views over one binary buffer."""

    def __init__(self) -> None:
        self.accessors: list[dict] = []
        self.views: list[dict] = []
        self._chunks: list[bytes] = []
        self._size = 0

    def accessor(self, data, component: int, *, target: int | None = None,
                 bounds: bool = False, name: str | None = None) -> int:
        """Store ``data`` of shape (N,) or (N, k) as one accessor; returns its index."""
        arr = np.ascontiguousarray(np.asarray(data), dtype=_COMPONENT[component])
        if arr.ndim == 1:
            arr = arr[:, None]
        count, width = arr.shape
        if not np.all(np.isfinite(arr)):
            raise InputError(f"cannot write {name or 'data'}: it holds NaN or infinite values")
        raw = arr.tobytes()
        view = {"buffer": 0, "byteOffset": self._size, "byteLength": len(raw)}
        if target is not None:
            view["target"] = target
        self.views.append(view)
        pad = (-len(raw)) % 4
        self._chunks.append(raw + b"\0" * pad)
        self._size += len(raw) + pad
        acc = {"bufferView": len(self.views) - 1, "componentType": component,
               "count": count, "type": _TYPES[width]}
        if bounds:
            acc["min"] = _numbers(arr.min(axis=0), component)
            acc["max"] = _numbers(arr.max(axis=0), component)
        if name:
            acc["name"] = name
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def blob(self) -> bytes:
        return b"".join(self._chunks)


def _numbers(v: np.ndarray, component: int) -> list:
    """Exact JSON numbers of stored values (a float32 as the double it equals)."""
    if component == _FLOAT:
        return [float(x) for x in v]
    return [int(x) for x in v]


def _floats(v) -> list[float]:
    return [float(x) for x in np.asarray(v, dtype=float)]


def _glb(gltf: dict, blob: bytes) -> bytes:
    js = json.dumps(gltf, separators=(",", ":"), allow_nan=False).encode("utf-8")
    js += b" " * ((-len(js)) % 4)
    blob += b"\0" * ((-len(blob)) % 4)
    parts = [struct.pack("<II", len(js), _CHUNK_JSON), js]
    if blob:
        parts += [struct.pack("<II", len(blob), _CHUNK_BIN), blob]
    body = b"".join(parts)
    return struct.pack("<III", _GLB_MAGIC, 2, 12 + len(body)) + body


def _generator() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return f"quadsim {version('quadsim')}"
    except PackageNotFoundError:  # run from a source tree, not installed
        return "quadsim"


