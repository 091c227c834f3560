"""BVH reading and writing: exact hand-computed cases, round trips, errors."""

from __future__ import annotations

import itertools
import re
import textwrap

import numpy as np
import pytest

import quadsim
from quadsim.errors import InputError
from quadsim.io import bvh as bvh_module
from quadsim.io import guess_foot_joints, read_bvh, write_bvh
from quadsim.kinematics.rotations import (
    euler_from_matrices,
    matrices_about_axis,
    matrices_from_axis_angles,
    matrices_from_euler,
)
from quadsim.skeleton.fk import end_site_positions
from quadsim.skeleton.motion import Motion
from quadsim.skeleton.skeleton import Skeleton

CHARACTERS = quadsim.list_characters()
TAIT_BRYAN = ["".join(p) for p in itertools.permutations("XYZ")]


# ----------------------------------------------------------------- helpers
def smooth_motion(skeleton: Skeleton, rng, *, frames=30, fps=30.0, max_deg=60.0) -> Motion:
    """Random smooth motion: each joint swings about a random axis by up to
    ``max_deg``; the root turns about +Y and wanders on a smooth path."""
    J = skeleton.n_joints
    t = np.arange(frames) / fps
    axes = rng.normal(size=(J, 3))
    amp = np.radians(rng.uniform(5.0, max_deg, J))
    freq = rng.uniform(0.5, 2.0, J)
    phase = rng.uniform(0.0, 2 * np.pi, J)
    angles = amp * np.sin(2 * np.pi * freq * t[:, None] + phase)           # (T, J)
    R = matrices_from_axis_angles(axes, angles)                            # (T, J, 3, 3)
    heading = rng.uniform(-np.pi, np.pi) + rng.uniform(-2, 2) * t
    R[:, 0] = matrices_about_axis(1, heading) @ R[:, 0]
    velocity = rng.normal(size=3) + 0.3 * np.sin(np.outer(t, rng.uniform(1, 3, 3)))
    root = skeleton.offsets[0] + np.cumsum(velocity, axis=0) / fps
    return Motion.from_matrices(skeleton, fps, root, R)


def same_positions(a: Motion, b: Motion, atol: float) -> float:
    """Largest distance between the joints of two motions, matched by name."""
    idx = b.skeleton.indices(a.skeleton.names)
    err = np.linalg.norm(a.world_positions() - b.world_positions()[:, idx], axis=-1).max()
    assert err <= atol, f"joint positions differ by {err:.3g} m"
    return err


def frame_values(path) -> np.ndarray:
    """The numbers of the frame lines of a BVH file, shape (T, C)."""
    lines = path.read_text().splitlines()
    k = next(i for i, s in enumerate(lines) if s.startswith("Frame Time:"))
    return np.array([s.split() for s in lines[k + 1:] if s.strip()], dtype=float)


def offset_values(path) -> np.ndarray:
    """Every OFFSET (joints and End Sites) in file order, shape (n, 3)."""
    return np.array([s.split()[1:] for s in path.read_text().splitlines()
                     if s.strip().startswith("OFFSET")], dtype=float)


FOUR_JOINTS = """\
HIERARCHY
ROOT hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT spine
  {
    OFFSET 0 0 1
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT neck
    {
      OFFSET 0 1 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 0.5 0
      }
    }
  }
  JOINT leg
  {
    OFFSET 0 -1 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 -0.5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.5
1 2 3  0 0 0  0 0 0  0 0 0  0 0 0
0 0 0  90 0 90  0 90 0  0 0 0  90 0 0
"""


