"""Metrics measured from motion, checked on synthetic footfalls with known truth."""

import json

import numpy as np
import pytest

from quadsim.analysis import (
    angular_acceleration,
    angular_velocity,
    body_span,
    contact_intervals,
    default_contact_thresholds,
    duty_factors,
    foot_contacts,
    foot_slide,
    format_report,
    ground_penetration,
    motion_report,
    penetration_depth,
    phases,
    report_from_positions,
    root_speed,
    stance_intervals,
    stride_frequency,
    stride_length,
    stride_table,
    touchdown_times,
)
from quadsim.frames import LEGS
from quadsim.kinematics.rotations import (
    matrices_about_axis,
    matrices_from_axis_angles,
    quaternions_from_matrices,
)
from quadsim.skeleton import Motion, Skeleton

#: Hip/shoulder offsets from the root (m): fore feet 0.5 m ahead, hind 0.5 m behind.
HIPS = np.array([[0.15, 0.0, 0.5], [-0.15, 0.0, 0.5], [0.15, 0.0, -0.5], [-0.15, 0.0, -0.5]])
WALK = {"duty": 0.6, "phase": (0.25, 0.75, 0.0, 0.5)}


def synth_gait(duty, phase, *, period=1.0, fps=60.0, seconds=10.0, speed=1.5,
               swing_height=0.08, t0=0.1, root_height=0.8, eased=True):
    """Feet planted during stance, lifted on a sine arc in swing, root at constant speed.

    Foot i touches down at ``t0 + (n + phase[i]) * period`` and stays down for
    ``duty * period``; in swing it moves forward by one stride length, eased
    (zero horizontal velocity at lift-off and touchdown) or at constant speed
    (``eased=False``). Returns times (T,), feet (T, 4, 3),
    root (T, 3) and the true contacts (T, 4).
    """
    t = np.arange(round(seconds * fps)) / fps
    stride = speed * period
    phase = np.asarray(phase, dtype=float)
    cyc = (t[:, None] - t0) / period - phase
    n = np.floor(cyc)
    u = cyc - n
    swing = u >= duty
    s = np.clip((u - duty) / (1.0 - duty), 0.0, 1.0)
    plant0 = HIPS[:, 2] + speed * (t0 + (phase + duty / 2) * period)
    feet = np.empty(t.shape + (4, 3))
    feet[..., 0] = HIPS[:, 0]
    feet[..., 1] = np.where(swing, swing_height * np.sin(np.pi * s), 0.0)
    progress = (1 - np.cos(np.pi * s)) / 2 if eased else s
    feet[..., 2] = plant0 + n * stride + np.where(swing, stride * progress, 0.0)
    root = np.stack([np.zeros_like(t), np.full_like(t, root_height), speed * t], axis=-1)
    return t, feet, root, ~swing


def circular_diff(a, b):
    d = (np.asarray(a) - np.asarray(b)) % 1.0
    return np.minimum(d, 1.0 - d)


# ------------------------------------------------------------ footfalls
def test_walk_duty_factor_phases_and_stride_are_measured():
    _, feet, root, _ = synth_gait(**WALK)
    c = foot_contacts(feet, 60.0)
    np.testing.assert_allclose(duty_factors(c, 60.0, feet), 0.6, atol=0.02)
    assert np.all(circular_diff(phases(c, 60.0, feet), WALK["phase"]) < 0.02)
    assert stride_frequency(c, 60.0, feet) == pytest.approx(1.0, abs=0.005)
    assert stride_length(root, c, 60.0, feet) == pytest.approx(1.5, abs=0.01)


@pytest.mark.parametrize("case", [
    # trot between frames
    {"duty": 0.4, "phase": (0.5, 0.0, 0.0, 0.5), "period": 0.93, "fps": 50.0,
     "t0": 0.0537, "speed": 2.5},
    # pace
    {"duty": 0.5, "phase": (0.05, 0.55, 0.0, 0.5), "period": 0.8, "fps": 30.0, "t0": 0.21},
    # rotary gallop
    {"duty": 0.25, "phase": (0.55, 0.35, 0.0, 0.12), "period": 0.4, "fps": 120.0,
     "t0": 0.013, "speed": 6.0, "swing_height": 0.15},
    # slow walk at a low frame rate
    {"duty": 0.7, "phase": (0.2, 0.7, 0.0, 0.5), "period": 1.37, "fps": 24.0,
     "t0": 0.3, "speed": 0.8},
])
def test_duty_and_phase_hold_for_other_gaits_and_frame_rates(case):
    _, feet, _, _ = synth_gait(**case)
    fps = case["fps"]
    c = foot_contacts(feet, fps)
    np.testing.assert_allclose(duty_factors(c, fps, feet), case["duty"], atol=0.02)
    assert np.all(circular_diff(phases(c, fps, feet), case["phase"]) < 0.02)
    assert stride_frequency(c, fps, feet) == pytest.approx(1 / case["period"], rel=0.005)


