"""Rigs of other conventions are adopted and trot in their own files.

The rigs are built here (:mod:`rig_builders`): Blender naming (``thigh.L``,
``spine.001``), ``LeftThigh`` naming and bare ``bone_017`` names; +Y and +Z
up; metres, centimetres in the translations, centimetres under an armature
node scaled by 0.01, BVH in centimetres; face, ear, jaw, eye, whisker, mane,
helper, twist and inline segment bones (most of the 20 to 200 bones are no
leg); hind legs of two, three and four bones; fore legs with and without a
scapula; a horse with a long neck and hooves. Each is mapped leg by leg, run
as a character through the CLI (`quadsim rig`, then `quadsim run ... --gait
trot --seconds 6`), and measured from the file written: the user's mesh and
every joint kept, diagonal pairs in phase, planted feet, forward travel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from rig_builders import (
    TO_Z_UP,
    animated_positions,
    quadruped,
    write_bvh_rig,
    write_gltf,
)

from quadsim.frames import LEGS


@dataclass(frozen=True)
class Kind:
    """A rig kind: how it is built and written, and what adopting it must say."""

    id: str
    build: dict
    fmt: str            # ".glb", ".gltf" or ".bvh"
    up: str             # "Y" or "Z"
    unit: str           # "m", "cm" or "scale" (cm under a 0.01 armature node)

    def spec(self):
        return quadruped(self.id, **self.build)

    def write(self, spec, folder):
        path = folder / f"{self.id}{self.fmt}"
        if self.fmt == ".bvh":
            return write_bvh_rig(spec, path, up=self.up, unit=self.unit)
        return write_gltf(spec, path, up=self.up, unit=self.unit)

    @property
    def to_quadsim(self) -> np.ndarray:
        """Rotation from the file's frame to quadsim's."""
        return np.eye(3) if self.up == "Y" else TO_Z_UP.T

    @property
    def metres(self) -> float:
        return 0.01 if self.unit == "cm" else 1.0


KINDS = [
    Kind("blender_dog", dict(style="blender", hind_bones=3, scapula=True, whiskers=3),
         ".glb", "Z", "cm"),
    Kind("cat", dict(style="camel", hip=0.28, hind_bones=2, scapula=False, toes=3,
                     whiskers=6), ".gltf", "Z", "scale"),
    Kind("horse", dict(style="camel", hip=1.0, hind_bones=4, scapula=True, neck_bones=6,
                       mane=True, tail_bones=6), ".glb", "Y", "m"),
    Kind("wolf_200", dict(style="blender", hind_bones=4, scapula=False, whiskers=70,
                          tail_bones=8), ".glb", "Y", "cm"),
    Kind("bvh_bare", dict(style="anonymous", hind_bones=4, scapula=False, face=False,
                          helpers=False, neck_bones=1, tail_bones=3, root=False),
         ".bvh", "Z", "cm"),
    Kind("bvh_blender", dict(style="blender", hind_bones=2, scapula=True, whiskers=2),
         ".bvh", "Y", "m"),
    # a root bone on the ground (the hips its child) in centimetres: the root's height
    # alone says nothing of the unit (read as metres, its hip stood 50 m tall)
    Kind("bvh_ground_root_cm", dict(style="blender", hind_bones=3, scapula=True),
         ".bvh", "Z", "cm"),
]


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("rigs")


def test_the_kinds_cover_the_conventions_asked_for():
    specs = {k.id: k.spec() for k in KINDS}
    sizes = [len(s.joints) for s in specs.values()]
    assert 20 <= min(sizes) <= 30 and 180 <= max(sizes) <= 200, sizes
    assert {k.build["hind_bones"] for k in KINDS} == {2, 3, 4}
    assert {k.build["scapula"] for k in KINDS} == {True, False}
    assert {k.up for k in KINDS} == {"Y", "Z"} and {k.unit for k in KINDS} >= {"m", "cm"}
    big = specs["wolf_200"]
    legs = {j for leg in LEGS for j in big.expect[leg]}
    assert len(legs) < 0.1 * len(big.joints)          # most of its bones are no leg


@pytest.mark.parametrize("kind", KINDS, ids=[k.id for k in KINDS])
def test_adoption_maps_every_leg_and_finds_axes_and_unit(kind, folder):
    from quadsim.io.adopt import adopt, rig_foot
    from quadsim.io.rig_structure import name_words

    spec = kind.spec()
    a = adopt(kind.write(spec, folder))
    for leg in LEGS:
        top, foot = spec.expect[leg]
        assert (a.legs[leg][0], rig_foot(a.legs[leg])) == (top, foot), leg
    assert (a.spine[0], a.spine[-1]) == (spec.expect["pelvis"], spec.expect["withers"])
    if kind.build["style"] != "anonymous":
        assert a.head == spec.expect["head"]
    assert a.rig.up == ("+Y" if kind.up == "Y" else "+Z")
    assert a.rig.forward == ("+Z" if kind.up == "Y" else "-Y")
    assert a.rig.unit == ("cm" if kind.unit == "cm" else "m")
    # standing where the rig stands, in metres and quadsim's frame
    assert a.anatomy.hip_height == pytest.approx(kind.build.get("hip", 0.5), rel=0.02)
    # every joint not kept is listed with a reason; the kept ones are locomotion chains
    kept = set(a.skeleton.names)
    assert set(a.ignored) == set(spec.names) - kept
    assert all(a.ignored.values())
    face = [n for n in a.ignored if {"ear", "whisker", "jaw"} & set(name_words(n))]
    assert face or kind.build.get("face") is False
    assert all("face" in a.ignored[n] or "head" in a.ignored[n] for n in face)
    report = a.report()
    assert "leg RH" in report and (not a.ignored or f"ignored ({len(a.ignored)})" in report)


def _runs(mask):
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    return list(zip(np.flatnonzero(np.diff(m) == 1), np.flatnonzero(np.diff(m) == -1)))


def _written_motion(kind, out):
    """Joint world positions (T, J, 3) in quadsim's frame (m), by rig joint name, and fps."""
    if out.suffix == ".bvh":
        from quadsim.io.bvh import read_bvh

        m = read_bvh(out, units="m")
        P, names, fps = m.world_positions(), m.skeleton.names, m.fps
    else:
        index, P, fps = animated_positions(out)
        names = sorted(index, key=index.get)
    P = P @ kind.to_quadsim.T * kind.metres
    return {n: k for k, n in enumerate(names)}, P, fps


