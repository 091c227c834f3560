"""Synthetic rigs of other conventions, written as glTF models and BVH hierarchies.

A :class:`RigSpec` is a quadruped described in quadsim's frame (+Y up, +Z
forward, +X left, metres): joints with their parents and rest positions, and
the mapping a correct adoption finds (each leg's top and foot joint, pelvis,
withers, head). :func:`quadruped` builds one from a few choices -- naming
(Blender ``thigh.L``, ``LeftThigh``, ``bone_017``), hind legs of two, three or
four bones, fore legs with or without a scapula, a long neck with a mane and
hooves, face, ear, jaw, eye, whisker, helper, twist and inline segment bones.
:func:`write_gltf` writes it in the rig's own frame (``up="Y"`` or Blender's
``"Z"``, facing -Y) and unit (metres, centimetres in the translations, or
centimetres under an armature node scaled by 0.01), every joint with a rest
rotation whose +Y runs along its bone (Blender's convention) and a small
skinned mesh (a box on every bone); :func:`write_bvh_rig` writes the same as
a BVH hierarchy. :func:`animated_positions` reads back a written ``.glb``
animation as joint world positions.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: quadsim frame -> Blender's (+Z up, facing -Y, left +X), as a rotation matrix.
TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


@dataclass
class RigSpec:
    """A quadruped rig in quadsim's frame (m), and what adopting it must find."""

    name: str
    joints: list = field(default_factory=list)      # (name, parent or None, position (3,))
    expect: dict = field(default_factory=dict)      # leg -> (top, foot); pelvis/withers/head

    def add(self, name, parent, pos) -> str:
        assert name not in self.names, name
        self.joints.append((name, parent, np.asarray(pos, float)))
        return name

    @property
    def names(self) -> list[str]:
        return [j[0] for j in self.joints]

    @property
    def height(self) -> float:
        return float(np.ptp([p[1] for _, _, p in self.joints]))


def _namer(style: str):
    counter = iter(range(1000))

    def name(base: str, side: str = "", k: int | None = None) -> str:
        if style == "anonymous":
            return f"bone_{next(counter):03d}"
        if style == "blender":
            n = f"{base}.{side}" if side else base
            return n + (f".{k:03d}" if k else "")
        words = "".join(w.capitalize() for w in base.split("_"))
        left = {"L": "Left", "R": "Right", "": ""}[side]
        return f"{left}{words}{k if k else ''}"

    return name