def test_touchdown_times_are_refined_below_a_frame():
    fps, period, t0 = 50.0, 0.93, 0.0537          # touchdowns fall between frames
    phase = np.array([0.25, 0.75, 0.0, 0.5])
    _, feet, _, _ = synth_gait(0.6, phase, period=period, fps=fps, t0=t0)
    c = foot_contacts(feet, fps)
    for i, td in enumerate(touchdown_times(c, fps, feet)):
        truth = t0 + (np.round((td - t0) / period - phase[i]) + phase[i]) * period
        assert len(td) >= 9
        np.testing.assert_allclose(td, truth, atol=0.25 / fps)
    iv = stance_intervals(c, fps, feet)[2]
    whole = np.all(np.isfinite(iv), axis=1)
    np.testing.assert_allclose(iv[whole, 1] - iv[whole, 0], 0.6 * period, atol=0.5 / fps)


def test_contacts_agree_with_the_true_stance():
    _, feet, _, truth = synth_gait(**WALK)
    c = foot_contacts(feet, 60.0)
    # every planted frame is found; at most the frame next to each end of a
    # stance (the foot still low and slow) is added
    assert np.all(c[truth])
    assert np.mean(c == truth) > 0.95
    assert not np.any(c[feet[..., 1] > 0.03])   # a lifted foot is never in contact


def test_a_foot_landing_at_speed_is_in_contact_only_once_planted():
    # constant-speed swing: the last airborne frame can be a millimetre above
    # the ground and slow into the touchdown, yet it is not part of the stance
    for fps in (30.0, 60.0, 120.0):
        _, feet, _, truth = synth_gait(**WALK, fps=fps, period=0.93, t0=0.051, eased=False)
        c = foot_contacts(feet, fps)
        np.testing.assert_array_equal(c, truth)
        assert foot_slide(feet, c)[1] < 1e-9
        np.testing.assert_allclose(duty_factors(c, fps, feet), 0.6, atol=0.005)


def test_jittery_feet_still_give_the_footfall_pattern():
    rng = np.random.default_rng(3)
    _, feet, _, truth = synth_gait(**WALK, period=0.9, t0=0.05)
    feet = feet + rng.normal(scale=0.0003, size=feet.shape)      # 0.3 mm noise
    c = foot_contacts(feet, 60.0)
    assert np.mean(c == truth) > 0.99
    np.testing.assert_allclose(duty_factors(c, 60.0, feet), 0.6, atol=0.01)
    assert np.all(circular_diff(phases(c, 60.0, feet), WALK["phase"]) < 0.01)


def test_contacts_from_flags_alone_give_frame_precision():
    truth = synth_gait(**WALK)[3]
    duty = duty_factors(truth, 60.0)
    np.testing.assert_allclose(duty, 0.6, atol=1.5 / 60)
    assert np.all(circular_diff(phases(truth, 60.0), WALK["phase"]) < 0.02)


def test_stride_table_has_one_row_per_whole_stride():
    _, feet, _, _ = synth_gait(**WALK)
    c = foot_contacts(feet, 60.0)
    t = stride_table(c, 60.0, feet)
    counts = np.bincount(t["leg"], minlength=4)
    assert np.all(counts >= 8) and np.all(counts <= 10)
    np.testing.assert_allclose(t["period"], 1.0, atol=1e-9)
    np.testing.assert_allclose(t["duty"], 0.6, atol=0.02)
    np.testing.assert_allclose(t["length"], 1.5, atol=1e-9)
    assert np.all(np.diff(t["touchdown"][t["leg"] == 0]) > 0)


def test_results_do_not_depend_on_the_frame_rate():
    out = []
    for fps in (30.0, 60.0, 120.0):
        _, feet, _, _ = synth_gait(**WALK, fps=fps)
        c = foot_contacts(feet, fps)
        out.append(np.concatenate([duty_factors(c, fps, feet), phases(c, fps, feet)]))
    np.testing.assert_allclose(out[0], out[2], atol=0.02)
    np.testing.assert_allclose(out[1], out[2], atol=0.01)


