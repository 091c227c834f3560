"""The shipped characters, and how malformed character files are reported.

Every shipped character (:func:`characters_dir`) must load, stand on its four feet at
rest with real proportions, bend its legs the right way, and mirror its left
legs onto its right. Bad files raise :class:`quadsim.errors.InputError`
naming the file and the key.
"""

from __future__ import annotations

import numpy as np
import pytest

import quadsim
from quadsim.errors import InputError
from quadsim.frames import Y, Z
from quadsim.skeleton.character import characters_dir, load_character

SHIPPED = quadsim.list_characters()

# id: (joint count range, standing shoulder / withers height range in m)
SPECS = {
    "leopard": ((28, 40), (0.60, 0.70)),
    "leopard_cub": ((28, 40), (0.33, 0.42)),
    "dog_cub": ((28, 40), (0.28, 0.36)),
    "horse": ((33, 37), (1.50, 1.70)),
}
DIGITIGRADE = {
    "fore": ["scapula", "shoulder", "elbow", "wrist", "paw"],
    "hind": ["hip", "knee", "hock", "paw"],
}
UNGULIGRADE = {
    "fore": ["scapula", "shoulder", "elbow", "carpus", "fetlock", "pastern", "hoof"],
    "hind": ["hip", "stifle", "hock", "fetlock", "pastern", "hoof"],
}
CATS_AND_DOGS_GAITS = ["walk", "trot", "pace", "canter", "transverse_gallop", "rotary_gallop"]
HORSE_GAITS = ["walk", "amble", "trot", "rack", "pace", "canter", "transverse_gallop",
               "rotary_gallop"]


def spec(name):
    if name not in SPECS:
        pytest.fail(f"no expected sizes for character {name!r}: add it to SPECS")
    return SPECS[name]


def rest(c):
    return c.skeleton.rest_positions


def signed_forward_offset(P, a, b, c):
    """How far joint ``b`` lies forward (+Z) of the line from ``a`` to ``c``,
    measured perpendicular to that line in the forward-up (Z, Y) plane (m)."""
    u = np.array([P[c, Z] - P[a, Z], P[c, Y] - P[a, Y]])
    w = np.array([P[b, Z] - P[a, Z], P[b, Y] - P[a, Y]])
    # the line runs downward, so a positive cross product means b is forward of it
    return float((u[0] * w[1] - u[1] * w[0]) / np.linalg.norm(u))


def mirror_name(n):
    """``LF_x`` -> ``RF_x``, ``LH_x`` -> ``RH_x``; other names unchanged."""
    prefix = {"LF_": "RF_", "LH_": "RH_"}.get(n[:3])
    return n if prefix is None else prefix + n[3:]


# --------------------------------------------------------------- the roster
def test_the_four_characters_are_shipped_and_gaits_toml_is_not_one():
    assert {"leopard", "leopard_cub", "dog_cub", "horse"} <= set(SHIPPED)
    assert (characters_dir() / "gaits.toml").exists()
    assert "gaits" not in SHIPPED


def test_list_characters_skips_files_without_a_character_table(tmp_path, monkeypatch):
    (tmp_path / "gaits.toml").write_text("[walk]\nduty = [0.7, 0.6]\n")
    (tmp_path / "notes.toml").write_text("title = 'not a character'\n")
    (tmp_path / "cat.toml").write_text("[character]\nid = 'cat'\n")
    (tmp_path / "broken.toml").write_text("[character\n")
    monkeypatch.setenv("QUADSIM_CHARACTERS", str(tmp_path))
    assert quadsim.list_characters() == ["broken", "cat"]


def test_unknown_character_names_the_known_ones():
    with pytest.raises(InputError, match=r"unknown character 'zebra'; known: .*leopard"):
        load_character("zebra")


# ------------------------------------------------------ every character
@pytest.mark.parametrize("name", SHIPPED)
def test_loads_with_its_own_id_and_a_plausible_joint_count(name):
    c = load_character(name)
    assert c.id == name
    assert c.mass > 0
    assert c.sources, "a character cites the sources of its measurements"
    lo, hi = spec(name)[0]
    assert lo <= c.skeleton.n_joints <= hi