def quadruped(name: str, *, style: str = "blender", hip: float = 0.5, hind_bones: int = 3,
              scapula: bool = True, neck_bones: int = 2, face: bool = True,
              helpers: bool = True, mane: bool = False, toes: int = 1,
              tail_bones: int = 4, whiskers: int = 0, root: bool = True) -> RigSpec:
    """A quadruped standing on the ground at rest (see the module notes)."""
    n = _namer(style)
    s = RigSpec(name)
    h, L, w = hip, 1.3 * hip, 0.16 * hip
    zp, zc = -L / 2, L / 2
    top = None
    if root:
        top = s.add(n("root"), None, [0.0, 0.0, 0.0])
    spine, prev = [], top
    for k in range(4):
        prev = s.add(n("spine", k=k), prev, [0, h * (1 + 0.02 * k), zp + k * L / 3])
        spine.append(prev)
    pelvis, chest = spine[0], spine[-1]
    s.expect.update(pelvis=pelvis, withers=chest)
    # neck and head: rising ahead of the withers (steeply for a long neck)
    prev, y, z = chest, h * 1.06, zc
    rise, reach = (0.5 * h, 0.25 * h) if neck_bones <= 2 else (1.1 * h, 0.45 * h)
    for k in range(neck_bones):
        y, z = y + rise / neck_bones, z + reach / neck_bones
        prev = s.add(n("neck", k=k) if style != "blender" else f"spine.{4 + k:03d}",
                     prev, [0, y, z])
        if mane:
            s.add(n("mane", k=k + 1) if style != "blender" else f"mane.{k + 1:03d}",
                  prev, [0, y + 0.08 * h, z - 0.05 * h])
    head = s.add(n("head") if style != "blender" else f"spine.{4 + neck_bones:03d}", prev,
                 [0, y + 0.08 * h, z + 0.12 * h])
    s.expect["head"] = head
    hy, hz = y + 0.08 * h, z + 0.12 * h
    if face:
        for side, sx in (("L", 1), ("R", -1)):
            e = s.add(n("ear", side), head, [sx * 0.05 * h, hy + 0.08 * h, hz - 0.02 * h])
            s.add(n("ear", side, 1), e, [sx * 0.06 * h, hy + 0.18 * h, hz - 0.03 * h])
            eye = s.add(n("eye", side), head, [sx * 0.04 * h, hy + 0.03 * h, hz + 0.06 * h])
            s.add(n("lid", side, 1), eye, [sx * 0.045 * h, hy + 0.045 * h, hz + 0.07 * h])
            for k in range(whiskers):
                s.add(n("whisker", side, k + 1), head,
                      [sx * (0.03 + 0.01 * k) * h, hy - 0.02 * h, hz + (0.2 + 0.01 * k) * h])
        jaw = s.add(n("jaw"), head, [0, hy - 0.04 * h, hz + 0.02 * h])
        s.add(n("jaw", k=1), jaw, [0, hy - 0.06 * h, hz + 0.16 * h])
        t = s.add(n("tongue"), jaw, [0, hy - 0.05 * h, hz + 0.05 * h])
        s.add(n("tongue", k=1), t, [0, hy - 0.05 * h, hz + 0.12 * h])
        s.add(n("nose"), head, [0, hy + 0.01 * h, hz + 0.24 * h])
    # tail: backwards and a little down from the pelvis
    prev = pelvis
    for k in range(tail_bones):
        prev = s.add(n("tail", k=k), prev, [0, h * (0.98 - 0.06 * k), zp - (k + 1) * 0.12 * h])
    if helpers:
        for side, sx in (("L", 1), ("R", -1)):
            s.add(n("breast", side), chest, [sx * 0.05 * h, 0.8 * h, zc + 0.05 * h])
    for side, sx in (("L", 1), ("R", -1)):
        _hind(s, n, side, sx * w, h, zp, hind_bones, pelvis, helpers)
        _fore(s, n, side, sx * w, h, zc, scapula, chest, helpers, toes)
    return s


def _hind(s, n, side, x, h, zp, bones, pelvis, helpers):
    names = {2: ["thigh", "shin", "foot"], 3: ["thigh", "shin", "foot", "toe"],
             4: ["thigh", "shin", "foot", "toe", "hoof"]}[bones]
    at = {2: [(h, 0), (0.5 * h, 0.12 * h), (0, 0.04 * h)],
          3: [(h, 0), (0.55 * h, 0.14 * h), (0.22 * h, -0.1 * h), (0, 0.0)],
          4: [(h, 0), (0.6 * h, 0.14 * h), (0.32 * h, -0.12 * h), (0.1 * h, -0.08 * h),
              (0, -0.05 * h)]}[bones]
    prev = pelvis
    if helpers:
        s.add(n("thigh_twist", side), pelvis, [x, h * 0.95, zp + 0.01 * h])
    for k, (base, (y, dz)) in enumerate(zip(names, at)):
        if helpers and k == 1:   # an inline segment halfway down the thigh (Rigify's thigh.001)
            (y0, dz0) = at[0]
            prev = s.add(n("thigh", side, 1), prev, [x, (y0 + y) / 2, zp + (dz0 + dz) / 2])
        prev = s.add(n(base, side), prev, [x, y, zp + dz])
        if k == 0:
            first = prev
        if helpers and k == 0:
            s.add(n("kneecap", side), prev, [x, 0.6 * h, zp + 0.2 * h])
    leg = ("L" if x > 0 else "R") + "H"
    s.expect[leg] = (first, prev)


