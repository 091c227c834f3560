"""Clip sets for game engines (`quadsim clips`): what the set holds and how its clips join.

Every figure is measured on the clips' joint world positions (the root among them)
or with :mod:`quadsim.analysis`, as ``quadsim metrics`` measures a run -- not read
from the sidecar the code under test wrote, except where the test is about the
sidecar. The dog cub's and the horse's sets are made once per module (about two
seconds each once the kernels are compiled).
"""

from __future__ import annotations

import json
import re
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from quadsim.analysis import metrics as M
from quadsim.analysis.appearance import appearance_report
from quadsim.clipset import make_clip_set, plan_clip_set, write_clip_set
from quadsim.clipset.clips import tiled
from quadsim.clipset.measure import loop_transform
from quadsim.clipset.rows import pose_rows
from quadsim.cli import main
from quadsim.frames import LEGS
from quadsim.locomotion.gaits import auto_gaits, gait_table
from quadsim.skeleton.character import load_character

FPS = 60.0
SLIDE_LIMIT_MM = 5.0
PENETRATION_LIMIT_MM = 5.0
#: Steady gaits whose stances the procedural engine measures a frame short (a swing
#: foot out of reach drops onto the ground: test_locomotion_quality's known defects,
#: xfail there): their footfall table is not held to the gait table's here either.
SHORT_STANCES = {("dog_cub", "rotary_gallop")}
NAME = re.compile(r"^(?P<gait>[a-z_]+?)_(?:(?P<speed>\d+\.\d)(?P<ip>_inplace)?"
                  r"|turn_(?P<side>left|right)_(?P<rate>\d+)(?P<tip>_inplace)?"
                  r"|to_(?P<to>[a-z_]+))$|^(?P<ss>start|stop)_(?P<sg>[a-z_]+)$")


@cache
def clip_set(character: str):
    ch = load_character(character)
    plan = plan_clip_set(ch, fps=FPS)
    return ch, plan, make_clip_set(ch, plan)


def clips_of(character, kind=None, loop=None):
    _, _, made = clip_set(character)
    return [c for c, _ in made if (kind is None or c.kind == kind)
            and (loop is None or c.loop == loop)]


CHARACTERS = ("dog_cub", "horse")


# ------------------------------------------------------------------ contents
@pytest.mark.parametrize("character", CHARACTERS)
def test_every_gait_has_two_speeds_both_ways_turns_starts_stops_and_transitions(character):
    ch, plan, made = clip_set(character)
    names = [c.name for c, _ in made]
    assert names == plan.names() and len(set(names)) == len(names)
    for name in names:
        assert NAME.match(name), name
    for gait in gait_table(ch):
        speeds = {n for n in names if re.fullmatch(rf"{gait}_\d+\.\d", n)}
        assert len(speeds) >= 2, (gait, speeds)
        assert {f"{n}_inplace" for n in speeds} <= set(names)
        for side in ("left", "right"):
            assert any(re.fullmatch(rf"{gait}_turn_{side}_\d+", n) for n in names), (gait, side)
    for gait in ("walk", "trot"):
        assert {f"start_{gait}", f"stop_{gait}"} <= set(names)
    auto = auto_gaits(ch)
    for a, b in zip(auto[:-1], auto[1:]):
        assert {f"{a}_to_{b}", f"{b}_to_{a}"} <= set(names)


def test_clip_names_carry_the_speed_with_one_decimal_and_the_turn_in_deg_s():
    for clip in clips_of("dog_cub", loop=True):
        m = NAME.match(clip.name)
        if clip.kind == "cycle":
            assert float(m["speed"]) == pytest.approx(clip.info["speed"])
        else:
            sign = 1 if m["side"] == "left" else -1
            assert sign * int(m["rate"]) == pytest.approx(clip.info["turn_rate_deg_s"])
            # and the loop turns that way: its heading changes by rate x duration
            turned = np.degrees(clip.rows[-1, 3] - clip.rows[0, 3]) if clip.root_motion else 0
            if clip.root_motion:
                duration = (clip.frames - 1) / FPS * clip.info["time_scale"]
                assert turned == pytest.approx(sign * int(m["rate"]) * duration, rel=0.02)