@pytest.mark.parametrize("name", SHIPPED)
def test_spine_runs_from_the_pelvis_to_the_front_girdle(name):
    """At least four spine joints after the pelvis; the fore legs hang from the last."""
    c = load_character(name)
    parents = c.skeleton.parents
    assert c.spine[0] == 0 and len(c.spine) >= 5
    assert all(parents[b] == a for a, b in zip(c.spine[:-1], c.spine[1:]))
    for leg in c.legs[:2]:
        assert parents[leg.top] == c.spine[-1]
    for leg in c.legs[2:]:
        assert parents[leg.top] == c.spine[0]
    assert len(c.neck) >= 2 and parents[c.neck[0]] == c.spine[-1]
    assert parents[c.head] == c.neck[-1]
    assert c.skeleton.names[c.head] in c.skeleton.end_sites
    assert len(c.tail) >= 2 and parents[c.tail[0]] == c.spine[0]


@pytest.mark.parametrize("name", SHIPPED)
def test_standing_shoulder_height(name):
    c = load_character(name)
    lo, hi = spec(name)[1]
    assert lo <= c.shoulder_height <= hi
    assert 0.6 * c.shoulder_height < c.hip_height < c.shoulder_height


@pytest.mark.parametrize("name", SHIPPED)
def test_feet_stand_on_the_ground_at_rest(name):
    """Each foot contact joint at y = 0, with its toe tip forward and not below ground."""
    c = load_character(name)
    P = rest(c)
    for leg in c.legs:
        foot = c.skeleton.names[leg.foot]
        assert P[leg.foot, Y] == pytest.approx(0.0, abs=1e-9), foot
        tip = c.skeleton.end_sites[foot]
        assert tip[Z] > 0.0 and P[leg.foot, Y] + tip[Y] > -1e-9, foot
    np.testing.assert_allclose(c.rest_foot_positions()[:, Y], 0.0, atol=1e-9)


@pytest.mark.parametrize("name", SHIPPED)
def test_leg_joint_names_and_ik_pairs(name):
    c = load_character(name)
    kind = UNGULIGRADE if name == "horse" else DIGITIGRADE
    for leg in c.legs:
        part = "fore" if leg.name[1] == "F" else "hind"
        names = [c.skeleton.names[j] for j in leg.chain]
        assert names == [f"{leg.name}_{n}" for n in kind[part]]
        top = "shoulder" if part == "fore" else "hip"
        assert names[leg.ik_start] == f"{leg.name}_{top}"
        assert leg.bend == (-1.0 if part == "fore" else 1.0)


@pytest.mark.parametrize("name", SHIPPED)
def test_legs_lie_in_sagittal_planes(name):
    """Below the top joint of a leg every offset has x = 0; the top joint carries the width."""
    c = load_character(name)
    off = c.skeleton.offsets
    for leg in c.legs:
        np.testing.assert_array_equal(off[leg.chain[1:], 0], 0.0)
        side = 1.0 if leg.name[0] == "L" else -1.0
        assert side * rest(c)[leg.top, 0] > 0.0


@pytest.mark.parametrize("name", SHIPPED)
def test_legs_are_not_bent_backwards_at_rest(name):
    """Knee/stifle in front of the hip->hock line, elbow behind the shoulder->wrist/carpus line,
    each by a clear margin (2 % of the hip height)."""
    c = load_character(name)
    P = rest(c)
    margin = 0.02 * c.hip_height
    for leg in c.legs:
        a, b, d = leg.chain[leg.ik_start:leg.ik_start + 3]
        fwd = signed_forward_offset(P, a, b, d)
        if leg.name[1] == "H":
            assert fwd > margin, f"{leg.name}: knee {fwd:.3f} m in front of hip->hock"
        else:
            assert fwd < -margin, f"{leg.name}: elbow {-fwd:.3f} m behind shoulder->wrist"


