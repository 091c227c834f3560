"""`quadsim retarget` and quadsim.robots on small quadrupeds written by the test itself.

No simulator is needed here: the URDF reader, leg detection, IK, joint limits, the
Froude scaling and the files are checked against the robots' own kinematics.
tests/test_retarget_pybullet.py plays the references back in PyBullet.
"""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest

from quadsim.cli import main
from quadsim.errors import InputError
from quadsim.robots.legs import find_legs
from quadsim.robots.retarget import froude_scale, nominal_stance, retarget
from quadsim.robots.urdf import read_urdf, rpy_matrix

#: Leg name -> (forward, left) of its hip in the body frame (m), in an unusual file order.
HIPS = {"hind_right": (-0.18, -0.05), "front_left": (0.18, 0.05),
        "hind_left": (-0.18, 0.05), "front_right": (0.18, -0.05)}
#: quadsim's frame as a base frame: body forward along +Z, left +X, up +Y.
Y_UP = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])


def _rpy_of(R: np.ndarray) -> tuple[float, float, float]:
    """URDF rpy of a rotation made of quarter turns."""
    for rpy in itertools.product((0.0, math.pi / 2, math.pi, -math.pi / 2), repeat=3):
        if np.allclose(rpy_matrix(rpy), R, atol=1e-9):
            return rpy
    raise AssertionError("not a quarter-turn rotation")


def quadruped_urdf(*, legs=tuple(HIPS), base_frame=np.eye(3), thigh_limit=(-1.0, 2.5),
                   knee_limit=(-2.6, -0.6), continuous=False, extras=False) -> str:
    """An A1-like quadruped: abduction (x), hip (y) and knee (y) per leg, 0.2 m thigh and
    shank, a 2 cm toe sphere; ``base_frame`` maps body coordinates to the base link's.
    ``extras`` adds a spine joint the hind legs hang from, a sensor link on each shank
    and a two-joint head."""
    rpy = _rpy_of(base_frame)
    out = ['<robot name="synthetic">', '  <link name="trunk"/>']
    if extras:
        out += ['  <link name="rear"/>', '  <link name="neck"/>', '  <link name="head"/>',
                '  <joint name="spine" type="revolute"><parent link="trunk"/>'
                '<child link="rear"/><axis xyz="0 1 0"/>'
                '<limit lower="-0.3" upper="0.3"/></joint>',
                '  <joint name="neck_yaw" type="continuous"><parent link="trunk"/>'
                '<child link="neck"/><origin xyz="0.25 0 0.05"/><axis xyz="0 0 1"/></joint>',
                '  <joint name="neck_pitch" type="continuous"><parent link="neck"/>'
                '<child link="head"/><origin xyz="0.05 0 0"/><axis xyz="0 1 0"/></joint>']

    def limit(lim):
        return "" if continuous else f'<limit lower="{lim[0]}" upper="{lim[1]}" ' \
            'effort="20" velocity="20"/>'

    kind = "continuous" if continuous else "revolute"
    for name in legs:
        fx, ly = HIPS[name]
        side = 1 if ly > 0 else -1
        hip = base_frame @ np.array([fx, ly, 0.0])
        parent = "rear" if extras and fx < 0 else "trunk"
        if extras:
            out += [f'  <link name="{name}_sensor"/>',
                    f'  <joint name="{name}_sensor" type="fixed"><parent link="{name}_shank"/>'
                    f'<child link="{name}_sensor"/><origin xyz="0 0 -0.1"/></joint>']
        out += [f'  <link name="{name}_hip"/>', f'  <link name="{name}_thigh"/>',
                f'  <link name="{name}_shank"/>',
                f'  <link name="{name}_toe"><collision><origin xyz="0 0 0"/><geometry>'
                '<sphere radius="0.02"/></geometry></collision></link>',
                f'  <joint name="{name}_abduct" type="{kind}"><parent link="{parent}"/>'
                f'<child link="{name}_hip"/><origin xyz="{hip[0]} {hip[1]} {hip[2]}" '
                f'rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/><axis xyz="1 0 0"/>'
                f'{limit((-0.8, 0.8))}</joint>',
                f'  <joint name="{name}_hip" type="{kind}"><parent link="{name}_hip"/>'
                f'<child link="{name}_thigh"/><origin xyz="0 {0.08 * side} 0"/>'
                f'<axis xyz="0 1 0"/>{limit(thigh_limit)}</joint>',
                f'  <joint name="{name}_knee" type="{kind}"><parent link="{name}_thigh"/>'
                f'<child link="{name}_shank"/><origin xyz="0 0 -0.2"/><axis xyz="0 1 0"/>'
                f'{limit(knee_limit)}</joint>',
                f'  <joint name="{name}_foot" type="fixed"><parent link="{name}_shank"/>'
                f'<child link="{name}_toe"/><origin xyz="0 0 -0.2"/></joint>']
    return "\n".join(out + ["</robot>", ""])