# ------------------------------------------------------------------- seams
def _steps(P):
    return np.linalg.norm(np.diff(P, axis=0), axis=-1).max(axis=-1)


@pytest.mark.parametrize("character", CHARACTERS)
def test_every_loop_closes_without_a_seam(character):
    """A loop's last frame is its first carried on by the loop's travel (a turn about +Y
    and a shift): an engine wrapping from the last frame it plays to the first sees one
    ordinary step. The seam -- how far that last frame is from where the simulation went
    -- is no larger than the loop's largest frame-to-frame step (far smaller: under
    0.1 mm), measured on every joint's world position."""
    for clip in clips_of(character, loop=True):
        P = clip.motion.world_positions()
        carried = loop_transform(clip.rows)(P[0])
        assert np.abs(carried - P[-1]).max() < 1e-9, clip.name
        largest = _steps(P[:-1]).max()
        assert clip.info["seam_m"] <= largest, clip.name
        assert clip.info["seam_m"] < 1e-4, (clip.name, clip.info["seam_m"])
        # whole strides in whole frames: simulated time over labelled time within 0.5 %
        assert abs(clip.info["time_scale"] - 1.0) <= 0.005, clip.name


def _steady_acceleration(character, clip) -> float:
    """The largest frame-to-frame velocity change (m per frame, over the joints) of the
    loop's gait and command run on without a cut, at the loop's own step."""
    import math

    from quadsim import Command, simulate

    info = clip.info
    cmd = Command(speed=info["speed"], gait=info["gait"],
                  turn_rate=math.radians(info["turn_rate_deg_s"]))
    m = simulate(load_character(character), cmd, seconds=10.0,
                 fps=1.0 / info["simulated_step_s"]).time_slice(5.0, 10.0)
    Q = m.world_positions()
    return float(np.linalg.norm(Q[2:] - 2 * Q[1:-1] + Q[:-2], axis=-1).max())


def test_a_loop_played_twice_moves_as_smoothly_across_the_wrap_as_inside():
    """Velocity is continuous too: played twice, the dog cub's loops change velocity
    across the wrap by no more than 1.1 times the largest change inside them or in the
    same gait run on without a cut (a loop of three strides samples its left hind
    touchdown at a third of a frame's offsets: the motion's own largest change can fall
    on the touchdown the loop starts at)."""
    for clip in clips_of("dog_cub", loop=True):
        P = pose_rows(load_character("dog_cub"), tiled(clip, 2), FPS).world_positions()
        N = clip.frames - 1
        acc = np.linalg.norm(P[2:] - 2 * P[1:-1] + P[:-2], axis=-1).max(axis=-1)
        inside = np.delete(acc, N - 1)
        if acc[N - 1] > 1.1 * inside.max():
            assert acc[N - 1] <= 1.1 * _steady_acceleration("dog_cub", clip), clip.name
        steps = _steps(P)
        assert steps[N - 1] <= 1.1 * np.delete(steps, N - 1).max(), clip.name


@pytest.mark.parametrize("character", CHARACTERS)
def test_every_clip_in_a_gait_starts_at_a_left_hind_touchdown(character):
    """Clips line up: each loop, stop and transition starts (and each start and
    transition ends) with the left hind oscillator at a whole stride, and a loop holds
    a whole number of strides."""
    for c, _ in clip_set(character)[2]:
        lh = c.motion.extras["phase"][:, LEGS.index("LH")]
        on = lambda u: min(u, 1.0 - u) < 1e-6  # noqa: E731
        if c.kind != "start":
            assert on(lh[0]), (c.name, lh[0])
        if c.loop or c.kind in ("start", "transition"):
            assert on(lh[-1]), (c.name, lh[-1])
        if c.loop:
            turns = np.sum(np.mod(np.diff(lh), 1.0))       # the phase, unwrapped
            assert turns == pytest.approx(c.info["strides"], abs=1e-6), c.name