@pytest.mark.parametrize("name", SHIPPED)
def test_feet_sit_roughly_under_their_hips_and_shoulders(name):
    c = load_character(name)
    P = rest(c)
    for leg in c.legs:
        ik = leg.chain[leg.ik_start]
        assert abs(P[leg.foot, Z] - P[ik, Z]) < 0.15 * c.hip_height, leg.name


@pytest.mark.parametrize("name", SHIPPED)
def test_limits_cover_the_ik_pair_and_allow_the_rest_pose(name):
    c = load_character(name)
    for leg in c.legs:
        for j in leg.chain[leg.ik_start + 1:leg.ik_start + 3]:
            assert j in c.limits, c.skeleton.names[j]
            lo, hi = c.limits[j]
            assert lo < 0.0 < hi
            assert np.radians(-150) <= lo and hi <= np.radians(150)


@pytest.mark.parametrize("name", SHIPPED)
def test_left_and_right_legs_mirror_each_other(name):
    c = load_character(name)
    s = c.skeleton
    P = rest(c)
    flip = np.array([-1.0, 1.0, 1.0])
    left = [n for n in s.names if n[:3] in ("LF_", "LH_")]
    assert len(left) == sum(len(leg.chain) for leg in c.legs[0::2])
    for n in left:
        i, k = s.index(n), s.index(mirror_name(n))
        np.testing.assert_array_equal(s.offsets[k], s.offsets[i] * flip)
        np.testing.assert_allclose(P[k], P[i] * flip, atol=1e-12)
        assert s.names[s.parents[k]] == mirror_name(s.names[s.parents[i]])
        if n in s.end_sites:
            np.testing.assert_array_equal(s.end_sites[mirror_name(n)], s.end_sites[n] * flip)
        if i in c.limits:
            assert c.limits[k] == c.limits[i]
    for lft, rgt in ((c.legs[0], c.legs[1]), (c.legs[2], c.legs[3])):
        assert [mirror_name(s.names[j]) for j in lft.chain] == [s.names[j] for j in rgt.chain]
        assert (lft.ik_start, lft.bend) == (rgt.ik_start, rgt.bend)
    np.testing.assert_allclose(c.leg_lengths[0], c.leg_lengths[1])
    np.testing.assert_allclose(c.leg_lengths[2], c.leg_lengths[3])


@pytest.mark.parametrize("name", SHIPPED)
def test_locomotion_table(name):
    loc = load_character(name).locomotion
    if name == "horse":
        assert loc.gaits == tuple(HORSE_GAITS)
        assert loc.auto == ("walk", "trot", "canter", "transverse_gallop")
        assert 0.0 < loc.spine_flex_deg <= 5.0 and -5.0 <= loc.spine_extend_deg < 0.0
    else:
        assert loc.gaits == tuple(CATS_AND_DOGS_GAITS)
        assert loc.auto == ("walk", "trot", "canter", "rotary_gallop")
        assert loc.spine_flex_deg >= 15.0 and loc.spine_extend_deg <= -8.0
    assert set(loc.auto) <= set(loc.gaits)
    assert 0.0 < loc.max_turn_rate_deg_s <= 360.0


@pytest.mark.parametrize("name", SHIPPED)
def test_locomotion_table_reads_as_a_mapping_of_the_keys_given(name):
    """``locomotion.get(key, default)`` gives the file's value, or the default
    for a key the file leaves out."""
    loc = load_character(name).locomotion
    assert loc["auto"] == loc.auto and loc.get("max_turn_rate_deg_s") == loc.max_turn_rate_deg_s
    assert set(loc) == {k for k in ("gaits", "auto", "max_turn_rate_deg_s", "spine_flex_deg",
                                    "spine_extend_deg", "spine_slow_scale",
                                    "min_turn_radius_body_lengths", "head_nod_deg", "toe_roll_deg",
                                    "fetlock_sink_deg", "digit_flex_deg")
                        if getattr(loc, k) is not None}
    assert "min_turn_radius_body_lengths" not in loc
    assert loc.get("min_turn_radius_body_lengths", 1.0) == 1.0
    with pytest.raises(KeyError):
        loc["min_turn_radius_body_lengths"]