# --------------------------------------------------------- exact reading
def test_hand_written_four_joint_file_gives_exact_positions(tmp_path):
    path = tmp_path / "four.bvh"
    path.write_text(FOUR_JOINTS)
    m = read_bvh(path)
    assert m.skeleton.names == ("hips", "spine", "neck", "leg")
    assert list(m.skeleton.parents) == [-1, 0, 1, 0]
    assert m.fps == 2.0 and len(m) == 2
    P = m.world_positions()
    # frame 0: no rotation, root at (1, 2, 3): offsets simply add up
    np.testing.assert_allclose(P[0], [[1, 2, 3], [1, 2, 4], [1, 3, 4], [1, 1, 3]], atol=1e-12)
    # frame 1: root R = Rz(90) Ry(90): +Z -> +X -> +Y, so the spine is at +Y;
    # the spine's Rx(90) turns the neck's +Y bone to +Z, and R takes it to +Y;
    # the leg's -Y bone: Ry keeps it, Rz(90) takes -Y to +X.
    np.testing.assert_allclose(P[1], [[0, 0, 0], [0, 1, 0], [0, 2, 0], [1, 0, 0]], atol=1e-12)
    ends = end_site_positions(m.skeleton, m.world_rotations(), P)
    np.testing.assert_allclose(ends["neck"], [[1, 3.5, 4], [0, 2.5, 0]], atol=1e-12)
    # leg tip (0, -0.5, 0): its Rz(90) -> (0.5, 0, 0); Ry(90) -> (0, 0, -0.5); Rz(90) keeps it
    np.testing.assert_allclose(ends["leg"], [[1, 0.5, 3], [1, 0, -0.5]], atol=1e-12)
    assert m.foot_joints is None


def test_lenient_syntax_reads_the_same(tmp_path):
    # CRLF line ends, a byte-order mark, braces on the name's line, lower-case
    # channel names and blank lines all read as the plain file does.
    text = ("\ufeff" + FOUR_JOINTS.replace("ROOT hips\n{", "ROOT hips {")
            .replace("Zrotation Xrotation Yrotation\n    JOINT neck",
                     "zrotation xROTATION Yrotation\n\n    JOINT neck")
            .replace("\n", "\r\n"))
    (tmp_path / "a.bvh").write_bytes(text.encode("utf-8"))
    (tmp_path / "b.bvh").write_text(FOUR_JOINTS)
    a, b = read_bvh(tmp_path / "a.bvh"), read_bvh(tmp_path / "b.bvh")
    assert a.skeleton.names == b.skeleton.names
    np.testing.assert_array_equal(a.world_positions(), b.world_positions())


def test_leaf_without_end_site_gets_a_zero_end_site_that_reads_back_as_none(tmp_path):
    skel = Skeleton(("root", "a", "b", "c"), [-1, 0, 1, 0],
                    [[0, 1, 0], [0, 0, 0.5], [0, 0, 0.5], [0.1, 0, 0]], {"b": [0, 0, 0.2]})
    m = Motion(skel, 30.0, [[0, 1, 0]], np.tile([1.0, 0, 0, 0], (1, 4, 1)))
    path = write_bvh(m, tmp_path / "e.bvh")
    assert path.read_text().count("End Site") == 2   # b's own and c's zero-length one
    assert offset_values(path).tolist()[-1] == [0.0, 0.0, 0.0]
    r = read_bvh(path)
    assert list(r.skeleton.end_sites) == ["b"]
    np.testing.assert_allclose(r.skeleton.end_sites["b"], [0, 0, 0.2])


def test_root_position_channels_are_absolute_and_replace_the_offset(tmp_path):
    # Blender's reading: channels give the root's world position; the OFFSET is
    # the skeleton's rest root position. A root without position channels sits at its OFFSET.
    text = FOUR_JOINTS.replace("ROOT hips\n{\n  OFFSET 0 0 0", "ROOT hips\n{\n  OFFSET 5 6 7")
    (tmp_path / "a.bvh").write_text(text)
    m = read_bvh(tmp_path / "a.bvh")
    np.testing.assert_allclose(m.root_positions, [[1, 2, 3], [0, 0, 0]])
    np.testing.assert_allclose(m.skeleton.offsets[0], [5, 6, 7])
    text = re.sub(r"CHANNELS 6 Xposition Yposition Zposition ", "CHANNELS 4 Yposition ", text)
    text = text.replace("1 2 3  0 0 0", "2  0 0 0").replace("0 0 0  90 0 90", "-1  90 0 90")
    (tmp_path / "b.bvh").write_text(text)
    m = read_bvh(tmp_path / "b.bvh")
    np.testing.assert_allclose(m.root_positions, [[5, 2, 7], [5, -1, 7]])


