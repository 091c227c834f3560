"""glTF export: re-read with an independent reader (pygltflib + numpy), validate.

The Khronos glTF validator runs when it is installed: set
``QUADSIM_GLTF_VALIDATOR`` to the folder of the npm package (for example after
``npm install --prefix /tmp/gltfv gltf-validator``, the folder
``/tmp/gltfv/node_modules/gltf-validator``), or install it into
``node_modules/`` at the repository root. Without it those tests are skipped;
with the variable set to a folder that does not hold it, they fail.
"""

import json
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

from quadsim.cli import main
from quadsim.config import load_config
from quadsim.errors import InputError
from quadsim.io.body_mesh import body_mesh
from quadsim.io.gltf import write_glb
from quadsim.locomotion import Command, simulate
from quadsim.skeleton.character import list_characters, load_character
from quadsim.skeleton.motion import Motion

pygltflib = pytest.importorskip("pygltflib")

REPO = Path(__file__).resolve().parents[1]
CHARACTERS = list_characters()
#: Joint world positions rebuilt from a GLB must match the motion within this (m).
ROUND_TRIP_TOL = 1e-4

_DTYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16,
           5125: np.uint32, 5126: np.float32}
_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


# ------------------------------------------------------------------ reader
class Glb:
    """A GLB parsed by pygltflib, with accessors decoded here with numpy."""

    def __init__(self, path):
        self.gltf = pygltflib.GLTF2().load(str(path))
        self.blob = self.gltf.binary_blob()

    def accessor(self, index: int) -> np.ndarray:
        """Accessor data, shape (count, width) (tightly packed views only)."""
        acc = self.gltf.accessors[index]
        view = self.gltf.bufferViews[acc.bufferView]
        assert view.byteStride in (None, 0)
        dtype = np.dtype(_DTYPES[acc.componentType]).newbyteorder("<")
        width = _WIDTHS[acc.type]
        start = (view.byteOffset or 0) + (acc.byteOffset or 0)
        n = acc.count * width
        assert start + n * dtype.itemsize <= (view.byteOffset or 0) + view.byteLength
        return np.frombuffer(self.blob, dtype=dtype, count=n, offset=start).reshape(acc.count,
                                                                                    width)

    def parents(self) -> np.ndarray:
        par = np.full(len(self.gltf.nodes), -1)
        for i, node in enumerate(self.gltf.nodes):
            for c in node.children or []:
                par[c] = i
        return par

    def animation_keys(self, animation: int = 0):
        """Key times and per-node key values ``{(node, path): (T, k)}`` of an animation."""
        anim = self.gltf.animations[animation]
        times, keys = None, {}
        for ch in anim.channels:
            s = anim.samplers[ch.sampler]
            t = self.accessor(s.input)[:, 0]
            out = self.accessor(s.output)
            if s.interpolation == "CUBICSPLINE":
                out = out.reshape(len(t), 3, -1)[:, 1]  # in-tangent, value, out-tangent
            times = t if times is None else times
            assert np.array_equal(times, t)
            keys[(ch.target.node, ch.target.path)] = out.astype(float)
        return times, keys