def test_a_character_is_frozen_down_to_its_tables():
    c = load_character("horse")
    with pytest.raises(AttributeError):
        c.mass = 1.0
    with pytest.raises(AttributeError):
        c.locomotion.auto = ("walk",)
    with pytest.raises(TypeError):
        c.gait_overrides["walk"]["speed"] = [0.0, 1.0]
    with pytest.raises(TypeError):
        c.file.limits["LF_elbow"] = (0.0, 1.0)
    assert c.file.character.id == "horse" and c.file.mirror_left_legs


# ------------------------------------------------------------ proportions
def head_length(c):
    return float(np.linalg.norm(c.skeleton.end_sites[c.skeleton.names[c.head]]))


def tail_length(c):
    s = c.skeleton
    tip = s.end_sites.get(s.names[c.tail[-1]], np.zeros(3))
    return float(np.linalg.norm(s.offsets[c.tail], axis=-1).sum() + np.linalg.norm(tip))


def test_cub_is_not_a_shrunk_adult():
    """Relative to its body the leopard cub has a bigger head, shorter legs and a shorter tail."""
    adult, cub = load_character("leopard"), load_character("leopard_cub")
    assert head_length(cub) / cub.body_length > 1.05 * head_length(adult) / adult.body_length
    assert (cub.leg_lengths.mean() / cub.body_length
            < 0.97 * adult.leg_lengths.mean() / adult.body_length)
    assert tail_length(cub) / cub.body_length < tail_length(adult) / adult.body_length
    assert cub.mass < 0.3 * adult.mass


def test_puppy_has_a_big_head_and_short_tail():
    dog = load_character("dog_cub")
    assert head_length(dog) / dog.body_length > 0.35
    assert tail_length(dog) < dog.body_length


# ----------------------------------------------------------------- horse
def test_horse_withers_is_the_last_spine_joint():
    c = load_character("horse")
    P = rest(c)
    assert P[c.spine[-1], Y] == pytest.approx(c.shoulder_height, abs=1e-9)
    assert c.shoulder_height == pytest.approx(1.6, abs=0.03)
    assert len(c.neck) == 3 and len(c.tail) == 2


def test_horse_pasterns_slope_and_cannons_stand_upright():
    """Fetlock -> pastern joint at 50-60 degrees from horizontal, sloping forward;
    carpus/hock -> fetlock within 5 degrees of vertical."""
    c = load_character("horse")
    s = c.skeleton
    for leg in ("LF", "RF", "LH", "RH"):
        pastern = s.offsets[s.index(f"{leg}_pastern")]
        slope = np.degrees(np.arctan2(-pastern[Y], pastern[Z]))
        assert 50.0 <= slope <= 60.0, leg
        cannon = s.offsets[s.index(f"{leg}_fetlock")]
        assert np.degrees(np.arctan2(abs(cannon[Z]), -cannon[Y])) < 5.0, leg


def test_horse_gait_overrides_are_real_speed_ranges():
    c = load_character("horse")
    over = c.gait_overrides
    allowed = {"speed", "duty", "phase", "froude", "stride", "swing_height", "spine",
               "spine_deg", "drop"}
    assert set(over) <= set(HORSE_GAITS)
    for gait, table in over.items():
        assert set(table) <= allowed, gait
        lo, hi = table["speed"]
        assert 0.5 < lo < hi < 20.0, gait
    assert over["walk"]["speed"][1] <= 2.0 and over["walk"]["duty"] == [0.70, 0.60]
    assert over["transverse_gallop"]["speed"][1] >= 14.0
    assert over["trot"]["speed"][0] < over["canter"]["speed"][0] < over["transverse_gallop"][
        "speed"][0]