def test_starts_and_transitions_end_on_the_loop_they_join_and_stops_leave_from_it():
    ch, _, made = clip_set("dog_cub")
    by_name = {c.name: c for c, _ in made}
    from quadsim.clipset.rows import in_place

    def apart(a, b):          # two plans seen from their own roots (m or rad)
        ab = in_place(np.stack([a, b]))
        return np.abs(ab[0] - ab[1]).max()

    for c, _ in made:
        if c.kind in ("start", "transition"):
            assert apart(c.rows[-1], by_name[c.info["joins"]].rows[0]) < 0.01, c.name
        if c.kind in ("stop", "transition"):
            assert apart(c.rows[0], by_name[c.info["from"]].rows[0]) < 1e-4, c.name
        if c.kind == "stop":
            assert c.info["still"] and c.motion.gaits[-1] == "stand", c.name


# ---------------------------------------------------------------- in place
@pytest.mark.parametrize("character", CHARACTERS)
def test_in_place_twins_keep_the_root_within_a_centimetre_and_the_pose(character):
    ch, _, made = clip_set(character)
    by_name = {c.name: c for c, _ in made}
    for c in clips_of(character, loop=True):
        if c.root_motion:
            continue
        root = c.motion.root_positions[:, [0, 2]]
        assert np.linalg.norm(root - root[0], axis=-1).max() < 0.01, c.name
        twin = by_name[c.name.removesuffix("_inplace")]
        # the same pose seen from the root: the twin's joints minus its root, unturned
        P, Q = c.motion.world_positions(), twin.motion.world_positions()
        a = -twin.rows[:, 3]
        rel = Q - twin.motion.root_positions[:, None]
        x = np.cos(a)[:, None] * rel[..., 0] + np.sin(a)[:, None] * rel[..., 2]
        z = -np.sin(a)[:, None] * rel[..., 0] + np.cos(a)[:, None] * rel[..., 2]
        mine = P - c.motion.root_positions[:, None]
        assert np.abs(mine - np.stack([x, rel[..., 1], z], -1)).max() < 1e-6, c.name
        ends = twin.motion.root_positions[[0, -1]][:, [0, 2]]
        travel = np.linalg.norm(ends[1] - ends[0])
        assert travel > 0.2, twin.name      # the twin does travel


# --------------------------------------------------------------- footfalls
def _feet(ch, motion):
    """Where a motion's feet touch the ground: the toe tips of feet that roll over them
    (``toe_roll_deg``: the heel leaves the ground while the toe stays planted), else the
    foot joints (a flat foot's joint is on the ground through its stance)."""
    rolls = float(ch.locomotion.get("toe_roll_deg", 0.0)) > 0.0
    return motion.contact_points() if rolls else motion.foot_positions()


def _measured(ch, clip, copies=4):
    m = pose_rows(ch, tiled(clip, copies), FPS)
    feet = _feet(ch, m)
    contacts = M.foot_contacts(feet, FPS)
    return m, feet, contacts


