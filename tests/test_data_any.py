"""The data mode on characters other than the horse, playing databases cut from takes.

The dog cub's database is cut by `quadsim clips-from` from noisy takes on
another skeleton (:mod:`take_builders`), named in a copy of its character
file (``[character] clips``) and played by ``quadsim run ... --mode data``
and :func:`quadsim.simulate`: through every ordered pair of its four gaits
the stance feet stay within 5 mm (contacts measured from the produced foot
positions). An adopted rig plays its own database likewise.
"""

from __future__ import annotations

import itertools
import warnings

import pytest

import quadsim
from quadsim.analysis.metrics import foot_contacts, foot_slide
from quadsim.cli import main
from quadsim.commands import Command, Script
from quadsim.errors import InputError, QuadsimClampWarning
from quadsim.horse.controller import HorseDataController
from quadsim.horse.playback import ClipPlayer, gait_law
from quadsim.horse.speed import clip_contact_time, hoyt_law
from quadsim.io.clips import clip_folder, load_database
from quadsim.skeleton.character import characters_dir, load_character
from take_builders import noisy, on_other_skeleton, take, write_take

PLANS = ([("walk", 0.5), ("trot", 1.4), ("canter", 2.4), ("rotary_gallop", 3.6)],
         [("walk", 0.8), ("trot", 2.0), ("canter", 3.0), ("rotary_gallop", 4.6)])
GAITS = ("walk", "trot", "canter", "rotary_gallop")
#: A speed inside each gait's clips (m/s).
SPEED = {"walk": 0.65, "trot": 1.7, "canter": 2.7, "rotary_gallop": 4.0}
PAIRS = list(itertools.permutations(GAITS, 2))
def _character_with_clips(folder, clips: str, ident: str = "my_dog"):
    text = (characters_dir() / "dog_cub.toml").read_text(encoding="utf-8")
    text = text.replace('id = "dog_cub"', f'id = "{ident}"\nclips = "{clips}"', 1)
    path = folder / f"{ident}.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def my_dog(tmp_path_factory):
    """A copy of the dog cub's file naming a database cut from noisy takes."""
    tmp = tmp_path_factory.mktemp("my_dog")
    dog = load_character("dog_cub")
    paths = []
    for k, plan in enumerate(PLANS):
        m = on_other_skeleton(noisy(take(dog, plan), deg=0.2, root=0.001, seed=k))
        paths.append(str(write_take(m, tmp / f"take{k}.bvh", units="cm")))
    assert main(["clips-from", *paths, "--character", "dog_cub", "--out",
                 str(tmp / "clips")]) == 0
    return _character_with_clips(tmp, "clips")


def _slide_and_contacts(motion):
    """The largest stance slide of the toe tips (what a viewer sees of a planted foot;
    the foot joint is what the placement pins), the contacts measured from the feet,
    and the foot positions."""
    from quadsim.analysis.appearance import toe_positions

    f = motion.foot_positions()
    c = foot_contacts(f, motion.fps)
    return max(foot_slide(f, c)[1], foot_slide(toe_positions(motion), c)[1]), c, f