@pytest.fixture
def robot_file(tmp_path):
    def write(name="robot.urdf", **kw):
        path = tmp_path / name
        path.write_text(quadruped_urdf(**kw), encoding="utf-8")
        return path
    return write


@pytest.fixture(scope="module")
def dog_cub_trot():
    """The dog cub and its trot command at 1.2 m/s."""
    from quadsim.api import resolve

    config = resolve("dog_cub", gait="trot", speed=1.2)
    character = config.load_character()
    return character, config


# ---------------------------------------------------------------- URDF reader
def test_rpy_is_fixed_axis_roll_then_pitch_then_yaw():
    r, p, y = 0.3, -0.7, 1.1
    Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    assert np.allclose(rpy_matrix((r, p, y)), Rz @ Ry @ Rx)


def test_the_reader_keeps_the_tree_origins_axes_limits_and_toe_spheres(robot_file):
    urdf = read_urdf(robot_file())
    assert urdf.root == "trunk"
    assert len(urdf.movable_joints) == 12 and len(urdf.joints) == 16
    knee = next(j for j in urdf.joints if j.name == "front_left_knee")
    assert (knee.lower, knee.upper) == (-2.6, -0.6)
    assert np.allclose(knee.axis, [0, 1, 0]) and np.allclose(knee.origin[:3, 3], [0, 0, -0.2])
    assert urdf.links["front_left_toe"].sphere_radius == 0.02
    toe = urdf.zero_pose()["front_left_toe"][:3, 3]
    assert np.allclose(toe, [0.18, 0.13, -0.4])


def test_a_continuous_joint_has_no_limits(robot_file):
    urdf = read_urdf(robot_file(continuous=True))
    assert all(j.lower == -math.inf and j.upper == math.inf for j in urdf.movable_joints)


@pytest.mark.parametrize("text, words", [
    ("<robot><link name='a'/><link name='b'/><joint name='j' type='floating'>"
     "<parent link='a'/><child link='b'/></joint></robot>", ["'floating'", "allowed"]),
    ("<robot><link name='a'/><link name='b'/></robot>", ["2 root links"]),
    ("<robot><link name='a'/><link name='b'/><joint name='j' type='revolute'>"
     "<parent link='a'/><child link='b'/><origin xyz='0 0'/></joint></robot>",
     ["joint 'j' origin xyz", "3 numbers"]),
    ("<robot><link name='a'/>", ["not a readable URDF"]),
    ("<sdf/>", ["<sdf>", "not <robot>"]),
])
def test_a_malformed_urdf_is_an_input_error_naming_the_element(tmp_path, text, words):
    path = tmp_path / "bad.urdf"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as e:
        read_urdf(path)
    for w in words:
        assert w in str(e.value)


# ---------------------------------------------------------------- legs
def test_legs_are_named_by_where_they_stand_not_by_file_order(robot_file):
    robot = find_legs(read_urdf(robot_file()))
    assert [leg.foot_link for leg in robot.legs] == [
        "front_left_toe", "front_right_toe", "hind_left_toe", "hind_right_toe"]
    assert [leg.name for leg in robot.legs] == ["LF", "RF", "LH", "RH"]
    assert [j.name for j in robot.legs[0].joints] == [
        "front_left_abduct", "front_left_hip", "front_left_knee"]
    assert np.allclose(robot.body, np.eye(3))
    # the columns are the URDF's movable joints in file order
    assert robot.joint_names[:3] == ("hind_right_abduct", "hind_right_hip", "hind_right_knee")