# ------------------------------------------------------- malformed files
BASE = """\
mirror_left_legs = true
joints = [
  { name = "pelvis", parent = "", offset = [0.0, 0.5, 0.0] },
  { name = "s1", parent = "pelvis", offset = [0.0, 0.0, 0.1] },
  { name = "s2", parent = "s1", offset = [0.0, 0.0, 0.1] },
  { name = "s3", parent = "s2", offset = [0.0, 0.0, 0.1] },
  { name = "s4", parent = "s3", offset = [0.0, 0.0, 0.1] },
  { name = "head", parent = "s4", offset = [0.0, 0.1, 0.1], end = [0.0, 0.0, 0.1] },
  { name = "LH_hip", parent = "pelvis", offset = [0.05, 0.0, 0.0] },
  { name = "LH_knee", parent = "LH_hip", offset = [0.0, -0.25, 0.05] },
  { name = "LH_hock", parent = "LH_knee", offset = [0.0, -0.15, -0.05] },
  { name = "LH_paw", parent = "LH_hock", offset = [0.0, -0.1, 0.0] },
  { name = "LF_shoulder", parent = "s4", offset = [0.05, 0.0, 0.0] },
  { name = "LF_elbow", parent = "LF_shoulder", offset = [0.0, -0.25, -0.05] },
  { name = "LF_wrist", parent = "LF_elbow", offset = [0.0, -0.2, 0.05] },
  { name = "LF_paw", parent = "LF_wrist", offset = [0.0, -0.05, 0.0] },
]

[character]
id = "tiny"
mass = 5.0

[chains]
spine = ["pelvis", "s1", "s2", "s3", "s4"]
head = "head"

[legs.LF]
chain = ["LF_shoulder", "LF_elbow", "LF_wrist", "LF_paw"]
ik = "LF_shoulder"
bend = "back"

[legs.LH]
chain = ["LH_hip", "LH_knee", "LH_hock", "LH_paw"]
ik = "LH_hip"
bend = "forward"

[limits]
LF_elbow = [-100.0, 20.0]
"""

LH_HIP = '  { name = "LH_hip", parent = "pelvis", offset = [0.05, 0.0, 0.0] },\n'
LH_KNEE = '  { name = "LH_knee", parent = "LH_hip", offset = [0.0, -0.25, 0.05] },\n'
LEGS_LH = ('[legs.LH]\nchain = ["LH_hip", "LH_knee", "LH_hock", "LH_paw"]\n'
           'ik = "LH_hip"\nbend = "forward"\n')