def test_default_thresholds_scale_with_the_body():
    _, feet, _, _ = synth_gait(**WALK)
    assert body_span(feet) == pytest.approx(1.0, abs=0.01)
    h, v = default_contact_thresholds(feet)
    assert h == pytest.approx(0.02, abs=1e-3)
    assert v == pytest.approx(0.25 * np.sqrt(9.81), abs=0.01)
    h_small, _ = default_contact_thresholds(feet * 0.1)
    assert h_small == 0.005                     # floor for a small animal


# ------------------------------------------------------- blips and intervals
def test_a_one_frame_blip_is_not_a_contact_and_a_one_frame_gap_is_filled():
    T = 40
    feet = np.zeros((T, 4, 3))
    feet[:, :, 1] = 0.2                         # every foot hovers still
    feet[10, 0, 1] = 0.0                        # LF touches for one frame
    feet[20:25, 1, 1] = 0.0                     # RF touches for five frames
    feet[5:30, 2, 1] = 0.0                      # LH stands...
    feet[17, 2, 1] = 0.05                       # ...but is lifted on one frame
    c = foot_contacts(feet, 60.0, height=0.01)
    assert contact_intervals(c) == [[], [(20, 25)], [(5, 30)], []]
    raw = foot_contacts(feet, 60.0, height=0.01, min_frames=1)
    assert contact_intervals(raw) == [[(10, 11)], [(20, 25)], [(5, 17), (18, 30)], []]


def test_a_fast_foot_near_the_ground_is_not_in_contact():
    fps = 60.0
    t = np.arange(60) / fps
    feet = np.zeros((60, 4, 3))
    feet[:, 0, 2] = 3.0 * t                     # skims the ground at 3 m/s
    c = foot_contacts(feet, fps)
    assert not c[:, 0].any() and c[:, 1:].all()


def test_contact_intervals_of_known_pattern():
    c = np.zeros((10, 4), dtype=bool)
    c[2:5, 0] = c[7:10, 0] = True
    c[:, 3] = True
    assert contact_intervals(c) == [[(2, 5), (7, 10)], [], [], [(0, 10)]]
    iv = stance_intervals(c, 10.0)
    np.testing.assert_allclose(iv[0], [[0.2, 0.5], [0.7, np.nan]])
    np.testing.assert_allclose(iv[3], [[np.nan, np.nan]])


# -------------------------------------------------- sliding and penetration
def test_a_foot_sliding_3_mm_in_one_stance_measures_3_mm():
    _, feet, _, _ = synth_gait(**WALK)
    c = foot_contacts(feet, 60.0)
    s, e = contact_intervals(c)[1][4]           # RF's fifth contact
    n = e - s
    feet = feet.copy()
    ramp = np.linspace(0.0, 0.003, n - 10)      # 3 mm sideways and back a little
    feet[s + 5:e - 5, 1, 0] += ramp
    feet[e - 5:e, 1, 0] += 0.0025
    c2 = foot_contacts(feet, 60.0)
    slides, top = foot_slide(feet, c2)
    assert slides[1][4] == pytest.approx(0.003, abs=1e-4)
    assert top == pytest.approx(0.003, abs=1e-4)
    others = np.concatenate([x for i, x in enumerate(slides) if i != 1] + [slides[1][:4]])
    assert np.all(others < 1e-9)


def test_slide_is_the_largest_distance_from_the_touchdown_point():
    feet = np.zeros((20, 4, 3))
    wiggle = 0.002 * np.sin(np.linspace(0, 6 * np.pi, 20))   # back and forth 2 mm
    feet[:, 0, 2] = wiggle
    slides, top = foot_slide(feet, np.ones((20, 4), dtype=bool))
    assert slides[0][0] == pytest.approx(np.abs(wiggle).max())
    assert top == slides[0][0]
    assert [len(x) for x in slides] == [1, 1, 1, 1]


def test_a_foot_4_mm_below_ground_gives_4_mm_penetration():
    _, feet, _, _ = synth_gait(**WALK)
    assert ground_penetration(feet) == 0.0
    feet = feet.copy()
    feet[100:104, 3, 1] = [-0.001, -0.004, -0.002, -0.0005]
    assert ground_penetration(feet) == pytest.approx(0.004)
    depth = penetration_depth(feet)
    assert depth.shape == (600, 4) and depth[101, 3] == pytest.approx(0.004)