def test_a_base_frame_that_is_y_up_and_z_forward_is_found(robot_file):
    robot = find_legs(read_urdf(robot_file(base_frame=Y_UP)))
    assert np.allclose(robot.body, Y_UP)  # columns: forward, left, up in the base frame
    assert robot.legs[0].foot_link == "front_left_toe"


def test_spine_head_and_sensor_links_are_not_legs(robot_file, dog_cub_trot):
    robot = find_legs(read_urdf(robot_file(extras=True)))
    assert [leg.foot_link for leg in robot.legs] == [
        "front_left_toe", "front_right_toe", "hind_left_toe", "hind_right_toe"]
    assert all(len(leg.joints) == 3 for leg in robot.legs)
    assert {"spine", "neck_yaw", "neck_pitch"} <= set(robot.joint_names)
    character, config = dog_cub_trot
    ref, _, _ = _reference(robot, character, config, seconds=1.0)
    held = [robot.joint_names.index(n) for n in ("spine", "neck_yaw", "neck_pitch")]
    assert np.all(ref.joint_angles[:, held] == 0.0)
    assert np.abs(ref.foot_positions[..., 2][ref.contacts] - 0.02).max() < 1e-3


def test_three_legs_are_refused(robot_file):
    with pytest.raises(InputError, match="found 3 leg chain"):
        find_legs(read_urdf(robot_file(legs=("front_left", "front_right", "hind_left"))))


def test_ik_reaches_targets_in_reach_and_keeps_every_limit(robot_file):
    robot = find_legs(read_urdf(robot_file()))
    leg = robot.legs[0]
    rng = np.random.default_rng(3)
    q_true = rng.uniform([-0.5, -0.5, -2.2], [0.5, 1.5, -0.8], size=(200, 3))
    target = leg.frames(q_true)[1]
    seed = nominal_stance(robot).seeds[0]
    q, res = leg.solve(target, seed)
    assert res.max() < 1e-6
    far = target * 3.0  # out of reach: the foot gets as close as the limits allow
    q, res = leg.solve(far, seed)
    assert np.all(q >= leg.lower) and np.all(q <= leg.upper)
    assert res.min() > 0.1


def test_the_stance_seed_bends_the_knee_behind_the_foot(robot_file):
    robot = find_legs(read_urdf(robot_file(continuous=True)))
    nominal = nominal_stance(robot)
    for leg, seed in zip(robot.legs, nominal.seeds):
        T, foot = leg.frames(seed[None])
        knee, hip = T[0, 2, :3, 3], T[0, 1, :3, 3]
        assert knee[0] < (hip[0] + foot[0, 0]) / 2
    assert nominal.hip_height == pytest.approx(0.75 * 0.4)


# ---------------------------------------------------------------- retargeting
def _reference(robot, character, config, seconds=3.0, fps=60.0, **kw):
    from quadsim.api import simulate

    nominal = nominal_stance(robot)
    s = froude_scale(character, nominal)
    motion = simulate(character, config.commands, seconds=seconds / math.sqrt(s),
                      fps=fps * math.sqrt(s))
    return retarget(motion, character, robot, nominal, scale=s, **kw), motion, s


def _stance_slides(ref):
    out = []
    for k in range(4):
        c = ref.contacts[:, k]
        edges = np.flatnonzero(np.diff(np.r_[0, c.astype(int), 0]))
        for a, b in zip(edges[::2], edges[1::2]):
            out.append(np.linalg.norm(ref.foot_positions[a:b, k, :2]
                                      - ref.foot_positions[a, k, :2], axis=1).max())
    return np.array(out)