def _fore(s, n, side, x, h, zc, scapula, chest, helpers, toes):
    prev = chest
    if scapula:
        # the scapula's head a little nearer the spine than the leg's plane
        prev = s.add(n("shoulder", side), chest, [0.9 * x, 1.04 * h, zc - 0.02 * h])
        first = prev
    arm = s.add(n("upper_arm", side), prev, [x, 0.82 * h, zc + 0.08 * h])
    if not scapula:
        first = arm
    if helpers:
        s.add(n("upper_arm_twist", side), arm, [x, 0.8 * h, zc + 0.08 * h])
    elbow = s.add(n("forearm", side), arm, [x, 0.55 * h, zc - 0.03 * h])
    prev = elbow
    if helpers:
        prev = s.add(n("forearm", side, 1), elbow, [x, 0.34 * h, zc + 0.005 * h])
    wrist = s.add(n("hand", side), prev, [x, 0.12 * h, zc + 0.04 * h])
    if toes == 1:
        foot = s.add(n("f_toe", side), wrist, [x, 0.0, zc + 0.09 * h])
    else:
        foot = None
        for k in range(toes):
            dx = (k - (toes - 1) / 2) * 0.02 * h
            t = s.add(n("f_toe", side, k + 1), wrist,
                      [x + dx, 0.0, zc + (0.1 - 0.01 * abs(k - (toes - 1) / 2)) * h])
            if k == toes // 2:
                foot = t
    leg = ("L" if x > 0 else "R") + "F"
    s.expect[leg] = (first, foot)


# ----------------------------------------------------------------------- writing
def _frame(up: str, unit: str) -> tuple[np.ndarray, float]:
    R = np.eye(3) if up == "Y" else TO_Z_UP
    return R, (100.0 if unit in ("cm", "scale") else 1.0)


def _rest(spec: RigSpec, up: str, unit: str):
    """Joint positions in the rig's frame and file units, and Blender-style rest rotations."""
    R, k = _frame(up, unit)
    names = spec.names
    parent = [names.index(p) if p is not None else -1 for _, p, _ in spec.joints]
    P = np.array([R @ p * k for _, _, p in spec.joints])
    rng = np.random.default_rng(len(names))
    rot = []
    for j in range(len(names)):
        kids = [c for c in range(len(names)) if parent[c] == j]
        d = (P[kids[0]] - P[j]) if kids else (P[j] - P[parent[j]] if parent[j] >= 0 else None)
        rot.append(_along(d, rng.uniform(-np.pi, np.pi)))
    return P, np.array(rot), parent