@pytest.mark.parametrize("character", CHARACTERS)
def test_loops_meet_the_footfall_and_slide_checks_of_run(character):
    """Played four times, each straight loop realises its gait's footfall table (duty
    factor and phases within 0.05, test_locomotion_quality's limits), every loop keeps
    planted feet within 5 mm and above the ground within 5 mm (their toe tips sliding
    5 mm in 90 % of stances and 3 mm below the ground at most, turning too),
    and the root moves at
    the speed its sidecar gives (within 1 %) and the name says (within 2 %)."""
    ch, _, made = clip_set(character)
    table = gait_table(ch)
    for c, fig in made:
        if not (c.loop and c.root_motion):
            continue
        m, feet, contacts = _measured(ch, c)
        slide = M.foot_slide(feet, contacts)[1] * 1000
        assert slide < SLIDE_LIMIT_MM, (c.name, slide)
        assert M.ground_penetration(feet) * 1000 < PENETRATION_LIMIT_MM, c.name
        # what a viewer sees of a planted foot, its toe tip, as run's toe test checks it
        toes = appearance_report(m)
        assert toes["toe_below_ground_mm"] <= 3.0, (c.name, toes["toe_below_ground_mm"])
        assert toes["toe_slide_mm_p90"] <= SLIDE_LIMIT_MM, (c.name, toes["toe_slide_mm_p90"])
        if c.kind != "cycle":
            continue
        g = table[c.info["gait"]]
        v = c.info["speed"]
        if (character, g.name) not in SHORT_STANCES:
            phase = M.phases(contacts, FPS, feet)
            assert np.all(np.abs(np.mod(phase - g.phases + 0.5, 1.0) - 0.5) < 0.05), \
                (c.name, phase)
            duty = M.duty_factors(contacts, FPS, feet)
            assert np.all(np.abs(duty - g.duty(v)) < 0.05), (c.name, duty, g.duty(v))
        speed, _ = M.root_speed(m.root_positions, FPS)
        assert speed == pytest.approx(fig["mean_speed_mps"], rel=0.01)
        assert speed == pytest.approx(v, rel=0.02), c.name


@pytest.mark.parametrize("character", CHARACTERS)
def test_starts_stops_and_transitions_keep_planted_feet_still(character):
    ch, _, made = clip_set(character)
    for c, _ in made:
        if c.loop:
            continue
        feet = _feet(ch, c.motion)
        contacts = M.foot_contacts(feet, FPS)
        assert M.foot_slide(feet, contacts)[1] * 1000 < SLIDE_LIMIT_MM, c.name
        assert M.ground_penetration(feet) * 1000 < PENETRATION_LIMIT_MM, c.name


# ------------------------------------------------------------------ files
@pytest.fixture(scope="module")
def cub_files(tmp_path_factory):
    ch, plan, made = clip_set("dog_cub")
    return write_clip_set(ch, plan, made, tmp_path_factory.mktemp("set") / "cub.glb")


def test_the_sidecar_says_what_each_animation_is(cub_files):
    import pygltflib

    glb, side = cub_files
    assert side.name == "cub.json"
    data = json.loads(side.read_text())
    anims = pygltflib.GLTF2().load(str(glb)).animations
    assert [a.name for a in anims] == [c["name"] for c in data["clips"]]
    assert data["character"] == "dog_cub" and data["fps"] == FPS
    for c, anim in zip(data["clips"], anims):
        assert c["frame_range"] == [0, c["frames"] - 1] and anim.extras["frames"] == c["frames"]
        for key in ("gait", "speed_mps", "loop", "root_motion", "kind"):
            assert key in c, key
        if c["loop"]:
            assert set(c["duty_factors"]) == set(LEGS) and c["phases"]["LH"] == 0.0
            assert c["stride_length_m"] > 0 and c["stride_frequency_hz"] > 0
            assert c["native_speed_mps"] == pytest.approx(c["speed_mps"], rel=0.02)
            assert c["seam_m"] <= c["max_step_m"]
            if not c["root_motion"]:
                assert c["root_travel_m"] < 0.01


def test_the_clip_set_passes_the_khronos_validator(cub_files, tmp_path):
    from gltf_tools import validate

    ch, plan, made = clip_set("horse")
    horse, _ = write_clip_set(ch, plan, made, tmp_path / "horse.glb")
    for report in validate(cub_files[0], horse):
        issues = report["issues"]
        assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), issues["messages"][:5]
        assert report["info"]["animationCount"] == len(json.loads(
            (cub_files[1] if report["uri"] == "cub.glb" else tmp_path / "horse.json")
            .read_text())["clips"])