@pytest.mark.parametrize("frame", ["z_up", "y_up"])
def test_a_trot_on_the_synthetic_robot_plants_its_feet_within_its_limits(
        robot_file, dog_cub_trot, frame):
    character, config = dog_cub_trot
    robot = find_legs(read_urdf(robot_file(base_frame=np.eye(3) if frame == "z_up"
                                           else Y_UP)))
    ref, motion, s = _reference(robot, character, config)
    assert ref.n_frames == 180 and ref.fps == pytest.approx(60.0)
    z = ref.foot_positions[..., 2]
    assert np.abs(z[ref.contacts] - 0.02).max() < 1e-3  # the toe sphere on the ground
    assert z.min() > 0.02 - 1e-3  # never below it
    assert _stance_slides(ref).max() < 1e-3
    q = ref.joint_angles
    assert np.all(q >= robot.lower) and np.all(q <= robot.upper)
    assert np.mean(ref.contacts[:, 0] == ref.contacts[:, 3]) > 0.9  # diagonals together
    assert np.mean(ref.contacts[:, 1] == ref.contacts[:, 2]) > 0.9
    travel = ref.base_position[-1] - ref.base_position[0]
    assert travel[0] > 1.0 and abs(travel[1]) < 0.05
    assert np.allclose(np.linalg.norm(ref.base_quaternion, axis=1), 1.0)
    assert ref.info["leg_clearance_min"] >= 0.06


def test_the_feet_stand_under_the_robots_own_hips(robot_file, dog_cub_trot):
    """Feet placed by the robot's legs: planted, they straddle its hips (0.13 m out, where
    the toes hang at zero angles), not the animal's narrower track scaled."""
    character, config = dog_cub_trot
    robot = find_legs(read_urdf(robot_file()))
    ref, _, _ = _reference(robot, character, config)
    from quadsim.kinematics.rotations import matrices_from_quaternions

    R = matrices_from_quaternions(ref.base_quaternion[:, [3, 0, 1, 2]])
    local = np.einsum("tba,tlb->tla", R, ref.foot_positions - ref.base_position[:, None])
    for k, lateral in enumerate((0.13, -0.13, 0.13, -0.13)):
        planted = local[ref.contacts[:, k], k]
        assert planted[:, 1].mean() == pytest.approx(lateral, abs=0.01)
        assert planted[:, 0].mean() == pytest.approx(0.18 if k < 2 else -0.18, abs=0.06)


def test_a_turning_trot_keeps_planted_feet_still(robot_file):
    from quadsim.api import resolve

    config = resolve("dog_cub", gait="trot", speed=1.2, turn_rate_deg_s=30.0)
    character = config.load_character()
    robot = find_legs(read_urdf(robot_file()))
    ref, _, _ = _reference(robot, character, config)
    assert _stance_slides(ref).max() < 1e-3
    heading = np.arctan2(*(ref.base_position[-1, 1::-1] - ref.base_position[-20, 1::-1]))
    assert abs(heading) > 0.5  # it turned


@pytest.mark.parametrize("frame", ["z_up", "y_up"])
def test_the_base_pitches_and_heaves_with_the_animals_trunk(robot_file, frame):
    """A canter rocks the trunk: the robot's nose rises as the animal's withers do, and
    its hips stand at the robot's stance height times the animal's trunk height ratio."""
    from quadsim.api import resolve
    from quadsim.kinematics.rotations import matrices_from_quaternions
    from quadsim.robots.retarget import _trunk

    config = resolve("leopard", gait="canter")
    character = config.load_character()
    robot = find_legs(read_urdf(robot_file(base_frame=np.eye(3) if frame == "z_up"
                                           else Y_UP)))
    ref, motion, _ = _reference(robot, character, config, seconds=2.0)
    R = matrices_from_quaternions(ref.base_quaternion[:, [3, 0, 1, 2]])
    nose = np.einsum("tab,b->ta", R, robot.body[:, 0])[:, 2]
    trunk = _trunk(motion, character)
    assert np.ptp(trunk.pitch) > 0.1
    assert np.allclose(np.arcsin(nose), trunk.pitch, atol=1e-6)
    hips = ref.base_position[:, 2]  # the synthetic robot's hips are level with its base
    expected = 0.02 + 0.3 * trunk.mid[:, 2] / trunk.rest_mid[2]
    assert np.allclose(hips, expected, atol=1e-6)


def test_the_robot_runs_at_the_animals_froude_number(robot_file, dog_cub_trot):
    character, config = dog_cub_trot
    robot = find_legs(read_urdf(robot_file()))
    ref, motion, s = _reference(robot, character, config)
    k = ref.info["stride_factor"]
    animal = np.linalg.norm(motion.root_positions[-1, [0, 2]] - motion.root_positions[0, [0, 2]])
    robot_speed = ref.info["robot_speed"]
    assert robot_speed == pytest.approx(animal / motion.duration * math.sqrt(s) * k, rel=0.03)
    assert s == pytest.approx(0.3 / character.hip_height)