def _along(d, roll: float) -> np.ndarray:
    """A rotation taking +Y along ``d`` (then rolled about it)."""
    if d is None or np.linalg.norm(d) < 1e-9:
        return np.eye(3)
    y = d / np.linalg.norm(d)
    a = np.array([1.0, 0.0, 0.0]) if abs(y[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    x = np.cross(y, a)
    x /= np.linalg.norm(x)
    z = np.cross(x, y)
    B = np.stack([x, y, z], axis=1)
    c, s = np.cos(roll), np.sin(roll)
    return B @ np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _quat(R: np.ndarray) -> list[float]:
    from quadsim.kinematics.rotations import quaternions_from_matrices

    w, x, y, z = quaternions_from_matrices(R)
    return [float(x), float(y), float(z), float(w)]


def write_gltf(spec: RigSpec, path, *, up: str = "Y", unit: str = "m",
               mesh: bool = True) -> Path:
    """Write ``spec`` as a glTF model (``.glb`` or ``.gltf``) in its own frame and unit."""
    import pygltflib as gl

    P, Rw, parent = _rest(spec, up, unit)
    J = len(P)
    A = np.eye(4)
    if unit == "scale":
        A[:3, :3] *= 0.01
    nodes = [gl.Node(name="Armature", children=[1], scale=[0.01] * 3 if unit == "scale"
                     else None)]
    for j, (nm, _, _) in enumerate(spec.joints):
        p = parent[j]
        Rp = Rw[p] if p >= 0 else np.eye(3)
        t = Rp.T @ (P[j] - (P[p] if p >= 0 else 0.0))
        nodes.append(gl.Node(name=nm, translation=[float(v) for v in t],
                             rotation=_quat(Rp.T @ Rw[j]),
                             children=[c + 1 for c in range(J) if parent[c] == j] or None))
    blob = bytearray()

    def view(data: bytes, target=None) -> int:
        blob.extend(b"\0" * (-len(blob) % 4))
        g.bufferViews.append(gl.BufferView(buffer=0, byteOffset=len(blob),
                                           byteLength=len(data), target=target))
        blob.extend(data)
        return len(g.bufferViews) - 1

    def accessor(arr, ctype, kind, target=None, rng=False) -> int:
        v = view(arr.tobytes(), target)
        acc = gl.Accessor(bufferView=v, componentType=ctype, count=len(arr), type=kind)
        if rng:
            acc.min = [float(x) for x in arr.min(axis=0)]
            acc.max = [float(x) for x in arr.max(axis=0)]
        g.accessors.append(acc)
        return len(g.accessors) - 1

    g = gl.GLTF2(asset=gl.Asset(version="2.0"), scene=0, nodes=nodes, bufferViews=[],
                 accessors=[], buffers=[])
    g.scenes = [gl.Scene(nodes=[0])]
    if mesh:
        W = np.array([A @ _mat(Rw[j], P[j]) for j in range(J)])     # joint world matrices
        ibm = np.linalg.inv(W).transpose(0, 2, 1).astype(np.float32)  # column-major
        verts, joints, tris = [], [], []
        for j in range(J):
            kids = [c for c in range(J) if parent[c] == j]
            length = np.linalg.norm(P[kids[0]] - P[j]) if kids else 0.05 * _frame(up, unit)[1]
            r = 0.1 * length + 1e-3
            base = len(verts)
            for cy in (0.0, length):
                for cx, cz in ((-r, -r), (r, -r), (r, r), (-r, r)):
                    verts.append((W[j] @ [cx, cy, cz, 1.0])[:3])
                    joints.append(j)
            for a, b, c in _BOX:
                tris.append((base + a, base + b, base + c))
        pos = np.array(verts, np.float32)
        jnt = np.zeros((len(pos), 4), np.uint16)
        jnt[:, 0] = joints
        wgt = np.zeros((len(pos), 4), np.float32)
        wgt[:, 0] = 1.0
        prim = gl.Primitive(attributes=gl.Attributes(
            POSITION=accessor(pos, gl.FLOAT, "VEC3", 34962, rng=True),
            JOINTS_0=accessor(jnt, gl.UNSIGNED_SHORT, "VEC4", 34962),
            WEIGHTS_0=accessor(wgt, gl.FLOAT, "VEC4", 34962)),
            indices=accessor(np.array(tris, np.uint16).reshape(-1), gl.UNSIGNED_SHORT,
                             "SCALAR", 34963))
        g.meshes = [gl.Mesh(name="Body", primitives=[prim])]
        g.skins = [gl.Skin(joints=list(range(1, J + 1)), skeleton=1,
                           inverseBindMatrices=accessor(ibm, gl.FLOAT, "MAT4"))]
        g.nodes.append(gl.Node(name="Body", mesh=0, skin=0))
        g.scenes[0].nodes.append(len(g.nodes) - 1)
    else:
        g.skins = [gl.Skin(joints=list(range(1, J + 1)), skeleton=1)]
    g.buffers = [gl.Buffer(byteLength=len(blob))]
    g.set_binary_blob(bytes(blob))
    path = Path(path)
    if path.suffix == ".gltf":
        g.convert_buffers(gl.BufferFormat.DATAURI)
        g.save(str(path))
    else:
        g.save_binary(str(path))
    return path


#: Triangles of a box whose corners are 0-3 (bottom ring) and 4-7 (top ring).
_BOX = [(0, 2, 1), (0, 3, 2), (4, 5, 6), (4, 6, 7), (0, 1, 5), (0, 5, 4), (1, 2, 6), (1, 6, 5),
        (2, 3, 7), (2, 7, 6), (3, 0, 4), (3, 4, 7)]


def _mat(R, p) -> np.ndarray:
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R, p
    return M


def write_bvh_rig(spec: RigSpec, path, *, up: str = "Y", unit: str = "m") -> Path:
    """Write ``spec`` as a BVH hierarchy (one frame at rest) in its own frame and unit."""
    R, k = _frame(up, unit)
    names = spec.names
    parent = {nm: p for nm, p, _ in spec.joints}
    pos = {nm: R @ p * k for nm, _, p in spec.joints}
    kids = {nm: [c for c, p, _ in spec.joints if p == nm] for nm in names}
    lines = ["HIERARCHY"]
    orders = ("Zrotation Xrotation Yrotation", "Zrotation Yrotation Xrotation")

    def emit(nm, depth):
        ind = "\t" * depth
        off = pos[nm] - (pos[parent[nm]] if parent[nm] else 0.0)
        rot = orders[len(nm) % 2]
        if parent[nm] is None:
            lines.extend([f"ROOT {nm}", "{", f"\tOFFSET {_nums(off)}",
                          f"\tCHANNELS 6 Xposition Yposition Zposition {rot}"])
        else:
            lines.extend([f"{ind}JOINT {nm}", f"{ind}{{", f"{ind}\tOFFSET {_nums(off)}",
                          f"{ind}\tCHANNELS 3 {rot}"])
        for c in kids[nm]:
            emit(c, depth + 1)
        if not kids[nm]:
            tip = 0.1 * off
            lines.extend([f"{ind}\tEnd Site", f"{ind}\t{{", f"{ind}\t\tOFFSET {_nums(tip)}",
                          f"{ind}\t}}"])
        lines.append(f"{ind}}}")

    emit(names[0], 0)
    values = [*pos[names[0]], *([0.0] * (3 * len(names)))]
    lines += ["MOTION", "Frames: 1", "Frame Time: 0.0333333", _nums(values)]
    path = Path(path)
    path.write_text("\n".join(lines) + "\n")
    return path


def _nums(v) -> str:
    return " ".join(f"{x + 0.0:.6f}" for x in np.asarray(v, float))


# ----------------------------------------------------------------------- reading back
def animated_positions(path, animation: int = -1) -> tuple[dict, np.ndarray, float]:
    """Every node's world position (file units, file frame) at every key of an animation.

    Returns
    -------
    index : dict of str to int
        Node name -> index into the positions.
    positions : ndarray, shape (T, N, 3)
    fps : float
    """
    import pygltflib as gl

    from quadsim.io.rig import _node_matrix
    from quadsim.kinematics.rotations import matrices_from_quaternions

    g = gl.GLTF2().load(str(path))
    blob = g.binary_blob()

    def read(i, width):
        acc = g.accessors[i]
        v = g.bufferViews[acc.bufferView]
        start = (v.byteOffset or 0) + (acc.byteOffset or 0)
        return np.frombuffer(blob[start:start + 4 * width * acc.count],
                             dtype=np.float32).reshape(acc.count, width).astype(float)

    anim = g.animations[animation]
    rot, trans, times = {}, {}, None
    for ch in anim.channels:
        smp = anim.samplers[ch.sampler]
        times = read(smp.input, 1)[:, 0]
        if ch.target.path == "rotation":
            rot[ch.target.node] = read(smp.output, 4)
        elif ch.target.path == "translation":
            trans[ch.target.node] = read(smp.output, 3)
    parent = {c: i for i, nd in enumerate(g.nodes) for c in (nd.children or [])}
    base = [_node_matrix(nd) for nd in g.nodes]
    T, N = len(times), len(g.nodes)
    out = np.zeros((T, N, 3))
    order = sorted(range(N), key=lambda i: _depth(parent, i))
    for k in range(T):
        world = {}
        for i in order:
            M = base[i].copy()
            if i in rot:
                x, y, z, w = rot[i][k]
                s = np.linalg.norm(M[:3, :3], axis=0)
                M[:3, :3] = matrices_from_quaternions(np.array([w, x, y, z])) * s
            if i in trans:
                M[:3, 3] = trans[i][k]
            world[i] = M if i not in parent else world[parent[i]] @ M
            out[k, i] = world[i][:3, 3]
    fps = (T - 1) / (times[-1] - times[0]) if T > 1 else 1.0
    return {nd.name: i for i, nd in enumerate(g.nodes)}, out, float(fps)


def _depth(parent, i) -> int:
    d = 0
    while i in parent:
        i, d = parent[i], d + 1
    return d