def test_partial_and_constant_position_channels(tmp_path):
    # a joint with one rotation channel, one with none, and one with constant
    # position channels (they replace its OFFSET)
    text = textwrap.dedent("""\
        HIERARCHY
        ROOT a
        {
          OFFSET 0 0 0
          CHANNELS 3 Xposition Yposition Zposition
          JOINT b
          {
            OFFSET 0 0 1
            CHANNELS 1 Xrotation
            JOINT c
            {
              OFFSET 9 9 9
              CHANNELS 4 Xposition Yposition Zposition Yrotation
              JOINT d
              {
                OFFSET 0 0 1
                CHANNELS 0
              }
            }
          }
        }
        MOTION
        Frames: 2
        Frame Time: 0.04
        0 0 0  90  0 1 0  0
        0 0 0  0   0 1 0  90
        """)
    (tmp_path / "p.bvh").write_text(text)
    m = read_bvh(tmp_path / "p.bvh")
    np.testing.assert_allclose(m.skeleton.offsets[2], [0, 1, 0])
    assert m.fps == 25.0
    # frame 0: b's Rx(90) turns c's +Y bone to +Z and d's +Z bone to -Y
    np.testing.assert_allclose(m.world_positions()[0],
                               [[0, 0, 0], [0, 0, 1], [0, 0, 2], [0, -1, 2]], atol=1e-12)
    # frame 1: c's Ry(90) turns d's +Z bone to +X
    np.testing.assert_allclose(m.world_positions()[1],
                               [[0, 0, 0], [0, 0, 1], [0, 1, 1], [1, 1, 1]], atol=1e-12)


# ------------------------------------------------------------ round trips
@pytest.mark.parametrize("character", CHARACTERS)
def test_round_trip_every_character(tmp_path, character):
    rng = np.random.default_rng(7)
    ch = quadsim.load_character(character)
    skel = ch.skeleton
    m = smooth_motion(skel, rng, frames=30, fps=30.0)
    path = write_bvh(m, tmp_path / f"{character}.bvh")
    r = read_bvh(path)
    assert r.fps == m.fps and len(r) == len(m) == 30
    assert set(r.skeleton.names) == set(skel.names)
    parent = {n: (skel.names[p] if p >= 0 else None) for n, p in zip(skel.names, skel.parents)}
    parent_r = {n: (r.skeleton.names[p] if p >= 0 else None)
                for n, p in zip(r.skeleton.names, r.skeleton.parents)}
    assert parent_r == parent
    idx = r.skeleton.indices(skel.names)
    np.testing.assert_allclose(r.skeleton.offsets[idx[1:]], skel.offsets[1:], atol=1e-9)
    assert set(r.skeleton.end_sites) == set(skel.end_sites)
    for name, tip in skel.end_sites.items():
        np.testing.assert_allclose(r.skeleton.end_sites[name], tip, atol=1e-9)
    same_positions(m, r, atol=1e-6)
    np.testing.assert_allclose(r.root_positions, m.root_positions, atol=1e-9)
    assert r.foot_joints == ch.foot_joints