@pytest.mark.parametrize("kind", KINDS, ids=[k.id for k in KINDS])
def test_each_kind_trots_in_its_own_file(kind, folder, capsys):
    """`quadsim rig`, then `quadsim run CHARACTER.toml --gait trot --seconds 6 --out X`:
    the user's model (mesh, every joint) with a trot measured from the file."""
    import pygltflib

    from quadsim.cli import main
    from quadsim.skeleton.contacts import foot_contacts

    spec = kind.spec()
    model = kind.write(spec, folder)
    char = folder / f"{kind.id}.toml"
    assert main(["rig", str(model), "--out", str(char)]) == 0
    ext = ".bvh" if kind.fmt == ".bvh" else ".glb"
    out = folder / f"{kind.id}_trot{ext}"
    assert main(["run", str(char), "--gait", "trot", "--seconds", "6", "--out", str(out)]) == 0
    capsys.readouterr()
    if ext == ".glb":
        src, g = pygltflib.GLTF2().load(str(model)), pygltflib.GLTF2().load(str(out))
        assert [n.name for n in g.nodes] == [n.name for n in src.nodes]
        count = [g.accessors[p.attributes.POSITION].count for m in g.meshes for p in m.primitives]
        assert count == [src.accessors[p.attributes.POSITION].count
                         for m in src.meshes for p in m.primitives] and count[0] > 0
        assert g.skins[0].joints == src.skins[0].joints
    index, P, fps = _written_motion(kind, out)
    assert set(spec.names) <= set(index)                  # every one of the user's joints
    if ext == ".bvh":
        from quadsim.io.bvh import read_bvh

        back = read_bvh(out, units="m").skeleton
        src = read_bvh(model, units="m").skeleton
        assert back.names == src.names                    # the user's hierarchy and names
        assert list(back.parents) == list(src.parents)
        np.testing.assert_allclose(back.offsets[1:], src.offsets[1:], atol=1e-5)
    feet = P[:, [index[spec.expect[leg][1]] for leg in LEGS]]
    skip = int(2 * fps)
    c = foot_contacts(feet, fps)[skip:]
    lf, rf, lh, rh = c.T
    assert (lf == rh).mean() > 0.8 and (rf == lh).mean() > 0.8 and (lf != rf).mean() > 0.5
    f = feet[skip:]
    slide = max(np.ptp(f[s:e, i][:, [0, 2]], axis=0).max()
                for i in range(4) for s, e in _runs(c[:, i]))
    assert slide < 0.01 * spec.height, (slide, spec.height)
    assert abs(f[..., 1].min()) < 0.01 * spec.height          # on the ground, not under it
    pelvis = P[:, index[spec.expect["pelvis"]]]
    assert pelvis[-1, 2] - pelvis[0, 2] > 3.0 * kind.build.get("hip", 0.5)   # forward
    assert abs(pelvis[-1, 0] - pelvis[0, 0]) < 0.05 * (pelvis[-1, 2] - pelvis[0, 2])
    if ext == ".glb":
        from gltf_tools import validate

        issues = validate(out)[0]["issues"]
        assert issues["numErrors"] == 0, [m for m in issues["messages"] if m["severity"] == 0]