def test_root_speed_is_horizontal():
    fps = 60.0
    t = np.arange(300) / fps
    heading = np.deg2rad(30.0)
    root = np.stack([1.5 * t * np.sin(heading), 0.8 + 0.03 * np.sin(2 * np.pi * 2 * t),
                     1.5 * t * np.cos(heading)], axis=-1)
    mean, v = root_speed(root, fps)
    assert mean == pytest.approx(1.5)
    assert v.shape == (299,)
    np.testing.assert_allclose(v, 1.5)


# ---------------------------------------------------------------- smoothness
def _quats(axis, angles):
    return quaternions_from_matrices(matrices_from_axis_angles(axis, angles))


def test_constant_rotation_has_constant_speed_and_no_acceleration():
    rng = np.random.default_rng(7)
    fps = 60.0
    t = np.arange(600) / fps
    axis = rng.normal(size=3)
    q = np.stack([_quats(axis, 2.0 * t), _quats([0, 1, 0], np.zeros_like(t))], axis=1)
    q[::3] *= -1.0                              # the sign of a quaternion is irrelevant
    w = angular_velocity(q, fps)
    a = angular_acceleration(q, fps)
    assert w.shape == (599, 2) and a.shape == (598, 2)
    np.testing.assert_allclose(w[:, 0], 2.0, atol=1e-9)
    np.testing.assert_allclose(w[:, 1], 0.0, atol=1e-12)
    assert np.abs(a).max() < 1e-6


def test_a_reversing_joint_shows_an_acceleration_spike():
    fps = 60.0
    k = np.arange(121)
    angle = np.where(k <= 60, 2.0 * k / fps, 2.0 * (120 - k) / fps)   # up then back
    q = _quats([1, 0, 0], angle)[:, None]
    w = angular_velocity(q, fps)
    np.testing.assert_allclose(w[:, 0], 2.0, atol=1e-9)     # speed never changes...
    a = angular_acceleration(q, fps)[:, 0]
    assert a.max() == pytest.approx(4.0 * fps)              # ...the velocity vector flips
    assert np.argmax(a) == 59 and np.sum(a > 1e-6) == 1