def test_round_trip_two_metre_chain_at_any_angle_and_gimbal_lock(tmp_path):
    # A 2 m chain of 12 bones with irregular offsets, uniformly random rotations
    # (angles up to 180 degrees), and frames exactly at and next to gimbal lock.
    rng = np.random.default_rng(11)
    J = 13
    off = rng.normal(size=(J, 3))
    off *= (2.0 / 12) / np.linalg.norm(off, axis=1, keepdims=True)
    skel = Skeleton(tuple(f"j{k}" for k in range(J)), np.arange(J) - 1, off,
                    {f"j{J - 1}": [0.0123456789, 0.1, -0.05]})
    T = 40
    q = rng.normal(size=(T, J, 4))
    m = Motion(skel, 60.0, rng.uniform(-50, 50, (T, 3)), q)
    for order in TAIT_BRYAN:
        # frames whose middle angle is exactly or almost +-90 degrees
        ang = rng.uniform(-np.pi, np.pi, (T, J, 3))
        ang[:, :, 1] = np.pi / 2 * np.sign(rng.normal(size=(T, J))) \
            - rng.choice([0.0, 1e-12, 1e-9, 1e-7, 1e-5], size=(T, J))
        lock = Motion.from_matrices(skel, 60.0, m.root_positions, matrices_from_euler(ang, order))
        for motion in (m, lock):
            r = read_bvh(write_bvh(motion, tmp_path / "c.bvh", rotation_order=order))
            err = same_positions(motion, r, atol=1e-6)
            assert err < 1e-8  # the default 9 decimals leave a wide margin
            ends_a = end_site_positions(skel, motion.world_rotations(), motion.world_positions())
            ends_b = end_site_positions(r.skeleton, r.world_rotations(), r.world_positions())
            np.testing.assert_allclose(ends_b[f"j{J - 1}"], ends_a[f"j{J - 1}"], atol=1e-8)


def test_units_cm_scales_lengths_by_100_and_reads_back(tmp_path):
    rng = np.random.default_rng(3)
    skel = quadsim.load_character(CHARACTERS[0]).skeleton
    m = smooth_motion(skel, rng)
    pm = write_bvh(m, tmp_path / "m.bvh", units="m")
    pc = write_bvh(m, tmp_path / "cm.bvh", units="cm")
    same_positions(m, read_bvh(pc, units="cm"), atol=1e-6)
    vm, vc = frame_values(pm), frame_values(pc)
    np.testing.assert_allclose(vc[:, :3], 100 * vm[:, :3], atol=1e-6)  # root position
    np.testing.assert_allclose(vc[:, 3:], vm[:, 3:], atol=1e-9)        # angles, degrees
    np.testing.assert_allclose(offset_values(pc), 100 * offset_values(pm), atol=1e-6)
    # the same cm file read as metres is 100 times too big
    np.testing.assert_allclose(read_bvh(pc, units="m").root_positions,
                               100 * m.root_positions, atol=1e-6)


@pytest.mark.parametrize("order", TAIT_BRYAN)
def test_every_rotation_order_round_trips(tmp_path, order):
    rng = np.random.default_rng(5)
    skel = quadsim.load_character(CHARACTERS[0]).skeleton
    m = smooth_motion(skel, rng, max_deg=90.0)
    path = write_bvh(m, tmp_path / "o.bvh", rotation_order=order.lower())
    rot = " ".join(f"{a}rotation" for a in order)
    chans = [s.strip() for s in path.read_text().splitlines() if "CHANNELS" in s]
    assert chans[0] == f"CHANNELS 6 Xposition Yposition Zposition {rot}"
    assert all(c == f"CHANNELS 3 {rot}" for c in chans[1:])
    same_positions(m, read_bvh(path), atol=1e-6)


def test_file_whose_joints_use_different_orders(tmp_path):
    # Written here independently of write_bvh: joint k uses order k % 6, and the
    # root lists its rotations before its positions.
    rng = np.random.default_rng(9)
    skel = quadsim.load_character(CHARACTERS[0]).skeleton
    m = smooth_motion(skel, rng, frames=12)
    orders = [TAIT_BRYAN[k % 6] for k in range(skel.n_joints)]
    dfs = bvh_module._depth_first(skel)
    lines = ["HIERARCHY"]

    def emit(j, ind):
        rot = " ".join(f"{a}rotation" for a in orders[j])
        kw = "ROOT" if j == 0 else "JOINT"
        off = " ".join(repr(float(v)) for v in (np.zeros(3) if j == 0 else skel.offsets[j]))
        ch = (f"CHANNELS 6 {rot} Xposition Yposition Zposition" if j == 0
              else f"CHANNELS 3 {rot}")
        lines.extend([f"{ind}{kw} {skel.names[j]}", ind + "{",
                      f"{ind}  OFFSET {off}", f"{ind}  {ch}"])
        for c in skel.children[j]:
            emit(c, ind + "  ")
        lines.append(ind + "}")

    emit(0, "")
    cols = []
    for j in dfs:
        cols.append(np.degrees(euler_from_matrices(m.local_matrices[:, j], orders[j])))
        if j == 0:
            cols.append(m.root_positions)
    data = np.concatenate(cols, axis=1)
    lines += ["MOTION", f"Frames: {len(m)}", f"Frame Time: {1 / m.fps!r}"]
    lines += [" ".join(repr(float(v)) for v in row) for row in data]
    path = tmp_path / "mixed.bvh"
    path.write_text("\n".join(lines) + "\n")
    r = read_bvh(path)
    same_positions(m, r, atol=1e-9)
    assert r.skeleton.end_sites == {}  # no End Site in this file