def matrices_from_xyzw(q: np.ndarray) -> np.ndarray:
    """Rotation matrices from glTF quaternions (x, y, z, w), shape (..., 3, 3)."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def node_world_matrices(glb: Glb, animation: int | None = 0) -> np.ndarray:
    """World matrices of every node, (T, N, 4, 4) per animation frame or (1, N, 4, 4) at rest."""
    nodes = glb.gltf.nodes
    N = len(nodes)
    keys, T = {}, 1
    if animation is not None:
        times, keys = glb.animation_keys(animation)
        T = len(times)
    local = np.zeros((T, N, 4, 4))
    for i, node in enumerate(nodes):
        assert node.matrix is None
        t = np.broadcast_to(np.asarray(node.translation or [0, 0, 0], float), (T, 3))
        r = np.broadcast_to(np.asarray(node.rotation or [0, 0, 0, 1], float), (T, 4))
        s = np.broadcast_to(np.asarray(node.scale or [1, 1, 1], float), (T, 3))
        t = keys.get((i, "translation"), t)
        r = keys.get((i, "rotation"), r)
        s = keys.get((i, "scale"), s)
        local[:, i, :3, :3] = matrices_from_xyzw(r) * s[:, None, :]
        local[:, i, :3, 3] = t
        local[:, i, 3, 3] = 1.0
    parents = glb.parents()
    world = np.zeros_like(local)
    done = np.zeros(N, bool)
    while not done.all():
        for i in range(N):
            p = parents[i]
            if not done[i] and (p < 0 or done[p]):
                world[:, i] = local[:, i] if p < 0 else world[:, p] @ local[:, i]
                done[i] = True
    return world


# ---------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def motions():
    """A 2-second walk at 30 fps for every character."""
    return {c: simulate(load_character(c), Command(speed=1.0), 2.0, 30) for c in CHARACTERS}


@pytest.fixture(scope="module")
def glbs(motions, tmp_path_factory):
    folder = tmp_path_factory.mktemp("glb")
    return {c: write_glb(m, folder / f"{c}.glb") for c, m in motions.items()}


def joint_nodes(glb: Glb, motion: Motion) -> np.ndarray:
    """Node index of each joint of the motion, by name."""
    by_name = {n.name: i for i, n in enumerate(glb.gltf.nodes)}
    return np.array([by_name[n] for n in motion.skeleton.names])


# ------------------------------------------------------------- round trips
@pytest.mark.parametrize("character", CHARACTERS)
def test_joint_world_positions_round_trip(character, motions, glbs):
    motion, glb = motions[character], Glb(glbs[character])
    times, _ = glb.animation_keys()
    np.testing.assert_allclose(times, motion.times, atol=1e-6)
    world = node_world_matrices(glb)[:, joint_nodes(glb, motion)]
    err = np.abs(world[..., :3, 3] - motion.world_positions()).max()
    assert err < ROUND_TRIP_TOL, f"{character}: joint positions differ by {err:.3g} m"
    # and the orientations, which carry the body mesh
    rot_err = np.abs(world[..., :3, :3] - motion.world_rotations()).max()
    assert rot_err < 1e-5


@pytest.mark.parametrize("character", CHARACTERS)
def test_skin_inverse_bind_matrices_invert_the_rest_pose(character, motions, glbs):
    motion, glb = motions[character], Glb(glbs[character])
    skin = glb.gltf.skins[0]
    nodes = joint_nodes(glb, motion)
    assert list(skin.joints) == list(nodes)
    ibm = glb.accessor(skin.inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)
    rest = node_world_matrices(glb, animation=None)[0, nodes]
    np.testing.assert_allclose(ibm @ rest, np.broadcast_to(np.eye(4), rest.shape), atol=1e-6)
    np.testing.assert_allclose(rest[:, :3, 3], motion.skeleton.rest_positions, atol=1e-6)


@pytest.mark.parametrize("character", CHARACTERS)
def test_body_is_skinned_with_normalised_weights(character, motions, glbs):
    motion, glb = motions[character], Glb(glbs[character])
    body = [n for n in glb.gltf.nodes if n.mesh is not None]
    assert len(body) == 1 and body[0].skin == 0
    assert body[0].translation is None and body[0].rotation is None
    assert glb.parents()[glb.gltf.nodes.index(body[0])] == -1   # a scene root
    prim = glb.gltf.meshes[0].primitives[0]
    a = prim.attributes
    weights = glb.accessor(a.WEIGHTS_0).astype(float)
    joints = glb.accessor(a.JOINTS_0)
    assert glb.gltf.accessors[a.JOINTS_0].componentType in (5121, 5123)
    assert glb.gltf.accessors[a.WEIGHTS_0].componentType == 5126
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-6)
    assert weights.min() >= 0
    assert joints.max() < motion.skeleton.n_joints
    assert np.all(joints[weights == 0] == 0)
    normals = glb.accessor(a.NORMAL).astype(float)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-6)
    tris = glb.accessor(prim.indices).reshape(-1, 3)
    assert tris.max() < len(weights)


def test_body_mesh_is_closed_and_faces_outwards():
    skel = load_character("leopard").skeleton
    b = body_mesh(skel)
    p = b.positions[b.triangles]
    face = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert np.all(np.sum(face * b.normals[b.triangles].mean(axis=1), axis=1) > 0)
    # closed: every edge is shared by exactly two triangles, in opposite directions
    edges = np.concatenate([b.triangles[:, [0, 1]], b.triangles[:, [1, 2]],
                            b.triangles[:, [2, 0]]])
    fwd = {tuple(e) for e in edges}
    assert len(fwd) == len(edges)
    assert all((e[1], e[0]) in fwd for e in fwd)
    np.testing.assert_allclose(b.weights.sum(axis=1), 1.0, atol=1e-12)


def test_skinned_body_follows_the_bones(motions, glbs):
    """Linear blend skinning of the rest mesh with the file's matrices: rigid parts
    stay at their rest distance from their joint."""
    motion, glb = motions["leopard"], Glb(glbs["leopard"])
    a = glb.gltf.meshes[0].primitives[0].attributes
    v = glb.accessor(a.POSITION).astype(float)
    w = glb.accessor(a.WEIGHTS_0).astype(float)
    j = glb.accessor(a.JOINTS_0).astype(int)
    ibm = glb.accessor(glb.gltf.skins[0].inverseBindMatrices).reshape(-1, 4, 4)
    ibm = ibm.transpose(0, 2, 1)
    world = node_world_matrices(glb)[:, joint_nodes(glb, motion)]
    skin = world @ ibm                                          # (T, J, 4, 4)
    rigid = w[:, 0] == 1.0
    owner = j[rigid, 0]
    vh = np.concatenate([v[rigid], np.ones((rigid.sum(), 1))], axis=1)
    moved = np.einsum("tvij,vj->tvi", skin[:, owner], vh)[..., :3]
    rest_d = np.linalg.norm(v[rigid] - motion.skeleton.rest_positions[owner], axis=-1)
    d = np.linalg.norm(moved - motion.world_positions()[:, owner], axis=-1)
    np.testing.assert_allclose(d, np.broadcast_to(rest_d, d.shape), atol=1e-5)


@pytest.mark.parametrize("character", CHARACTERS)
def test_accessor_bounds_match_their_data(character, glbs):
    glb = Glb(glbs[character])
    bounded = set()
    for i, acc in enumerate(glb.gltf.accessors):
        if not acc.min and not acc.max:  # pygltflib reads absent bounds as []
            continue
        data = glb.accessor(i)
        assert acc.min == [float(x) for x in data.min(axis=0)], f"accessor {i} min"
        assert acc.max == [float(x) for x in data.max(axis=0)], f"accessor {i} max"
        bounded.add(i)
    a = glb.gltf.meshes[0].primitives[0].attributes
    assert a.POSITION in bounded
    for anim in glb.gltf.animations:
        for s in anim.samplers:
            assert s.input in bounded
            t = glb.accessor(s.input)[:, 0]
            assert t[0] == 0.0 and np.all(np.diff(t) > 0)


@pytest.mark.parametrize("character", CHARACTERS)
def test_file_layout_is_aligned(character, glbs):
    data = glbs[character].read_bytes()
    magic, version, length = struct.unpack_from("<III", data, 0)
    assert (magic, version, length) == (0x46546C67, 2, len(data))
    json_len, json_type = struct.unpack_from("<II", data, 12)
    bin_len, bin_type = struct.unpack_from("<II", data, 20 + json_len)
    assert json_type == 0x4E4F534A and bin_type == 0x004E4942
    assert json_len % 4 == 0 and bin_len % 4 == 0
    assert 28 + json_len + bin_len == len(data)
    glb = Glb(glbs[character])
    assert glb.gltf.buffers[0].byteLength <= bin_len < glb.gltf.buffers[0].byteLength + 4
    for view in glb.gltf.bufferViews:
        assert (view.byteOffset or 0) % 4 == 0
    assert glb.gltf.asset.version == "2.0"


def test_quaternions_are_unit_xyzw_and_continuous(motions, glbs):
    motion, glb = motions["horse"], Glb(glbs["horse"])
    _, keys = glb.animation_keys()
    nodes = joint_nodes(glb, motion)
    q = np.stack([keys[(n, "rotation")] for n in nodes], axis=1)   # (T, J, 4) xyzw
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-6)
    assert np.all(np.sum(q[1:] * q[:-1], axis=-1) > 0)
    wxyz = q[..., [3, 0, 1, 2]]
    same = np.abs(np.sum(wxyz * motion.rotations, axis=-1))
    np.testing.assert_allclose(same, 1.0, atol=1e-6)


# ------------------------------------------------------- several animations
def test_several_motions_become_named_animations(tmp_path):
    leopard = load_character("leopard")
    walk = simulate(leopard, Command(speed=1.0, gait="walk"), 1.0, 30)
    trot = simulate(leopard, Command(speed=2.5, gait="trot"), 1.5, 24)
    path = write_glb([walk, trot, walk[:5]], tmp_path / "clips.glb")
    glb = Glb(path)
    assert [a.name for a in glb.gltf.animations] == ["walk", "trot", "walk_2"]
    for k, m in enumerate([walk, trot, walk[:5]]):
        times, _ = glb.animation_keys(k)
        np.testing.assert_allclose(times, m.times, atol=1e-6)
        world = node_world_matrices(glb, k)[:, joint_nodes(glb, m)]
        assert np.abs(world[..., :3, 3] - m.world_positions()).max() < ROUND_TRIP_TOL
    path = write_glb([walk, trot], tmp_path / "named.glb", names=["a", "b"])
    assert [a.name for a in Glb(path).gltf.animations] == ["a", "b"]
    bare = Motion(walk.skeleton, walk.fps, walk.root_positions, walk.rotations)
    assert Glb(write_glb(bare, tmp_path / "bare.glb")).gltf.animations[0].name == "clip0"


@pytest.mark.parametrize("sampling", ["STEP", "CUBICSPLINE"])
def test_other_samplings_keep_the_keys(sampling, motions, tmp_path):
    motion = motions["dog_cub"]
    glb = Glb(write_glb(motion, tmp_path / "c.glb", sampling=sampling))
    assert {s.interpolation for s in glb.gltf.animations[0].samplers} == {sampling}
    world = node_world_matrices(glb)[:, joint_nodes(glb, motion)]
    assert np.abs(world[..., :3, 3] - motion.world_positions()).max() < ROUND_TRIP_TOL


def test_without_body(motions, tmp_path):
    glb = Glb(write_glb(motions["leopard"], tmp_path / "b.glb", body=False))
    assert not glb.gltf.meshes
    assert len(glb.gltf.nodes) == motions["leopard"].skeleton.n_joints


# -------------------------------------------------------------- bad input
def test_bad_inputs(motions, tmp_path):
    m = motions["leopard"]
    with pytest.raises(InputError, match="empty"):
        write_glb([], tmp_path / "x.glb")
    with pytest.raises(InputError, match="another skeleton"):
        write_glb([m, motions["horse"]], tmp_path / "x.glb")
    with pytest.raises(InputError, match="sampling"):
        write_glb(m, tmp_path / "x.glb", sampling="QUADRATIC")
    with pytest.raises(InputError, match="1 name"):
        write_glb([m, m], tmp_path / "x.glb", names=["only"])
    with pytest.raises(InputError, match="no frames"):
        write_glb(m[:0], tmp_path / "x.glb")
    with pytest.raises(InputError, match="expected a Motion"):
        write_glb([m, "walk"], tmp_path / "x.glb")
    assert list(tmp_path.iterdir()) == []


def test_write_is_atomic(motions, tmp_path):
    m = motions["leopard"]
    path = tmp_path / "keep.glb"
    path.write_bytes(b"old")
    root = m.root_positions.copy()
    root[3, 0] = np.nan
    bad = Motion(m.skeleton, m.fps, root, m.rotations)
    with pytest.raises(InputError, match="NaN"):
        write_glb(bad, path)
    assert path.read_bytes() == b"old"
    with pytest.raises(InputError, match="cannot write"):
        write_glb(m, tmp_path / "missing" / "x.glb")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.glb"]


# --------------------------------------------------------------------- CLI
def test_cli_run_writes_a_glb(tmp_path, capsys):
    out = tmp_path / "x.glb"
    code = main(["run", str(REPO / "configs" / "leopard.toml"), "--seconds", "1",
                 "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    glb = Glb(out)
    assert len(glb.gltf.animations) == 1
    times, _ = glb.animation_keys()
    assert len(times) == round(1.0 * load_config(REPO / "configs" / "leopard.toml").fps)
    assert "x.glb" in capsys.readouterr().out


# --------------------------------------------------- the Khronos validator
@pytest.fixture(scope="module")
def validator_reports(glbs, motions, tmp_path_factory):
    from gltf_tools import validator_dir

    pkg = validator_dir()
    extra = tmp_path_factory.mktemp("glb_extra")
    leopard = motions["leopard"]
    files = dict(glbs)
    files["leopard, cubic, two clips"] = write_glb([leopard, leopard[:20]],
                                                    extra / "cubic.glb", sampling="CUBICSPLINE")
    files["leopard, step, no body"] = write_glb(leopard, extra / "step.glb", sampling="STEP",
                                                body=False)
    proc = subprocess.run(["node", str(REPO / "tests" / "gltf_validate.mjs"), str(pkg),
                           *map(str, files.values())],
                          check=False, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return dict(zip(files, json.loads(proc.stdout)))


@pytest.mark.parametrize("case", CHARACTERS + ["leopard, cubic, two clips",
                                               "leopard, step, no body"])
def test_khronos_validator_reports_no_errors_or_warnings(case, validator_reports):
    issues = validator_reports[case]["issues"]
    bad = [m for m in issues["messages"] if m["severity"] <= 1]
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), bad


def test_a_ground_root_carries_the_travel_and_the_joints_stay_where_they_were(tmp_path):
    """``ground_root=True`` (clip sets for game engines): a ``root`` node, the scene root
    and the skin's last joint, stands on the ground under the root joint turned to its
    heading, and every joint's world position and rotation is the motion's as before."""
    motion = simulate(load_character("leopard"), Command(speed=2.0, turn_rate=0.6), 3.0, 30)
    glb = Glb(write_glb(motion, tmp_path / "ground.glb", ground_root=True))
    nodes = glb.gltf.nodes
    root = next(i for i, n in enumerate(nodes) if n.name == "root")
    assert glb.gltf.scenes[0].nodes[0] == root and nodes[root].children == [0]
    skin = glb.gltf.skins[0]
    assert skin.joints[-1] == root and skin.skeleton == root
    np.testing.assert_allclose(glb.accessor(skin.inverseBindMatrices)[-1],
                               np.eye(4).reshape(-1), atol=0)
    world = node_world_matrices(glb)
    joints = world[:, joint_nodes(glb, motion)]
    assert np.abs(joints[..., :3, 3] - motion.world_positions()).max() < ROUND_TRIP_TOL
    assert np.abs(joints[..., :3, :3] - motion.world_rotations()).max() < 1e-5
    ground = world[:, root]
    np.testing.assert_allclose(ground[:, 1, 3], 0.0, atol=1e-7)
    np.testing.assert_allclose(ground[:, [0, 2], 3], motion.root_positions[:, [0, 2]],
                               atol=1e-4)
    heading = np.arctan2(ground[:, 0, 2], ground[:, 2, 2])   # where its +Z points
    np.testing.assert_allclose(np.unwrap(heading), motion.extras["heading"], atol=1e-5)