# ------------------------------------------------------------ rigs it cannot map
def _three_legged(spec):
    """The rig without its right hind leg (and the helpers hanging from it)."""
    leg = {spec.expect["RH"][0]}
    for nm, p, _ in spec.joints:
        if p in leg:
            leg.add(nm)
    spec.joints = [j for j in spec.joints if j[0] not in leg]
    return spec


def _two_spines(spec):
    """A second copy of the skeleton (names ``*_b``) beside the first, on the same root."""
    rootname = spec.joints[0][0]
    copy = [(f"{nm}_b", rootname if p == rootname else f"{p}_b", pos + [0.8, 0.0, 0.0])
            for nm, p, pos in spec.joints[1:]]
    spec.joints += copy
    return spec


@pytest.mark.parametrize("fmt", [".glb", ".bvh"])
def test_a_three_legged_rig_is_refused_with_what_was_found_and_the_keys_to_set(fmt, tmp_path,
                                                                              capsys):
    import tomllib

    from quadsim.cli import main

    spec = _three_legged(quadruped("tripod", style="blender"))
    model = write_gltf(spec, tmp_path / "tripod.glb") if fmt == ".glb" else \
        write_bvh_rig(spec, tmp_path / "tripod.bvh", unit="cm")
    char = tmp_path / "tripod.toml"
    assert main(["rig", str(model), "--out", str(char)]) == 2
    err = capsys.readouterr().err
    assert "found 3 leg(s) ending in a foot near the ground" in err
    assert "toe.L" in err and "f_toe.L" in err and "f_toe.R" in err
    assert "legs.RH.chain" in err and f"wrote the draft {char}" in err
    assert "Traceback" not in err
    draft = tomllib.loads(char.read_text())
    assert draft["legs"]["RH"]["chain"] == [] and "SET BY HAND" in char.read_text()


def test_a_rig_with_two_spines_is_refused_then_adopted_with_the_feet_set_by_hand(tmp_path,
                                                                               capsys):
    """Eight feet on four girdles: exit 2 and a draft; the feet named in the draft, the
    same command adopts the first skeleton and the second follows its root."""
    import quadsim
    from quadsim.cli import main

    spec = _two_spines(quadruped("twins", style="camel", face=False))
    model = write_gltf(spec, tmp_path / "twins.glb", up="Z", unit="cm")
    char = tmp_path / "twins.toml"
    assert main(["rig", str(model), "--out", str(char)]) == 2
    err = capsys.readouterr().err
    assert "found 8 feet hanging from 4 girdle(s)" in err and "second spine" in err
    assert "legs.LF.chain" in err
    text = char.read_text()
    for leg in LEGS:
        foot = spec.expect[leg][1]
        text = text.replace(f"[legs.{leg}]\nchain = []  # SET BY HAND",
                            f'[legs.{leg}]\nchain = ["{foot}"]')
    char.write_text(text)
    assert main(["rig", str(model), "--out", str(char)]) == 0
    out = capsys.readouterr().out
    assert "the feet as named in" in out and "+Z up, -Y forward" in out
    assert "LeftThigh_b" in out                              # the copy, ignored
    motion = quadsim.run(quadsim.load_character(char), gait="trot", seconds=1)
    assert motion.skeleton.names[0] == "Spine"