@pytest.mark.parametrize("fps", [60, 30, 24])
def test_frame_time_is_exact(tmp_path, fps):
    skel = quadsim.load_character(CHARACTERS[0]).skeleton
    m = smooth_motion(skel, np.random.default_rng(fps), frames=5, fps=fps)
    path = write_bvh(m, tmp_path / "t.bvh")
    (line,) = [s for s in path.read_text().splitlines() if s.startswith("Frame Time:")]
    ft = float(line.split(":")[1])
    assert abs(ft - 1.0 / fps) < 1e-15
    assert read_bvh(path).fps == float(fps)


@pytest.mark.parametrize("written, fps", [("0.0333333", 30.0), ("0.008333", 120.0),
                                          ("0.033366700", 1 / 0.0333667), ("0.5", 2.0)])
def test_rounded_frame_times_snap_to_whole_rates_only_when_exact(tmp_path, written, fps):
    (tmp_path / "f.bvh").write_text(FOUR_JOINTS.replace("Frame Time: 0.5",
                                                        f"Frame Time: {written}"))
    assert read_bvh(tmp_path / "f.bvh").fps == pytest.approx(fps, rel=1e-12)
    assert read_bvh(tmp_path / "f.bvh", fps=48).fps == 48.0


def test_written_file_has_the_structure_blender_expects(tmp_path):
    rng = np.random.default_rng(2)
    skel = quadsim.load_character(CHARACTERS[-1]).skeleton
    m = smooth_motion(skel, rng, frames=17)
    text = write_bvh(m, tmp_path / "s.bvh").read_text()
    lines = text.splitlines()
    assert lines[0] == "HIERARCHY"
    assert re.fullmatch(r"ROOT \S+", lines[1]) and lines[2] == "{"
    assert lines[3].split() == ["OFFSET", "0.000000000", "0.000000000", "0.000000000"]
    k = lines.index("MOTION")
    head = lines[:k]
    assert sum(s.count("{") for s in head) == sum(s.count("}") for s in head)
    depth = 0
    for s in head[1:]:  # braces balanced and never below zero; root closes last
        depth += s.count("{") - s.count("}")
        assert depth >= 0
    assert depth == 0 and head[-1] == "}"
    chans = [s.split() for s in head if s.strip().startswith("CHANNELS")]
    assert all(int(c[1]) == len(c) - 2 for c in chans)
    assert chans[0][2:5] == ["Xposition", "Yposition", "Zposition"]
    joint_lines = [s for s in head if s.strip().split()[0] in ("ROOT", "JOINT")]
    assert len(joint_lines) == len(chans) == skel.n_joints
    n_leaves = sum(1 for c in skel.children if not c)
    n_end = sum(1 for s in head if s.strip() == "End Site")
    assert n_end == len(set(skel.end_sites) | {skel.names[j] for j, c in
                                                enumerate(skel.children) if not c})
    assert n_end >= n_leaves
    assert re.fullmatch(r"Frames: \d+", lines[k + 1])
    assert re.fullmatch(r"Frame Time: [0-9.]+", lines[k + 2])
    frames = lines[k + 3:]
    assert int(lines[k + 1].split()[1]) == len(frames) == 17
    per_line = sum(int(c[1]) for c in chans)
    assert per_line == 6 + 3 * (skel.n_joints - 1)
    assert all(len(s.split()) == per_line for s in frames)
    assert "e" not in " ".join(frames).lower()  # plain decimals, no exponents
    assert text.endswith("\n")