def write(tmp_path, text, name="bad.toml"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def edited(old, new):
    assert old in BASE, f"test setup: {old!r} is not in the base file"
    return BASE.replace(old, new, 1)


def test_the_base_file_of_the_error_tests_is_valid(tmp_path):
    c = load_character(write(tmp_path, BASE, "tiny.toml"))
    assert c.id == "tiny" and c.skeleton.n_joints == 14 + 8  # 8 mirrored right-leg joints
    assert [leg.name for leg in c.legs] == ["LF", "RF", "LH", "RH"]


@pytest.mark.parametrize("text, message", [
    pytest.param(
        edited('offset = [0.0, 0.0, 0.1] },\n  { name = "s3"',
               'offset = [0.0, 0.0, 0.1], colour = "red" },\n  { name = "s3"'),
        r"joints\[2\]: unknown key\(s\) \['colour'\]; allowed: name, parent, offset, end",
        id="unknown-joint-key"),
    pytest.param(
        edited(LH_HIP + LH_KNEE, LH_KNEE + LH_HIP),
        r"joint 'LH_knee' names parent 'LH_hip', which is not defined before it",
        id="parent-after-child"),
    pytest.param(edited(LEGS_LH, ""), r"missing table \[legs\.LH\]", id="missing-legs-LH"),
    pytest.param(
        edited('bend = "back"', 'bend = "sideways"'),
        r"legs\.LF\.bend must be \"forward\" or \"back\", got 'sideways'", id="bad-bend"),
    pytest.param(
        edited('spine = ["pelvis", "s1", "s2", "s3", "s4"]',
               'spine = ["pelvis", "s1"]'),
        r"chains\.spine needs the pelvis and at least two more joints", id="spine-too-short"),
    pytest.param(
        edited('spine = ["pelvis", "s1", "s2", "s3", "s4"]',
               'spine = ["pelvis", "s1", "s3", "s4", "head"]'),
        r"chains\.spine: 's3' is not a child of 's1'", id="spine-not-a-chain"),
    pytest.param(
        edited('"LH_hock", "LH_paw"]', '"LH_ankle", "LH_paw"]'),
        r"legs\.LH\.chain: no joint named 'LH_ankle'", id="unknown-chain-joint"),
    pytest.param(
        edited('ik = "LH_hip"', 'ik = "LH_hock"'),
        r"legs\.LH\.ik: the two-bone pair starting at 'LH_hock' needs two more joints",
        id="ik-too-low"),
    pytest.param(
        edited('offset = [0.0, 0.0, 0.1] },\n  { name = "s2"',
               'offset = [0.0, 0.1] },\n  { name = "s2"'),
        r"joints\[1\]\.offset must be a list of three numbers", id="short-offset"),
    pytest.param(
        edited("LF_elbow = [-100.0, 20.0]", "LF_elbow = [20.0, -100.0]"),
        r"limits\.LF_elbow must be \[min_deg, max_deg\] with min < max", id="limits-reversed"),
    pytest.param(
        edited("LF_elbow = [-100.0, 20.0]", 'LF_elbow = ["a", "b"]'),
        r"limits\.LF_elbow must be \[min_deg, max_deg\]", id="limits-not-numbers"),
    pytest.param(
        edited("LF_elbow = [-100.0, 20.0]", "LF_ankle = [-100.0, 20.0]"),
        r"limits: no joint named 'LF_ankle'", id="limits-unknown-joint"),
    pytest.param(edited("mass = 5.0", 'mass = "heavy"'),
                 r"character\.mass must be a positive number", id="mass-not-a-number"),
    pytest.param(edited("mass = 5.0", "mass = -5.0"),
                 r"character\.mass must be a positive number", id="mass-negative"),
    pytest.param(edited('[character]\nid = "tiny"\nmass = 5.0\n', ""),
                 r"missing key `character`", id="missing-character-table"),
    pytest.param(edited('{ name = "s1", parent = "pelvis"', '{ name = "s1", parent = "pelvis",,'),
                 r"not valid TOML", id="invalid-toml"),
    # unknown or misspelt keys, at every level
    pytest.param("mirror_left_leg = true\n" + BASE,
                 r"top level: unknown key\(s\) \['mirror_left_leg'\]; allowed: mirror_left_legs, "
                 r".* \(did you mean 'mirror_left_legs'\?\)", id="unknown-top-level-key"),
    pytest.param(edited("mass = 5.0", "mass = 5.0\nweight = 5.0"),
                 r"\[character\]: unknown key\(s\) \['weight'\]; allowed: id, name, species, "
                 r"mass, sources", id="unknown-character-key"),
    pytest.param(edited('head = "head"', 'head = "head"\ntails = []'),
                 r"\[chains\]: unknown key\(s\) \['tails'\]; allowed: spine, neck, head, tail "
                 r"\(did you mean 'tail'\?\)", id="unknown-chains-key"),
    pytest.param(edited("[legs.LF]", "[legs.LX]\nchain = []\n\n[legs.LF]"),
                 r"\[legs\]: unknown key\(s\) \['LX'\]; allowed: LF, RF, LH, RH",
                 id="unknown-leg-name"),
    pytest.param(edited('bend = "back"', 'bend = "back"\npost_gian = 0.5'),
                 r"legs\.LF: unknown key\(s\) \['post_gian'\]; allowed: chain, ik, bend, "
                 r"pre_gain, post_gain \(did you mean 'post_gain'\?\)", id="unknown-leg-key"),
    pytest.param(BASE + "\n[locomotion]\nmax_turn_rate = 90.0\n",
                 r"\[locomotion\]: unknown key\(s\) \['max_turn_rate'\]; allowed: gaits, auto, "
                 r".*\(did you mean 'max_turn_rate_deg_s'\?\)", id="unknown-locomotion-key"),
    pytest.param(BASE + "\n[gaits.walk]\nsped = [0.5, 1.0]\n",
                 r"gaits\.walk: unknown key\(s\) \['sped'\]; allowed: duty, phase, .*"
                 r"\(did you mean 'speed'\?\)", id="unknown-gait-key"),
    pytest.param(BASE + '\n[locomotion]\ngaits = ["walk", "trot"]\n\n[gaits.trott]\n'
                 "speed = [1.0, 2.0]\n",
                 r"\[gaits\.trott\] overrides a gait that is not one of the character's gaits "
                 r".*; allowed: walk, trot \(did you mean 'trot'\?\)",
                 id="override-of-a-missing-gait"),
    pytest.param(BASE + "\n[gaits.trott]\nspeed = [1.0, 2.0]\n",
                 r"\[gaits\.trott\] overrides a gait that is not one of the character's gaits "
                 r".*; allowed: walk, amble, rack, trot, .*\(did you mean 'trot'\?\)",
                 id="override-of-a-gait-the-shared-table-lacks"),
    pytest.param(BASE + '\n[locomotion]\ngaits = ["walk", "trott"]\n',
                 r"locomotion\.gaits names 'trott', which is not a gait of the shared gait "
                 r"table; known: walk, .* \(did you mean 'trot'\?\)", id="unknown-gait-name"),
    # locomotion values
    pytest.param(BASE + '\n[locomotion]\ngaits = ["walk", "trot"]\nauto = ["walk", "canter"]\n',
                 r"locomotion\.auto names 'canter', which is not among locomotion\.gaits",
                 id="auto-gait-not-among-gaits"),
    pytest.param(BASE + "\n[locomotion]\nmax_turn_rate_deg_s = -30.0\n",
                 r"locomotion\.max_turn_rate_deg_s = -30\.0 is out of range; allowed 0 <",
                 id="negative-turn-rate"),
    pytest.param(BASE + "\n[locomotion]\ntoe_roll_deg = 75.0\n",
                 r"locomotion\.toe_roll_deg = 75\.0 is out of range; allowed 0 <= .* <= 60",
                 id="toe-roll-past-60-degrees"),
    pytest.param(BASE + "\n[locomotion]\ntoe_roll_deg = 30.0\n",
                 r"locomotion\.toe_roll_deg = 30: a foot rolls over its toe tip, the end site "
                 r"of its foot joint, .* not so for legs LF, RF, LH, RH: give each foot joint "
                 r"an `end` ahead of it, or set toe_roll_deg = 0", id="toe-roll-without-toe-tips"),
    pytest.param(BASE + "\n[locomotion]\nfetlock_sink_deg = 50.0\n",
                 r"locomotion\.fetlock_sink_deg = 50\.0 is out of range; allowed 0 <= .* <= 45",
                 id="fetlock-sink-past-45-degrees"),
    pytest.param(BASE + "\n[locomotion]\nfetlock_sink_deg = 20.0\n",
                 r"locomotion\.fetlock_sink_deg = 20: a leg's digit .* every leg needs at least "
                 r"two bones below its pair; legs LF, RF, LH, RH have fewer: give them a digit "
                 r"\(fetlock -> pastern -> hoof\) or set fetlock_sink_deg = 0",
                 id="fetlock-sink-without-a-digit"),
    pytest.param(BASE + "\n[locomotion]\ndigit_flex_deg = 60.0\n",
                 r"locomotion\.digit_flex_deg = 60: a leg's digit .* flexes in swing, so every "
                 r"leg needs at least two bones below its pair; legs LF, RF, LH, RH have fewer",
                 id="digit-flex-without-a-digit"),
    # geometry: zero-length bones
    pytest.param(edited(LH_KNEE, LH_KNEE.replace("[0.0, -0.25, 0.05]", "[0.0, 0.0, 0.0]")),
                 r"joints\[7\]\.offset = \[0\.0, 0\.0, 0\.0\]: joint 'LH_knee' sits on its "
                 r"parent 'LH_hip', a bone of zero length", id="zero-length-bone"),
    pytest.param(edited("end = [0.0, 0.0, 0.1]", "end = [0.0, 0.0, 0.0]"),
                 r"joints\[5\]\.end = \[0\.0, 0\.0, 0\.0\]: the bone tip of 'head' has zero "
                 r"length", id="zero-length-end-tip"),
    pytest.param(edited("offset = [0.0, 0.0, 0.1] },\n  { name = \"s2\"",
                        "offset = [0.0, nan, 0.1] },\n  { name = \"s2\""),
                 r"joints\[1\]\.offset must be a list of three numbers", id="offset-not-finite"),
    # geometry: legs that cannot stand at the rest height
    pytest.param(edited('"LH_paw", parent = "LH_hock", offset = [0.0, -0.1, 0.0]',
                        '"LH_paw", parent = "LH_hock", offset = [0.0, -0.3, 0.0]'),
                 r"legs\.LH: over-long leg: at rest its foot 'LH_paw' is 0\.2 m below the "
                 r"ground .* shorten the leg or raise the root by 0\.2 m", id="over-long-leg"),
    pytest.param(edited('"LF_paw", parent = "LF_wrist", offset = [0.0, -0.05, 0.0]',
                        '"LF_paw", parent = "LF_wrist", offset = [0.0, -0.01, 0.0]'),
                 r"legs\.LF: leg too short: at rest its foot 'LF_paw' is 0\.04 m above the "
                 r"ground", id="leg-too-short"),
    pytest.param(edited(LH_KNEE, LH_KNEE.replace("[0.0, -0.25, 0.05]", "[0.02, -0.25, 0.05]")),
                 r"legs\.LH\.chain: joints below the top of a leg lie in the leg's plane "
                 r"\(offset x = 0\); not so for LH_knee", id="leg-out-of-its-plane"),
    pytest.param(edited('ik = "LF_shoulder"\nbend = "back"', 'ik = "LF_shoulder"\nbend = "forward"'),
                 r"legs\.LF\.bend = \"forward\": at rest 'LF_elbow' lies 0\.0\d+ m behind the "
                 r"line 'LF_shoulder' -> 'LF_wrist'; it must lie forward of it",
                 id="pair-bent-against-its-bend"),
    pytest.param(edited(LH_HIP, LH_HIP.replace("[0.05, 0.0, 0.0]", "[0.05, 0.0, 0.6]")),
                 r"legs: the fore legs' IK joints must lie ahead \(\+Z\) of the hind legs'",
                 id="fore-legs-behind-hind-legs"),
    # missing joints
    pytest.param(edited('head = "head"', 'head = "skull"'),
                 r"chains\.head: no joint named 'skull'", id="missing-head-joint"),
    pytest.param(edited('ik = "LH_hip"', 'ik = "LH_pelvis"'),
                 r"legs\.LH\.ik: 'LH_pelvis' is not in the leg's chain", id="ik-joint-not-in-chain"),
    pytest.param(BASE.replace("mirror_left_legs = true\n", ""),
                 r"missing table \[legs\.RF\]", id="right-legs-without-mirroring"),
    # joint-limit ranges
    pytest.param(edited("LF_elbow = [-100.0, 20.0]", "LF_elbow = [10.0, 50.0]"),
                 r"limits\.LF_elbow = \[10\.0, 50\.0\]: the range must hold the rest pose "
                 r"\(0 deg\)", id="limits-exclude-the-rest-pose"),
    pytest.param(edited("LF_elbow = [-100.0, 20.0]", "LF_elbow = [-200.0, 20.0]"),
                 r"limits\.LF_elbow = \[-200\.0, 20\.0\]: .* within -180 to 180 deg",
                 id="limits-beyond-a-half-turn"),
])
def test_malformed_file_raises_input_error_naming_file_and_key(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(InputError, match=message) as err:
        load_character(path)
    assert path.name in str(err.value)


def test_missing_file_is_an_input_error(tmp_path):
    path = tmp_path / "nobody.toml"
    with pytest.raises(InputError, match="no such character file") as err:
        load_character(path)
    assert "nobody.toml" in str(err.value)