def test_a_gltf_rig_run_to_bvh_is_the_users_hierarchy_in_its_own_axes_and_unit(tmp_path):
    """A .bvh of a character adopted from a glTF model holds every joint of the model's
    skin by its name, the OFFSETs of its rest pose in the file's frame and unit."""
    import quadsim
    from quadsim.io.adopt import adopt
    from quadsim.io.bvh import read_bvh

    kind = KINDS[0]                                    # Blender names, +Z up, centimetres
    spec = kind.spec()
    model = kind.write(spec, tmp_path)
    a = adopt(model)
    char = tmp_path / "dog.toml"
    char.write_text(a.character_toml("dog", model=model.name), encoding="utf-8")
    dog = quadsim.load_character(char)
    out = quadsim.save(quadsim.run(dog, gait="trot", seconds=2), tmp_path / "dog.bvh",
                       character=dog)
    back = read_bvh(out, units="m")
    assert set(back.skeleton.names) == set(spec.names)
    P = back.world_positions()[0] @ kind.to_quadsim.T * kind.metres   # frame 0, m
    Q = quadsim.run(dog, gait="trot", seconds=2).world_positions()[0]
    for name in ("spine", "f_toe.L", "toe.R", "spine.006"):
        got = P[back.skeleton.names.index(name)] - [0.0, a.ground, 0.0]
        np.testing.assert_allclose(got, Q[dog.skeleton.names.index(name)], atol=2e-3)


def test_asking_for_units_on_an_adopted_rigs_bvh_warns_that_they_do_not_apply(tmp_path):
    """The .bvh of an adopted rig is in the model's own unit: ``units="cm"`` is not
    silently dropped but said to be, and the file is the same as without it."""
    import quadsim
    from quadsim.io.adopt import adopt

    kind = KINDS[0]
    model = kind.write(kind.spec(), tmp_path)
    char = tmp_path / "dog.toml"
    char.write_text(adopt(model).character_toml("dog", model=model.name), encoding="utf-8")
    dog = quadsim.load_character(char)
    motion = quadsim.run(dog, gait="trot", seconds=0.5)
    plain = quadsim.save(motion, tmp_path / "m.bvh", character=dog)
    with pytest.warns(UserWarning, match="units 'cm' do not apply"):
        asked = quadsim.save(motion, tmp_path / "cm.bvh", units="cm", character=dog)
    assert asked.read_text() == plain.read_text()


# ------------------------------------------------------------ the model itself
@pytest.mark.parametrize("kind", [KINDS[0], KINDS[-1]], ids=[KINDS[0].id, KINDS[-1].id])
def test_running_the_model_itself_adopts_it_as_quadsim_rig_would(kind, tmp_path, capsys):
    """`quadsim run MODEL --gait trot --out X` with no character file: the same
    file, byte for byte, as `quadsim rig MODEL` and then running what it wrote,
    and no file left beside the model."""
    from quadsim.cli import main

    spec = kind.spec()
    model = kind.write(spec, tmp_path)
    ext = ".bvh" if kind.fmt == ".bvh" else ".glb"
    before = set(tmp_path.iterdir())
    direct = tmp_path / f"direct{ext}"
    assert main(["run", str(model), "--gait", "trot", "--seconds", "2", "--out",
                 str(direct)]) == 0
    assert set(tmp_path.iterdir()) - before == {direct}
    char = tmp_path / "rigged.toml"
    assert main(["rig", str(model), "--out", str(char)]) == 0
    via = tmp_path / f"via{ext}"
    assert main(["run", str(char), "--gait", "trot", "--seconds", "2", "--out", str(via)]) == 0
    capsys.readouterr()
    assert direct.read_bytes() == via.read_bytes()


def test_running_a_model_with_no_quadruped_says_how_to_set_its_legs(tmp_path, capsys):
    from quadsim.cli import main

    model = write_gltf(_three_legged(quadruped("tripod", style="blender")),
                       tmp_path / "tripod.glb")
    assert main(["run", str(model), "--gait", "trot", "--out", str(tmp_path / "t.glb")]) == 2
    err = capsys.readouterr().err
    assert "no quadruped found" in err and f"quadsim rig {model}" in err
    assert "Traceback" not in err and not (tmp_path / "t.glb").exists()
