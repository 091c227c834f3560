"""`quadsim clips-from`: a clip database cut out of long takes, checked against the truth.

The takes are the dog cub's own procedural motion (:mod:`take_builders`):
two long takes, each walking, trotting, cantering and galloping (rotary) at a
speed of its own, changing gait every 4 s; the second set has per-frame
joint-angle jitter (0.2 deg rms every joint) and root jitter (1 mm), and is
written on another skeleton (10 % bigger, extra jaw, ear, helper and dew-claw
joints) in centimetres. A Z-up centimetre Blender-named rig adopted with
`quadsim rig` cuts its own database from takes in its own hierarchy. The
truth is the procedural controller's planned contacts.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from quadsim.cli import main
from quadsim.errors import InputError
from quadsim.horse.speed import clip_contact_time
from quadsim.io.clips import load_database
from quadsim.io.takes import Stride, cut_database, fit_law, label_gait, read_take, steady_runs
from quadsim.skeleton.character import load_character
from take_builders import noisy, on_other_skeleton, take, write_take

PLANS = ([("walk", 0.5), ("trot", 1.4), ("canter", 2.4), ("rotary_gallop", 3.6)],
         [("walk", 0.8), ("trot", 2.0), ("canter", 3.0), ("rotary_gallop", 4.6)])


@pytest.fixture(scope="module")
def dog():
    return load_character("dog_cub")


@pytest.fixture(scope="module")
def truth(dog):
    return [take(dog, plan) for plan in PLANS]


def _cut(tmp, dog, motions, name, units="m"):
    paths = []
    for k, m in enumerate(motions):
        paths.append(str(write_take(m, tmp / f"{name}{k}.bvh", units=units)))
    out = tmp / f"{name}_clips"
    assert main(["clips-from", *paths, "--character", "dog_cub", "--out", str(out)]) == 0
    return load_database(out, dog), paths


@pytest.fixture(scope="module")
def clean(tmp_path_factory, dog, truth):
    return _cut(tmp_path_factory.mktemp("clean"), dog, truth, "take")


@pytest.fixture(scope="module")
def rough(tmp_path_factory, dog, truth):
    motions = [on_other_skeleton(noisy(m, deg=0.2, root=0.001, seed=k), scale=1.1)
               for k, m in enumerate(truth)]
    return _cut(tmp_path_factory.mktemp("rough"), dog, motions, "noisy", units="cm")


def _onsets(contacts: np.ndarray) -> list[np.ndarray]:
    c = np.asarray(contacts, dtype=bool)
    return [np.nonzero(c[1:, i] & ~c[:-1, i])[0] + 1 for i in range(4)]


def _take_of(clip, paths) -> int:
    return next(k for k, p in enumerate(paths) if clip.source.startswith(p.split("/")[-1]))


def _start(clip) -> float:
    return float(clip.source.split(" at ")[1].split(" s ")[0])


@pytest.mark.parametrize("which", ["clean", "rough"])
def test_every_steady_gait_of_the_takes_is_found_with_its_label(which, request):
    db, _ = request.getfixturevalue(which)
    found = sorted((c.gait, c.speed) for c in db.clips.values())
    want = sorted((g, v) for plan in PLANS for g, v in plan)
    assert [g for g, _ in found] == [g for g, _ in want], found
    for (g, v), (g2, v2) in zip(want, found):
        assert abs(v2 / v - 1) < 0.04, (g, v, v2)   # the cut's speed, as measured
    for c in db.clips.values():
        if c.gait in ("canter", "rotary_gallop"):
            assert c.lead == "left"          # the procedural gaits lead with the left fore


@pytest.mark.parametrize("which", ["clean", "rough"])
def test_touchdowns_and_cycle_lengths_match_the_planned_contacts(which, request, truth):
    db, paths = request.getfixturevalue(which)
    worst_td, worst_len = 0, 0.0
    for c in db.clips.values():
        m = truth[_take_of(c, paths)]
        fps = m.fps
        f0 = round(_start(c) * fps)  # a cut starts on a frame; its source gives ms
        on = _onsets(m.contacts)
        lh = on[2][on[2] >= f0 - 2][:2]                  # the cycle's own stride
        period = float(lh[1] - lh[0])
        worst_len = max(worst_len, abs(c.frames - period))
        for i in range(4):
            k = on[i][on[i] >= f0 - 3][0]
            d = (c.touchdown[i] - (k - f0)) % c.frames
            worst_td = max(worst_td, min(d, c.frames - d))
    assert worst_td <= 2, f"a touchdown {worst_td:.1f} frames off the planned one"
    assert worst_len <= 1.5, f"a cycle {worst_len:.1f} frames off the stride period"


def test_the_fitted_laws_give_the_clips_contact_times(clean, dog):
    db, _ = clean
    assert set(db.laws) == {"walk", "trot", "canter", "rotary_gallop"}
    for c in db.clips.values():
        law = db.laws[c.gait]
        assert law.b < 0 and law.anchor == "law"
        tc = clip_contact_time(c)
        # within 12 %, or within the frame in which a contact is measured (a canter's
        # 0.12 s stance is 7 frames at 60 fps: one frame is 14 % of it)
        miss = abs(float(law.contact_time(c.speed)) - tc)
        assert miss < max(0.12 * tc, 1.0 / c.motion.fps), (c.name, law, tc)


def test_a_stride_off_the_runs_speed_by_more_than_5_percent_ends_the_run():
    """Four canter strides of one period, the last 8 % faster (the stride into a
    gallop's speed-up, its period still the canter's): the run is the first three; at
    4 % faster the fourth stays in it."""
    def strides(last_speed):
        phase, duty = np.array([0.4, 0.7, 0.0, 0.8]), np.full(4, 0.35)
        return [Stride("t", 0.3 * k, 0.3 * (k + 1), v, phase, duty, 0.1, "canter", "left", 0.0)
                for k, v in enumerate([3.0, 3.0, 3.0, last_speed])]

    assert [len(r) for r in steady_runs(strides(3.24))] == [3]
    assert [len(r) for r in steady_runs(strides(3.12))] == [4]


def test_fit_law_recovers_a_power_law_and_falls_back_over_one_speed():
    v = np.array([1.0, 1.5, 2.0, 3.0])
    law, rms = fit_law(np.stack([v, 0.4 * v ** -0.8], axis=1))
    assert law.a == pytest.approx(0.4) and law.b == pytest.approx(-0.8) and rms < 1e-9
    one, _ = fit_law(np.array([[2.0, 0.2], [2.05, 0.2]]))
    assert one.b == pytest.approx(-0.7) and one.contact_time(2.0) == pytest.approx(0.2, rel=0.02)


def test_labels_come_from_the_gait_tables_right_leads_mirrored(dog):
    assert label_gait(np.array([0.25, 0.75, 0.0, 0.5]), np.full(4, 0.68), dog)[:2] == ("walk", None)
    assert label_gait(np.array([0.5, 0.0, 0.0, 0.5]), np.full(4, 0.4), dog)[:2] == ("trot", None)
    assert label_gait(np.array([0.0, 0.5, 0.0, 0.5]), np.full(4, 0.4), dog)[:2] == ("pace", None)
    # canter with the right fore leading: RF, LF, RH, LH of the left-lead table, from LH
    ph = np.array([0.2, 0.0, 0.0, 0.8])[[1, 0, 3, 2]]
    assert label_gait((ph - ph[2]) % 1.0, np.full(4, 0.35), dog)[:2] == ("canter", "right")
    assert label_gait(np.array([0.1, 0.9, 0.0, 0.3]), np.full(4, 0.5), dog)[0] is None


def test_the_manifest_names_its_takes_and_laws(clean):
    db, paths = clean
    data = tomllib.loads((db.folder / "manifest.toml").read_text(encoding="utf-8"))
    assert set(data["laws"]) == set(db.laws)
    assert all("fitted to" in t["source"] for t in data["laws"].values())
    assert all(any(p.split("/")[-1] in c["source"] for p in paths) for c in data["clips"].values())


def test_an_adopted_rig_cuts_its_own_database_from_takes_in_its_own_hierarchy(tmp_path):
    from quadsim.io.adopt import write_for_character
    from rig_builders import quadruped, write_bvh_rig

    spec = quadruped("wolf", style="blender", hip=0.6, hind_bones=3, root=False)
    model = write_bvh_rig(spec, tmp_path / "wolf.bvh", up="Z", unit="cm")
    char = tmp_path / "wolf.toml"
    assert main(["rig", str(model), "--out", str(char)]) == 0
    wolf = load_character(char)
    plans = [[("walk", 1.0), ("trot", 2.4), ("canter", 3.6)],
             [("walk", 1.4), ("trot", 3.2), ("canter", 4.4)]]
    paths = []
    for k, plan in enumerate(plans):
        m = take(wolf, plan)
        paths.append(str(write_for_character(wolf, m, tmp_path / f"take{k}.bvh")))
        back = read_take(paths[-1], wolf)              # Z-up centimetres, 55 joints
        assert np.abs(back.foot_positions() - m.foot_positions()).max() < 1e-5
    out = tmp_path / "clips"
    assert main(["clips-from", *paths, "--character", str(char), "--out", str(out)]) == 0
    db = load_database(out, wolf)
    found = sorted((c.gait, c.speed) for c in db.clips.values())
    want = sorted((g, v) for plan in plans for g, v in plan)
    assert [g for g, _ in found] == [g for g, _ in want]
    assert all(abs(v2 / v - 1) < 0.04 for (_, v), (_, v2) in zip(want, found)), found


# ------------------------------------------------------------------ bad input
def _expect_exit_2(capsys, argv, *words):
    assert main(argv) == 2
    err = capsys.readouterr().err
    for w in words:
        assert w in err, err
    return err


def test_a_take_missing_leg_joints_names_the_file_and_the_joints(tmp_path, capsys, truth):
    m = truth[0][:300]
    sk = m.skeleton
    from quadsim.skeleton.motion import Motion
    from quadsim.skeleton.skeleton import Skeleton

    names = tuple(n.replace("LH_", "hindL_") for n in sk.names)
    other = Motion(Skeleton(names, sk.parents, sk.offsets), m.fps, m.root_positions,
                   m.rotations, foot_joints=None)
    p = write_take(other, tmp_path / "renamed.bvh")
    _expect_exit_2(capsys, ["clips-from", str(p), "--character", "dog_cub", "--out",
                            str(tmp_path / "o")], "renamed.bvh", "LH_", "rename",
                   "quadsim rig")
    assert not (tmp_path / "o").exists()


def test_a_take_too_short_for_a_stride_is_refused(tmp_path, capsys, truth):
    p = write_take(truth[0][:20], tmp_path / "short.bvh")
    _expect_exit_2(capsys, ["clips-from", str(p), "--character", "dog_cub", "--out",
                            str(tmp_path / "o")], "short.bvh", "no whole stride", "longer take")


def test_a_take_with_no_steady_gait_is_refused(tmp_path, capsys, dog):
    # the speed changes every half second: strides, but never three alike
    plan = [("trot", (1.2, 2.4)[k % 2]) for k in range(10)]
    p = write_take(take(dog, plan, segment=0.5), tmp_path / "wobbly.bvh")
    _expect_exit_2(capsys, ["clips-from", str(p), "--character", "dog_cub", "--out",
                            str(tmp_path / "o")], "wobbly.bvh", "no steady gait", "steady")


def test_the_out_folder_must_be_new_empty_or_a_clip_database(tmp_path, capsys, clean):
    _, paths = clean
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "notes.txt").write_text("mine")
    _expect_exit_2(capsys, ["clips-from", paths[0], "--character", "dog_cub", "--out",
                            str(busy)], "busy", "manifest.toml")
    assert (busy / "notes.txt").read_text() == "mine"
    _expect_exit_2(capsys, ["clips-from", paths[0], "--character", "dog_cub", "--out",
                            str(tmp_path / "o"), "--smooth", "-1"], "--smooth")


def test_a_clip_database_in_the_out_folder_is_replaced_whole(tmp_path, clean):
    db, paths = clean
    out = tmp_path / "db"
    assert main(["clips-from", paths[0], "--character", "dog_cub", "--out", str(out)]) == 0
    first = sorted(p.name for p in out.iterdir())
    assert main(["clips-from", paths[1], "--character", "dog_cub", "--out", str(out)]) == 0
    second = sorted(p.name for p in out.iterdir())
    assert first != second and "manifest.toml" in second
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]   # no leftovers
    data = tomllib.loads((out / "manifest.toml").read_text(encoding="utf-8"))
    assert sorted(f"{c['file']}" for c in data["clips"].values()) == \
        sorted(n for n in second if n.endswith(".bvh"))


def test_a_take_turned_away_from_z_is_cut_facing_z(tmp_path, truth, dog):
    from quadsim.kinematics.rotations import matrices_about_axis, quaternion_multiply
    from quadsim.kinematics.rotations import quaternions_from_matrices
    from quadsim.skeleton.motion import Motion

    m = truth[1]
    R = matrices_about_axis(1, np.array(math.radians(70.0)))
    q = quaternions_from_matrices(R)
    rot = np.array(m.rotations)
    rot[:, 0] = quaternion_multiply(np.broadcast_to(q, rot[:, 0].shape), rot[:, 0])
    turned = Motion(m.skeleton, m.fps, m.root_positions @ R.T, rot, foot_joints=m.foot_joints)
    cut = cut_database([("turned", turned)], dog)
    assert len(cut.clips) == 4
    for c in cut.clips:
        travel = c.motion.root_positions[-1] - c.motion.root_positions[0]
        assert abs(travel[0]) < 0.02 * abs(travel[2]) and travel[2] > 0, (c.name, travel)


def test_takes_at_other_frame_rates_join_the_first_takes(dog):
    slow = take(dog, [("walk", 0.6), ("trot", 1.6)], fps=30.0)
    fast = take(dog, [("canter", 2.6)], fps=120.0)
    cut = cut_database([("slow", slow), ("fast", fast)], dog)
    assert {c.motion.fps for c in cut.clips} == {30.0}
    assert [c.gait for c in cut.clips] == ["walk", "trot", "canter"]
    canter = cut.clips[-1]
    assert abs(canter.frames - 30.0 * 0.33) <= 1.5          # the 120 fps stride, at 30 fps


def test_cut_database_with_no_takes_says_so(dog):
    with pytest.raises(InputError, match="no steady gait"):
        cut_database([], dog)


def test_a_character_whose_paws_roll_is_warned_of(tmp_path, capsys):
    """The leopard's paws roll over their toes at push-off, and clips-from finds contacts at
    the foot joints, which rise through the roll: its own takes read short stances (cut
    from a walk, trot and canter take, only the trot and canter were found). The command
    says so on one warning line naming the key."""
    leopard = load_character("leopard")
    path = tmp_path / "leopard.bvh"
    write_take(take(leopard, [("walk", 1.0), ("trot", 3.0), ("canter", 5.0)]), path)
    assert main(["clips-from", str(path), "--character", "leopard",
                 "--out", str(tmp_path / "clips")]) == 0
    err = capsys.readouterr().err
    warned = [line for line in err.splitlines() if line.startswith("quadsim: warning:")]
    assert len(warned) == 1 and "toe_roll_deg = 50" in warned[0], err