def test_angular_velocity_matches_scipy_for_random_rotations():
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(11)
    q = rng.normal(size=(50, 3, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    r = Rotation.from_quat(q.reshape(-1, 4)[:, [1, 2, 3, 0]]).as_rotvec().reshape(50, 3, 3)
    rel = (Rotation.from_rotvec(r[1:].reshape(-1, 3))
           * Rotation.from_rotvec(r[:-1].reshape(-1, 3)).inv())
    expected = rel.magnitude().reshape(49, 3) * 24.0
    np.testing.assert_allclose(angular_velocity(q, 24.0), expected, atol=1e-9)


def test_angular_velocity_of_a_motion_matches_its_arrays():
    skel = Skeleton(("root", "j"), [-1, 0], [[0, 1, 0], [0, -1, 0]])
    t = np.arange(30) / 30.0
    q = np.stack([_quats([0, 1, 0], 0.5 * t), _quats([0, 0, 1], np.sin(t))], axis=1)
    m = Motion(skel, 30.0, np.zeros((30, 3)), q)
    np.testing.assert_allclose(angular_velocity(m), angular_velocity(q, 30.0))
    np.testing.assert_allclose(angular_acceleration(m), angular_acceleration(q, 30.0))


# ------------------------------------------------------------------ reports
def _two_bone_motion(feet, root, fps, bone=0.5):
    """A Motion whose feet reach ``feet`` exactly: root -> hip -> knee -> foot per leg."""
    names, parents, offsets = ["root"], [-1], [root[0] * 0 + [0, root[0, 1], 0]]
    for i, leg in enumerate(LEGS):
        base = len(names)
        names += [f"{leg}_hip", f"{leg}_knee", f"{leg}_foot"]
        parents += [0, base, base + 1]
        offsets += [HIPS[i], [0, -bone, 0], [0, -bone, 0]]
    skel = Skeleton(tuple(names), parents, offsets)
    hip = root[:, None, :] + HIPS
    d = feet - hip
    dist = np.linalg.norm(d, axis=-1)
    phi = np.arctan2(-d[..., 2], -d[..., 1])
    gamma = np.arccos(dist / (2 * bone))
    angles = np.zeros((len(root), skel.n_joints))
    angles[:, 1::3] = phi + gamma
    angles[:, 2::3] = -2 * gamma
    m = Motion.from_matrices(skel, fps, root, matrices_about_axis(0, angles),
                             foot_joints=tuple(f"{leg}_foot" for leg in LEGS))
    return m


def test_motion_report_measures_a_hand_made_walk():
    fps = 60.0
    _, feet, root, _ = synth_gait(**WALK, speed=1.0, fps=fps, seconds=8.0)
    m = _two_bone_motion(feet, root, fps)
    np.testing.assert_allclose(m.foot_positions(), feet, atol=1e-9)
    rep = motion_report(m)
    json.dumps(rep)                                          # plain values only
    assert rep["frames"] == 480 and rep["fps"] == 60.0
    assert rep["duration"] == pytest.approx(479 / 60)
    for i, leg in enumerate(LEGS):
        r = rep["legs"][leg]
        assert r["duty_factor"] == pytest.approx(0.6, abs=0.02)
        assert circular_diff(r["phase"], WALK["phase"][i]) < 0.02
        assert r["strides"] in (6, 7)
        assert r["contact_time"] == pytest.approx(0.6, abs=0.02)
        assert r["max_slide_mm"] < 1e-6 and r["mean_slide_mm"] < 1e-6
        assert r["max_penetration_mm"] < 1e-6
    assert rep["stride_frequency"] == pytest.approx(1.0, abs=0.005)
    assert rep["stride_length"] == pytest.approx(1.0, abs=0.01)
    assert rep["mean_speed"] == pytest.approx(1.0)
    assert rep["max_penetration_mm"] < 1e-6
    assert 0 < rep["max_angular_velocity"] < 20
    assert rep["max_angular_velocity_joint"].endswith(("_hip", "_knee"))
    assert rep["max_angular_acceleration"] > 0
    same = report_from_positions(feet, root, fps, rotations=m.rotations,
                                 joint_names=m.skeleton.names)
    for leg in LEGS:                          # motion_report is report_from_positions
        assert same["legs"][leg] == pytest.approx(rep["legs"][leg], abs=1e-9)
    assert same["max_angular_velocity"] == pytest.approx(rep["max_angular_velocity"])


def test_report_start_skips_the_settling_seconds():
    _, feet, root, _ = synth_gait(**WALK)
    feet = feet.copy()
    feet[:60, 0, 1] -= 0.05                     # LF sinks 5 cm during the first second
    full = report_from_positions(feet, root, 60.0)
    late = report_from_positions(feet, root, 60.0, start=1.0)
    assert full["max_penetration_mm"] == pytest.approx(50.0)
    assert late["max_penetration_mm"] == 0.0
    assert late["frames"] == 540 and late["start"] == 1.0
    assert late["legs"]["LF"]["duty_factor"] == pytest.approx(0.6, abs=0.02)
    assert full["max_angular_velocity"] is None


def test_format_report_has_a_row_per_foot_and_the_totals():
    _, feet, root, _ = synth_gait(**WALK)
    text = format_report(report_from_positions(feet, root, 60.0))
    rows = [line for line in text.splitlines() if line[:3].strip() in LEGS]
    assert [r.split()[0] for r in rows] == list(LEGS)
    assert rows[0].split()[1] == "0.600"
    for word in ("stride frequency", "Hz", "m/s", "mm", "rad/s"):
        assert word in text


# ---------------------------------------------------------------- bad input
def test_bad_input_is_rejected_with_a_named_argument():
    skel = Skeleton(("root",), [-1], [[0, 1, 0]])
    m = Motion(skel, 30.0, np.zeros((10, 3)), np.tile([1.0, 0, 0, 0], (10, 1, 1)))
    with pytest.raises(ValueError, match="foot joints"):
        motion_report(m)
    with pytest.raises(ValueError, match=r"`feet` has shape \(10, 3\)"):
        foot_contacts(np.zeros((10, 3)), 30.0)
    with pytest.raises(ValueError, match="`fps` must be a positive"):
        foot_contacts(np.zeros((10, 4, 3)), 0.0)
    with pytest.raises(ValueError, match=r"`contacts` has shape \(10, 3\)"):
        duty_factors(np.zeros((10, 3), dtype=bool), 30.0)
    with pytest.raises(ValueError, match="`min_frames`"):
        foot_contacts(np.zeros((10, 4, 3)), 30.0, min_frames=0)
    with pytest.raises(ValueError, match="`fps` is required"):
        angular_velocity(np.zeros((5, 2, 4)))
    with pytest.raises(ValueError, match="at least 3 frames after `start`"):
        report_from_positions(np.zeros((10, 4, 3)), np.zeros((10, 3)), 30.0, start=1.0)
    with pytest.raises(ValueError, match="`root_positions` has shape"):
        report_from_positions(np.zeros((10, 4, 3)), np.zeros((9, 3)), 30.0)