def test_tight_limits_shorten_the_stride_with_a_warning_and_are_never_exceeded(
        robot_file, dog_cub_trot):
    character, config = dog_cub_trot
    robot = find_legs(read_urdf(robot_file(thigh_limit=(0.45, 0.95))))
    said = []
    ref, _, _ = _reference(robot, character, config, warn=said.append)
    assert any("stride was shortened" in m for m in said)
    assert ref.info["stride_factor"] < 1.0
    q = ref.joint_angles
    assert np.all(q >= robot.lower) and np.all(q <= robot.upper)


# ---------------------------------------------------------------- the command
def test_the_command_writes_the_motion_imitation_json(robot_file, tmp_path, capsys):
    urdf = robot_file()
    out = tmp_path / "ref.json"
    assert main(["retarget", "dog_cub", "--robot", str(urdf), "--gait", "trot", "--speed",
                 "1.0", "--seconds", "1", "--out", str(out)]) == 0
    data = json.loads(out.read_text(encoding="utf-8"))
    assert data["LoopMode"] == "Clamp" and data["FrameDuration"] == pytest.approx(1 / 60)
    names = [j.name for j in read_urdf(urdf).movable_joints]
    assert data["JointNames"] == names
    frames = np.array(data["Frames"])
    assert frames.shape == (60, 7 + 12)
    assert np.allclose(np.linalg.norm(frames[:, 3:7], axis=1), 1.0, atol=1e-5)
    assert "wrote" in capsys.readouterr().out


def test_the_npz_holds_feet_contacts_and_gaits_too(robot_file, tmp_path):
    out = tmp_path / "ref.npz"
    assert main(["retarget", "dog_cub", "--robot", str(robot_file()), "--seconds", "1",
                 "--out", str(out)]) == 0
    z = np.load(out)
    T = len(z["frames"])
    assert z["foot_positions"].shape == (T, 4, 3) == z["foot_velocities"].shape
    assert z["contacts"].shape == (T, 4) and z["contacts"].dtype == bool
    assert set(z["gaits"]) == {"trot"}  # a character without --gait trots
    assert list(z["leg_names"]) == ["LF", "RF", "LH", "RH"]
    assert np.allclose(z["frames"][:, 7:], z["joint_angles"])


def _input_error(code, capsys, *words):
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("quadsim: error: ") and "Traceback" not in err
    for w in words:
        assert w in err


def test_bad_inputs_exit_2_naming_the_field(robot_file, tmp_path, capsys):
    urdf = str(robot_file())
    three = str(robot_file("three.urdf", legs=("front_left", "front_right", "hind_left")))
    _input_error(main(["retarget", "dog_cub", "--robot", urdf, "--out", "r.bvh"]), capsys,
                 "`--out`", ".json or .npz")
    _input_error(main(["retarget", "dog_cub", "--robot", str(tmp_path / "none.urdf"),
                       "--out", str(tmp_path / "r.json")]), capsys, "`--robot`", "no such")
    _input_error(main(["retarget", "dog_cub", "--robot", three,
                       "--out", str(tmp_path / "r.json")]), capsys, "found 3 leg chain")
    _input_error(main(["retarget", "dog_cub", "--robot", urdf, "--gait", "hop",
                       "--out", str(tmp_path / "r.json")]), capsys, "gait", "hop")
    _input_error(main(["retarget", "dog_cub", "--robot", urdf, "--seconds", "-1",
                       "--out", str(tmp_path / "r.json")]), capsys, "`--seconds`")
    assert not list(tmp_path.glob("r.*"))


def test_legs_that_cannot_stand_are_an_input_error(robot_file, tmp_path, capsys):
    urdf = str(robot_file(thigh_limit=(2.9, 3.1)))  # thighs held pointing up
    _input_error(main(["retarget", "dog_cub", "--robot", urdf, "--out",
                       str(tmp_path / "r.json")]), capsys, "standing pose", "limits")


def test_the_command_has_help(capsys):
    assert main(["retarget", "--help"]) == 0
    assert "--robot" in capsys.readouterr().out
    assert main(["--help"]) == 0
    assert "retarget" in capsys.readouterr().out