@pytest.mark.parametrize("pair", PAIRS, ids=[f"{a}-{b}" for a, b in PAIRS])
def test_every_ordered_gait_pair_keeps_stance_feet_within_5mm(my_dog, pair):
    a, b = pair
    script = Script((0.0, 2.5), (Command(speed=SPEED[a], gait=a), Command(speed=SPEED[b], gait=b)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", QuadsimClampWarning)
        m = quadsim.simulate(str(my_dog), script, seconds=5.5, mode="data")
    slide, c, f = _slide_and_contacts(m)
    assert slide < 0.005, f"{a} -> {b}: a stance toe slides {slide * 1000:.2f} mm"
    labels = set(m.gaits)
    assert {a, b, f"{a}->{b}"} <= labels, labels
    half = int(2.5 * m.fps)
    assert c[:half].any(axis=0).all() and c[half:].any(axis=0).all()   # every foot steps
    assert f[..., 1].min() > -0.005                                    # and none sinks
    travel = m.root_positions[-1, 2] - m.root_positions[0, 2]
    assert travel > 0.5 * (SPEED[a] + SPEED[b]) * 5.5 * 0.6


def test_quadsim_run_plays_the_database_the_character_file_names(my_dog, tmp_path, capsys):
    out = tmp_path / "trot.bvh"
    assert main(["run", str(my_dog), "--mode", "data", "--speed", "1.8", "--seconds", "3",
                 "--out", str(out)]) == 0
    assert "data mode" in capsys.readouterr().out
    m = quadsim.run(str(my_dog), mode="data", speed=1.8, seconds=3)
    assert set(m.gaits) == {"trot"}
    assert foot_slide(m.foot_positions(), foot_contacts(m.foot_positions(), m.fps))[1] < 0.005


def test_the_gaits_by_speed_are_the_characters_own(my_dog):
    ch = load_character(my_dog)
    db = load_database(clip_folder(ch), ch)
    ctl = HorseDataController(ch, db)
    assert ctl.auto_gaits == ["walk", "trot", "canter", "rotary_gallop"]
    assert ctl.stop_gait == "walk" and ctl.stop_speed == pytest.approx(min(
        1.0, db.by_gait("walk")[0].speed))
    player = ClipPlayer(ch, db)
    assert [player.gait_for(v, None) for v in (0.6, 1.6, 2.6, 4.2)] == list(GAITS)


def test_expanded_clips_follow_the_databases_own_law(my_dog):
    """Within 15 % of the law, or within one frame: a stance is measured in whole frames,
    and the gallop's spans 4-5 at 60 fps (a frame is 23 % of it)."""
    ch = load_character(my_dog)
    db = load_database(clip_folder(ch), ch)
    player = ClipPlayer(ch, db)
    for g, v in (("walk", 0.6), ("trot", 1.7), ("canter", 2.7), ("rotary_gallop", 4.1)):
        law = gait_law(db, g)
        assert law is db.laws[g]
        clip = player.expanded(g, v)
        tc, want = clip_contact_time(clip), float(law.contact_time(v))
        assert abs(tc - want) < max(0.15 * want, 1.0 / clip.motion.fps), (g, v, tc, want)


def test_make_controller_steps_the_characters_database(my_dog):
    ctl = quadsim.make_controller(str(my_dog), mode="data", dt=1 / 60)
    frames = [ctl.step(Command(speed=2.7)) for _ in range(120)]
    assert frames[-1].gait == "canter" and ctl.speed == pytest.approx(2.7, rel=0.03)
    assert frames[-1].positions[:, 1].min() > -0.005


def test_the_preview_plays_the_characters_database(my_dog, tmp_path):
    from quadsim.viz.preview import Preview

    p = Preview(str(my_dog), mode="data", off_screen=True, size=(160, 120),
                record_dir=tmp_path / "rec")
    try:
        assert p.gait_order == list(GAITS)
        for _ in range(90):
            p.update(1 / 60)
        assert p.gait == "walk" and p.world_positions[0][2] > 0.2
    finally:
        p.close()


def test_it_stops_square_and_ignores_a_leap_it_has_no_clip_for(my_dog):
    ch = load_character(my_dog)
    script = Script((0.0, 1.0, 2.5), (Command(speed=1.7), Command(speed=1.7, leap=True),
                                      Command(speed=0.0)))
    with pytest.warns(QuadsimClampWarning, match="no leap clip"):
        m = quadsim.simulate(ch, script, seconds=6.0, mode="data")
    assert m.gaits[-1] == "stand" and m.contacts[-10:].all()
    assert "leap" not in set(m.gaits)


def test_the_horse_keeps_table_1(horse, db):
    assert db.laws == {}
    assert gait_law(db, "walk") == hoyt_law("walk")
    assert gait_law(db, "gallop").anchor == "clip" and gait_law(db, "amble").anchor == "clip"
    assert HorseDataController(horse, db).auto_gaits == ["walk", "trot", "canter", "gallop"]


def test_an_adopted_rig_plays_its_own_database(tmp_path):
    from quadsim.io.adopt import write_for_character
    from rig_builders import quadruped, write_bvh_rig

    model = write_bvh_rig(quadruped("wolf", style="blender", hip=0.6, hind_bones=3, root=False),
                          tmp_path / "wolf.bvh", up="Z", unit="cm")
    char = tmp_path / "wolf.toml"
    assert main(["rig", str(model), "--out", str(char)]) == 0
    wolf = load_character(char)
    plans = [[("walk", 1.0), ("trot", 2.4), ("canter", 3.6)],
             [("walk", 1.4), ("trot", 3.2), ("canter", 4.4)]]
    takes = [str(write_for_character(wolf, take(wolf, p), tmp_path / f"t{k}.bvh"))
             for k, p in enumerate(plans)]
    assert main(["clips-from", *takes, "--character", str(char), "--out",
                 str(tmp_path / "clips")]) == 0
    char.write_text(char.read_text(encoding="utf-8").replace(
        "[character]\n", '[character]\nclips = "clips"\n', 1), encoding="utf-8")
    script = Script((0.0, 2.5, 5.0), (Command(speed=1.2), Command(speed=2.8), Command(speed=4.0)))
    m = quadsim.simulate(str(char), script, seconds=7.5, mode="data")
    slide, _, _ = _slide_and_contacts(m)
    assert slide < 0.005 and {"walk", "trot", "canter"} <= set(m.gaits)
    out = tmp_path / "run.bvh"                      # written in the user's own hierarchy
    assert main(["run", str(char), "--mode", "data", "--speed", "2.8", "--seconds", "2",
                 "--out", str(out)]) == 0
    assert "thigh.L.001" in out.read_text(encoding="utf-8")


# ------------------------------------------------------------------ the `clips` key
def test_the_clips_key_must_name_a_clip_database(tmp_path):
    bad = _character_with_clips(tmp_path, "nowhere", "lost_dog")
    with pytest.raises(InputError, match=r"character\.clips: no clip database.*clips-from"):
        load_character(bad)
    text = bad.read_text(encoding="utf-8").replace('clips = "nowhere"', "clips = 3")
    bad.write_text(text, encoding="utf-8")
    with pytest.raises(InputError, match=r"character\.clips must be the path"):
        load_character(bad)


def test_data_mode_without_a_database_points_to_clips_from(capsys):
    assert main(["run", "dog_cub", "--mode", "data", "--seconds", "1"]) == 2
    err = capsys.readouterr().err
    assert "clips-from" in err and "clips = " in err


def test_a_manifest_law_is_checked(tmp_path, my_dog):
    import shutil

    ch = load_character(my_dog)
    folder = tmp_path / "clips"
    shutil.copytree(clip_folder(ch), folder)
    man = folder / "manifest.toml"
    man.write_text(man.read_text(encoding="utf-8") + "\n[laws.amble]\na = -1\nb = -0.5\n",
                   encoding="utf-8")
    with pytest.raises(InputError, match=r"laws\.amble: `a` must be a positive number"):
        load_database(folder, ch)