def test_zero_frames_round_trip(tmp_path):
    skel = quadsim.load_character(CHARACTERS[0]).skeleton
    m = Motion(skel, 30.0, np.zeros((0, 3)), np.zeros((0, skel.n_joints, 4)))
    r = read_bvh(write_bvh(m, tmp_path / "z.bvh"))
    assert len(r) == 0 and r.fps == 30.0


# -------------------------------------------------------------- atomicity
def test_failed_write_leaves_previous_file_and_no_temp(tmp_path, monkeypatch):
    skel = quadsim.load_character(CHARACTERS[0]).skeleton
    m = smooth_motion(skel, np.random.default_rng(4))
    path = write_bvh(m, tmp_path / "keep.bvh")
    before = path.read_bytes()

    def fail_midway(f, values, p):
        f.write("0.1 0.2 0.3\n" * 3)
        raise RuntimeError("disk full (simulated)")

    monkeypatch.setattr(bvh_module, "_write_frames", fail_midway)
    with pytest.raises(RuntimeError, match="simulated"):
        write_bvh(m[:10], path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.bvh"]


def test_unwritable_destination_raises_input_error(tmp_path):
    skel = quadsim.load_character(CHARACTERS[0]).skeleton
    m = smooth_motion(skel, np.random.default_rng(6), frames=3)
    with pytest.raises(InputError, match=r"no_such_dir.*cannot write"):
        write_bvh(m, tmp_path / "no_such_dir" / "x.bvh")
    (tmp_path / "adir.bvh").mkdir()
    with pytest.raises(InputError, match=r"adir\.bvh: cannot write"):
        write_bvh(m, tmp_path / "adir.bvh")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["adir.bvh"]


# ----------------------------------------------------------- bad arguments
@pytest.mark.parametrize("kwargs, match", [
    ({"units": "mm"}, r"`units` must be one of 'm', 'cm', got 'mm'"),
    ({"rotation_order": "XXY"}, r"`rotation_order` must be three distinct letters"),
    ({"rotation_order": "XY"}, r"`rotation_order` must be three distinct letters"),
    ({"precision": -1}, r"`precision` must be an integer from 0 to 15"),
    ({"precision": 2.5}, r"`precision` must be an integer from 0 to 15"),
])
def test_write_rejects_bad_arguments(tmp_path, kwargs, match):
    skel = quadsim.load_character(CHARACTERS[0]).skeleton
    m = smooth_motion(skel, np.random.default_rng(8), frames=2)
    with pytest.raises(InputError, match=match):
        write_bvh(m, tmp_path / "a.bvh", **kwargs)
    assert list(tmp_path.iterdir()) == []


def test_write_rejects_joint_names_bvh_cannot_hold(tmp_path):
    skel = Skeleton(("root", "left leg"), [-1, 0], [[0, 1, 0], [0, -1, 0]])
    m = Motion(skel, 30.0, np.zeros((1, 3)), np.tile([1.0, 0, 0, 0], (1, 2, 1)))
    with pytest.raises(InputError, match=r"rename: 'left leg'"):
        write_bvh(m, tmp_path / "a.bvh")


def test_read_rejects_bad_arguments(tmp_path):
    (tmp_path / "a.bvh").write_text(FOUR_JOINTS)
    with pytest.raises(InputError, match=r"`units` must be one of"):
        read_bvh(tmp_path / "a.bvh", units="inch")
    with pytest.raises(InputError, match=r"`fps` must be a positive number"):
        read_bvh(tmp_path / "a.bvh", fps=0)


# --------------------------------------------------------- malformed files
def _edit(old, new, count=1):
    assert old in FOUR_JOINTS
    return FOUR_JOINTS.replace(old, new, count)


# the spine gets an X position channel that moves from 7 to 8
ANIMATED_SPINE = (_edit("CHANNELS 3 Zrotation Xrotation Yrotation\n    JOINT",
                        "CHANNELS 4 Xposition Zrotation Xrotation Yrotation\n    JOINT")
                  .replace("1 2 3  0 0 0  0", "1 2 3  0 0 0  7 0")
                  .replace("90 0 90  0", "90 0 90  8 0"))

MALFORMED = {
    "empty file": ("", r"bad\.bvh:1: empty file, expected HIERARCHY"),
    "blank file": ("\n  \n", r"bad\.bvh:1: empty file"),
    "missing HIERARCHY": (_edit("HIERARCHY\n", ""), r"bad\.bvh:1: expected HIERARCHY, got 'ROOT'"),
    "missing ROOT": (_edit("ROOT hips", "JOINT hips"), r"bad\.bvh:2: expected ROOT, got 'JOINT'"),
    "missing joint name": (_edit("JOINT neck", "JOINT"), r"bad\.bvh:10: expected a joint name"),
    "missing MOTION": (FOUR_JOINTS[:FOUR_JOINTS.index("MOTION")],
                       r"bad\.bvh:29: missing MOTION section"),
    "junk instead of MOTION": (_edit("MOTION", "MOTON"),
                               r"bad\.bvh:30: expected MOTION after the hierarchy; got 'MOTON'"),
    "second ROOT": (_edit("MOTION", "ROOT other\n{\n}\nMOTION"),
                    r"bad\.bvh:30: expected MOTION.*only one ROOT"),
    "bad channel count": (_edit("CHANNELS 3 Zrotation Xrotation Yrotation",
                                "CHANNELS 3 Zrotation Xrotation"),
                          r"bad\.bvh:9: bad channel count: CHANNELS 3 in joint 'spine' lists 2"),
    "non-integer channel count": (_edit("CHANNELS 3", "CHANNELS three"),
                                  r"bad\.bvh:9: CHANNELS count must be a whole number"),
    "unknown channel name": (_edit("CHANNELS 3 Zrotation Xrotation Yrotation\n      End",
                                   "CHANNELS 3 Zrotation Xrotation Wrotation\n      End"),
                             r"bad\.bvh:13: unknown channel name 'Wrotation' in joint 'neck'"),
    "repeated channel": (_edit("CHANNELS 3 Zrotation Xrotation Yrotation",
                               "CHANNELS 3 Zrotation Xrotation Zrotation"),
                         r"bad\.bvh:9: channel 'Zrotation' repeated in joint 'spine'"),
    "short OFFSET": (_edit("OFFSET 0 0 1", "OFFSET 0 1"),
                     r"bad\.bvh:8: OFFSET of joint 'spine' needs three numbers, got 2"),
    "non-numeric OFFSET": (_edit("OFFSET 0 0 1", "OFFSET 0 zero 1"),
                           r"bad\.bvh:8: expected a number, got 'zero'"),
    "missing OFFSET": (_edit("    OFFSET 0 0 1\n", ""),
                       r"bad\.bvh:\d+: joint 'spine' \(line 6\) has no OFFSET"),
    "unexpected keyword": (_edit("OFFSET 0 0 1", "OFSET 0 0 1"),
                           (r"bad\.bvh:8: expected OFFSET, CHANNELS, JOINT, End Site or '}' "
                            r"in joint 'spine', got 'OFSET'")),
    "End without Site": (_edit("End Site", "End Sight"), r"bad\.bvh:14: expected 'Site'"),
    "unbalanced braces, missing }": (_edit("  }\n  JOINT leg", "  JOINT leg"),
                                     (r"bad\.bvh:29: MOTION before joint 'hips' "
                                      r"\(opened at line 2\) was closed: unbalanced braces")),
    "unbalanced braces, extra }": (_edit("}\nMOTION", "}\n}\nMOTION"),
                                   r"bad\.bvh:30: expected MOTION after the hierarchy; got '}'"),
    "unbalanced braces, end of file": (FOUR_JOINTS[:FOUR_JOINTS.index("  JOINT leg")],
                                       (r"bad\.bvh:19: unexpected end of file, expected '}' to "
                                        r"close joint 'hips' opened at line 2 "
                                        r"\(unbalanced braces\)")),
    "missing Frames": (_edit("Frames: 2\n", ""), r"bad\.bvh:31: expected 'Frames: <count>'"),
    "non-integer Frames": (_edit("Frames: 2", "Frames: two"),
                           r"bad\.bvh:31: Frames must be a whole number >= 0, got 'two'"),
    "missing Frame Time": (_edit("Frame Time: 0.5\n", ""),
                           r"bad\.bvh:32: expected 'Frame Time: <seconds>'"),
    "zero Frame Time": (_edit("Frame Time: 0.5", "Frame Time: 0"),
                        r"bad\.bvh:32: Frame Time must be positive"),
    "too few values in a frame line": (_edit("0 0 0  90 0 90  0 90 0  0 0 0  90 0 0",
                                             "0 0 0  90 0 90  0 90 0  0 0 0  90 0"),
                                       r"bad\.bvh:34: frame line has 14 values, expected 15"),
    "too many values in a frame line": (_edit("1 2 3  0 0 0", "1 2 3  0 0 0 0"),
                                        r"bad\.bvh:33: frame line has 16 values, expected 15"),
    "non-numeric frame value": (_edit("0 0 0  90 0 90", "0 0 0  90 O 90"),
                                r"bad\.bvh:34: expected a number, got 'O'"),
    "nan in a frame": (_edit("0 0 0  90 0 90", "0 0 0  90 nan 90"),
                       r"bad\.bvh:34: expected finite numbers"),
    "Frames larger than the lines": (_edit("Frames: 2", "Frames: 3"),
                                     r"bad\.bvh:34: 'Frames: 3' but the file has only 2 frame"),
    "Frames smaller than the lines": (_edit("Frames: 2", "Frames: 1"),
                                      r"bad\.bvh:34: more frame lines than 'Frames: 1'"),
    "duplicate joint names": (_edit("JOINT leg", "JOINT neck"),
                              r"bad\.bvh: joint names must be unique; repeated: neck"),
    "animated non-root position": (ANIMATED_SPINE,
                                   r"bad\.bvh:9: joint 'spine' has animated position channels"),
}


@pytest.mark.parametrize("kind", list(MALFORMED))
def test_malformed_file_raises_input_error_naming_file_and_line(tmp_path, kind):
    text, match = MALFORMED[kind]
    path = tmp_path / "bad.bvh"
    path.write_text(text)
    with pytest.raises(InputError, match=match):
        read_bvh(path)


def test_missing_file_raises_input_error(tmp_path):
    with pytest.raises(InputError, match=r"nothere\.bvh: no such BVH file"):
        read_bvh(tmp_path / "nothere.bvh")


# --------------------------------------------------------------- foot joints
def test_guess_foot_joints_takes_the_deepest_joint_of_each_leg():
    names = ("pelvis", "spine", "LF_top", "LF_hoof", "RF_top", "RF_hoof",
             "LH_top", "LH_mid", "LH_hoof", "RH_top", "RH_mid", "RH_hoof", "RH_spur")
    parents = [-1, 0, 1, 2, 1, 4, 0, 6, 7, 0, 9, 10, 9]
    skel = Skeleton(names, parents, np.zeros((len(names), 3)))
    assert guess_foot_joints(skel) == ("LF_hoof", "RF_hoof", "LH_hoof", "RH_hoof")
    no_rh = Skeleton(names[:9], parents[:9], np.zeros((9, 3)))
    assert guess_foot_joints(no_rh) is None
    # "LFoot" does not follow the LF_ convention
    other = Skeleton(("root", "LFoot"), [-1, 0], np.zeros((2, 3)))
    assert guess_foot_joints(other) is None