# -------------------------------------------------------------------- CLI
def test_the_command_writes_the_set_and_its_sidecar(tmp_path, capsys):
    out = tmp_path / "sets" / "cub.glb"
    assert main(["clips", "dog_cub", "--gaits", "walk,trot", "--speeds", "walk=0.5,0.9",
                 "--turn-rates", "30", "--fps", "30", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "wrote" in printed and "sidecar" in printed
    data = json.loads(out.with_suffix(".json").read_text())
    names = [c["name"] for c in data["clips"]]
    assert {"walk_0.5", "walk_0.9_inplace", "walk_turn_left_30", "trot_turn_right_30_inplace",
            "start_walk", "stop_trot", "walk_to_trot", "trot_to_walk"} <= set(names)
    assert data["fps"] == 30.0


@pytest.mark.parametrize("argv, words", [
    (["--out", "x.bvh"], [".glb or .fbx"]),
    (["--out", "x.glb", "--speeds", "walk=9"], ["walk", "held at"]),
    (["--out", "x.glb", "--speeds", "walk"], ["GAIT=SPEED"]),
    (["--out", "x.glb", "--gaits", "amble"], ["amble"]),
    (["--out", "x.glb", "--gaits", "walk", "--speeds", "trot=2"], ["trot", "--gaits"]),
    (["--out", "x.glb", "--turn-rates", "fast"], ["--turn-rates"]),
])
def test_bad_flags_are_one_line_errors(argv, words, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["clips", "dog_cub", *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("quadsim: error:") and all(w in err for w in words), err
    assert not list(tmp_path.iterdir())


def test_fbx_without_blender_says_how_to_get_it(tmp_path, capsys):
    try:
        import bpy  # noqa: F401
    except ImportError:
        assert main(["clips", "dog_cub", "--out", str(tmp_path / "x.fbx")]) == 2
        err = capsys.readouterr().err
        assert "bpy" in err and "quadsim[blender]" in err
    else:
        pytest.skip("Blender's bpy is installed here (tests/test_clipset_blender.py)")


# ------------------------------------------------------------ your own rig
FOX = Path(__file__).resolve().parents[2] / "shared" / "assets" / "fox" / "Fox.gltf"


@pytest.mark.skipif(not FOX.is_file(), reason="the Fox test rig is not on this machine "
                    "(../shared/assets/fox/Fox.gltf)")
def test_an_adopted_rig_gets_its_own_model_back_with_the_clips_added(tmp_path):
    """`quadsim rig` then `quadsim clips`: the Fox's own file with its own Survey, Walk
    and Run and every clip after them, valid for the Khronos validator (no error, and
    warnings only of kinds the Fox's own file has)."""
    import pygltflib
    from gltf_tools import validate

    fox = tmp_path / "fox.toml"
    assert main(["rig", str(FOX), "--out", str(fox)]) == 0
    out = tmp_path / "fox_clips.glb"
    assert main(["clips", str(fox), "--gaits", "walk,trot", "--out", str(out)]) == 0
    clips = json.loads(out.with_suffix(".json").read_text())["clips"]
    g = pygltflib.GLTF2().load(str(out))
    assert [a.name for a in g.animations] == ["Survey", "Walk", "Run"] + [c["name"] for c in clips]
    assert len(g.meshes) == 1 and g.images        # the Fox's textured mesh
    source, ours = validate(FOX, out)
    assert ours["issues"]["numErrors"] == 0
    codes = {m["code"] for m in ours["issues"]["messages"] if m["severity"] == 1}
    assert codes <= {m["code"] for m in source["issues"]["messages"] if m["severity"] == 1}
    for c in clips:
        if c["loop"]:
            assert c["seam_m"] < 1e-4 and c["max_slide_mm"] < SLIDE_LIMIT_MM, c["name"]
