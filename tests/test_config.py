"""Run configurations: good files parse to SI values; every bad input names its key."""

import math
import shutil
from pathlib import Path

import pytest

from quadsim.commands import Command, Script
from quadsim.config import RunConfig, load_config, with_overrides
from quadsim.errors import InputError
from quadsim.frames import KMH, MPH
from quadsim.skeleton.character import characters_dir, load_character

REPO = Path(__file__).resolve().parents[1]
SHIPPED = sorted((REPO / "configs").glob("*.toml"))

HEAD = """\
character = "leopard"
duration = 10.0
fps = 60
"""
WALK = """
[[command]]
at = 0.0
speed = 1.0
"""


def write(tmp_path, text, name="run.toml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def leopard_gaits():
    from quadsim.locomotion.gaits import gait_table

    return gait_table(load_character("leopard"))


# ----------------------------------------------------------------- good input
def test_good_config_parses_to_si_values(tmp_path):
    path = write(tmp_path, """\
description = "a test"
character = "leopard"
duration = 12.5
fps = 30
seed = 7
units = "cm"

[[command]]
at = 0.0
speed = 1.0

[[command]]
at = 2.0
speed_kmh = 18.0
turn_rate_deg_s = 30.0

[[command]]
at = 4.0
speed_mph = 10
heading_deg = 90
gait = "gallop"

[[command]]
at = 6.5
gait = "trot"
leap = true
""")
    cfg = load_config(path)
    assert isinstance(cfg, RunConfig)
    assert cfg.character == "leopard"
    assert cfg.duration == 12.5
    assert cfg.fps == 30.0
    assert cfg.seed == 7
    assert cfg.mode == "procedural"
    assert cfg.units == "cm"
    assert cfg.source == path
    assert cfg.description == "a test"
    assert cfg.n_frames == 375
    assert cfg.commands.times == (0.0, 2.0, 4.0, 6.5)
    c0, c1, c2, c3 = cfg.commands.commands
    assert c0 == Command(speed=1.0)
    assert c1.speed == pytest.approx(18.0 * KMH) == pytest.approx(5.0)
    assert c1.turn_rate == pytest.approx(math.radians(30.0))
    assert c1.heading is None and c1.gait is None
    assert c2.speed == pytest.approx(10 * MPH)
    assert c2.heading == pytest.approx(math.pi / 2)
    assert c2.gait == "transverse_gallop"
    assert c3.gait == "trot" and c3.leap
    assert c3.speed == pytest.approx(leopard_gaits()["trot"].preferred_speed)


def test_defaults(tmp_path):
    cfg = load_config(write(tmp_path, HEAD + WALK))
    assert (cfg.seed, cfg.mode, cfg.units, cfg.description) == (0, "procedural", "m", "")
    assert cfg.commands == Script((0.0,), (Command(speed=1.0),))


def test_character_path_is_relative_to_the_config(tmp_path):
    shutil.copy(characters_dir() / "leopard.toml", tmp_path / "my_leopard.toml")
    sub = tmp_path / "configs"
    sub.mkdir()
    path = write(sub, HEAD.replace('"leopard"', '"../my_leopard.toml"') + WALK)
    cfg = load_config(path)
    assert Path(cfg.character) == (tmp_path / "my_leopard.toml").resolve()
    assert cfg.load_character().id == "leopard"


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_shipped_configs_validate(path):
    cfg = load_config(path)
    assert cfg.fps == 60
    assert 20.0 <= cfg.duration <= 30.0
    assert cfg.character == path.stem.removesuffix("_data")
    turns = [abs(c.turn_rate) for c in cfg.commands.commands if c.turn_rate]
    assert turns and max(turns) < math.radians(60.0)


def test_four_shipped_configs():
    assert {p.stem for p in SHIPPED} >= {"leopard", "leopard_cub", "dog_cub", "horse"}


# ------------------------------------------------------------------ bad input
# Each case: the file text, and a regular expression the message must match.
BAD = {
    "unknown top key": (HEAD + 'colour = "spotted"\n' + WALK, r"unknown key `colour`"),
    "unknown command key": (HEAD + WALK + "sped = 2.0\n", r"`command\[0\]\.sped`"),
    "missing character": (HEAD.replace('character = "leopard"\n', "") + WALK,
                          r"missing key `character`"),
    "unknown character": (HEAD.replace('"leopard"', '"unicorn"') + WALK,
                          r"`character`.*unicorn"),
    "missing character file": (HEAD.replace('"leopard"', '"nowhere/cat.toml"') + WALK,
                               r"`character`.*cat\.toml"),
    "missing duration": (HEAD.replace("duration = 10.0\n", "") + WALK,
                         r"missing key `duration`"),
    "zero duration": (HEAD.replace("10.0", "0.0") + WALK, r"`duration`.*0 < duration <= 3600"),
    "long duration": (HEAD.replace("10.0", "4000.0") + WALK, r"`duration`.*<= 3600"),
    "nan duration": (HEAD.replace("10.0", "nan") + WALK, r"`duration` must be a finite"),
    "text duration": (HEAD.replace("10.0", '"10 s"') + WALK, r"`duration` must be a number"),
    "fps zero": (HEAD.replace("fps = 60", "fps = 0") + WALK, r"`fps`.*1 to 1000"),
    "fps too high": (HEAD.replace("fps = 60", "fps = 5000") + WALK, r"`fps`.*1 to 1000"),
    "fps inf": (HEAD.replace("fps = 60", "fps = inf") + WALK, r"`fps` must be a finite"),
    "negative seed": (HEAD + "seed = -1\n" + WALK, r"`seed`.*0 to 2\*\*32"),
    "float seed": (HEAD + "seed = 1.5\n" + WALK, r"`seed`"),
    "unknown mode": (HEAD + 'mode = "dream"\n' + WALK, r"`mode`.*'procedural'"),
    "unknown units": (HEAD + 'units = "ft"\n' + WALK, r"`units`.*'m', 'cm'"),
    "no commands": (HEAD, r"\[\[command\]\]"),
    "command not a table": (HEAD + "command = 3\n", r"`command` must be an array of tables"),
    "first at not zero": (HEAD + WALK.replace("at = 0.0", "at = 1.0"),
                          r"`command\[0\]\.at`.*first command must start at 0"),
    "missing at": (HEAD + WALK.replace("at = 0.0\n", ""), r"command\[0\]: missing key `at`"),
    "at not increasing": (HEAD + WALK + "[[command]]\nat = 0.0\nspeed = 2.0\n",
                          r"`command\[1\]\.at`.*must increase"),
    "at beyond duration": (HEAD + WALK + "[[command]]\nat = 12.0\nspeed = 2.0\n",
                           r"`command\[1\]\.at`.*before the end.*duration = 10"),
    "negative speed": (HEAD + WALK + "[[command]]\nat = 2.0\nspeed = -1.0\n",
                       r"`command\[1\]\.speed`.*allowed 0 to [\d.]+ m/s"),
    "speed too high": (HEAD + WALK.replace("speed = 1.0", "speed = 40.0"),
                       r"`command\[0\]\.speed`.*out of range for leopard"),
    "speed nan": (HEAD + WALK.replace("speed = 1.0", "speed = nan"),
                  r"`command\[0\]\.speed` must be a finite"),
    "speed_mph too high": (HEAD + WALK.replace("speed = 1.0", "speed_mph = 100"),
                           r"`command\[0\]\.speed_mph`.*44\.7 m/s.*allowed 0 to"),
    "two speed units": (HEAD + WALK + "speed_kmh = 3.6\n",
                        r"command\[0\] gives speed and speed_kmh"),
    "no speed or gait": (HEAD + WALK.replace("speed = 1.0", "turn_rate_deg_s = 10.0"),
                         r"command\[0\] needs a speed"),
    "unknown gait": (HEAD + WALK + 'gait = "flying"\n',
                     r"`command\[0\]\.gait` = 'flying'.*allowed: walk, trot"),
    "gait the character lacks": (HEAD + WALK + 'gait = "amble"\n',
                                 r"`command\[0\]\.gait` = 'amble' is not a gait of leopard"),
    "gait not a string": (HEAD + WALK + "gait = 3\n", r"`command\[0\]\.gait` must be a gait"),
    "turn rate too high": (HEAD + WALK + "turn_rate_deg_s = 1000.0\n",
                           r"`command\[0\]\.turn_rate_deg_s`.*-720 to 720 deg/s"),
    "heading too large": (HEAD + WALK + "heading_deg = 400.0\n",
                          r"`command\[0\]\.heading_deg`.*-360 to 360 deg"),
    "turn rate and heading": (HEAD + WALK + "turn_rate_deg_s = 10.0\nheading_deg = 90.0\n",
                              r"command\[0\] gives turn_rate_deg_s and heading_deg"),
    "leap not a bool": (HEAD + WALK + "leap = 1\n", r"`command\[0\]\.leap`.*true or false"),
    "toml syntax": (HEAD + "[[command]]\nat = 0.0\nspeed = \n", r"not valid TOML.*line 6"),
    "shorter than one frame": (HEAD.replace("10.0", "0.01") + WALK,
                               (r"`duration` = 0\.01 s at `fps` = 60 gives less than one frame "
                                r"\(0\.6\); a run needs duration \* fps >= 1, here a duration of "
                                r"at least 0\.01667 s")),
}


@pytest.mark.parametrize("text, pattern", BAD.values(), ids=BAD.keys())
def test_bad_input_names_file_and_key(tmp_path, text, pattern):
    path = write(tmp_path, text)
    with pytest.raises(InputError, match=pattern) as err:
        load_config(path)
    assert str(err.value).startswith(f"{path}: ")


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match=r"nothere\.toml: no such config file"):
        load_config(tmp_path / "nothere.toml")


# ------------------------------------------------------------------ overrides
@pytest.fixture
def config(tmp_path):
    return load_config(write(tmp_path, HEAD + WALK + "[[command]]\nat = 3.0\nspeed = 5.0\n"))


def test_no_override_keeps_the_config(config):
    assert with_overrides(config) is config


def test_override_duration_fps_units(config):
    cfg = with_overrides(config, duration=2.0, fps=30, units="cm")
    assert (cfg.duration, cfg.fps, cfg.units, cfg.n_frames) == (2.0, 30.0, "cm", 60)
    assert cfg.commands == config.commands


def test_override_speed_and_turn_rate(config):
    cfg = with_overrides(config, speed=2.0, turn_rate_deg_s=-45.0)
    assert cfg.commands == Script.constant(Command(speed=2.0, turn_rate=math.radians(-45.0)))


def test_override_gait_alone_uses_its_preferred_speed(config):
    cfg = with_overrides(config, gait="gallop")
    (cmd,) = cfg.commands.commands
    assert cmd.gait == "transverse_gallop"
    assert cmd.speed == pytest.approx(leopard_gaits()["transverse_gallop"].preferred_speed)


def test_override_turn_rate_alone_walks(config):
    (cmd,) = with_overrides(config, turn_rate_deg_s=20.0).commands.commands
    assert cmd.speed == pytest.approx(leopard_gaits()["walk"].preferred_speed)
    assert cmd.gait is None


BAD_FLAGS = {
    "negative speed": ({"speed": -1.0}, r"`--speed` gives -1 m/s"),
    "nan speed": ({"speed": float("nan")}, r"`--speed` must be a finite"),
    "unknown gait": ({"gait": "flying"}, r"`--gait` = 'flying'"),
    "turn rate": ({"turn_rate_deg_s": 1e4}, r"`--turn-rate` = 10000 deg/s"),
    "seconds": ({"duration": 0.0}, r"`--seconds` = 0 is out of range"),
    "fps": ({"fps": 2000}, r"`--fps` = 2000 is out of range"),
    "units": ({"units": "ft"}, r"`--units` = 'ft'"),
    "seconds below one frame": ({"duration": 0.01},
                                (r"`--seconds` = 0\.01 s at the config's `fps` = 60 gives "
                                 r"less than one frame")),
    "seconds and fps below one frame": ({"duration": 0.5, "fps": 1},
                                        (r"`--seconds` = 0\.5 s at `--fps` = 1 gives less "
                                         r"than one frame")),
}


@pytest.mark.parametrize("kw, pattern", BAD_FLAGS.values(), ids=BAD_FLAGS.keys())
def test_bad_override_names_the_flag(config, kw, pattern):
    with pytest.raises(InputError, match=pattern):
        with_overrides(config, **kw)


# ------------------------------------------------------------ at least one frame
def test_one_frame_is_enough(tmp_path):
    cfg = load_config(write(tmp_path, HEAD.replace("10.0", "0.5").replace("60", "2") + WALK))
    assert cfg.n_frames == 1
    assert with_overrides(cfg, duration=1.0, fps=1).n_frames == 1


def test_fps_override_below_one_frame_names_the_config_duration(tmp_path):
    cfg = load_config(write(tmp_path, HEAD.replace("10.0", "0.5") + WALK))
    with pytest.raises(InputError, match=r"the config's `duration` = 0\.5 s at `--fps` = 1 "
                                         r"gives less than one frame"):
        with_overrides(cfg, fps=1)


def test_a_run_config_shorter_than_one_frame_cannot_be_made(tmp_path):
    """However it is built (a file, overrides, or directly), a RunConfig has a frame."""
    cfg = load_config(write(tmp_path, HEAD + WALK))
    with pytest.raises(InputError, match=r"`duration` = 0\.001 s at `fps` = 60 gives less"):
        RunConfig(character="leopard", duration=0.001, fps=60.0, seed=0, mode="procedural",
                  units="m", commands=cfg.commands)


def test_validate_and_run_refuse_a_config_shorter_than_one_frame(tmp_path, capsys):
    from quadsim.cli import main

    short = write(tmp_path, HEAD.replace("10.0", "0.001") + WALK, "short.toml")
    out = tmp_path / "short.bvh"
    assert main(["validate", str(short)]) == 2
    assert main(["run", str(short), "--out", str(out)]) == 2
    good = write(tmp_path, HEAD + WALK, "good.toml")
    assert main(["run", str(good), "--seconds", "0.001", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("gives less than one frame") == 3
    assert "`--seconds` = 0.001 s at the config's `fps` = 60" in err
    assert not out.exists()


# ------------------------------------------------------------ a bad character file
LEOPARD_HOCK = '{ name = "LH_hock", parent = "LH_knee", offset = [0.0, -0.23, -0.12] }'
LEOPARD_PAW = '{ name = "LH_paw", parent = "LH_hock", offset = [0.0, -0.17, 0.01]'


@pytest.mark.parametrize("old, new, pattern", [
    pytest.param(LEOPARD_HOCK, LEOPARD_HOCK.replace("[0.0, -0.23, -0.12]", "[0.0, 0.0, 0.0]"),
                 r"joints\[\d+\]\.offset = \[0\.0, 0\.0, 0\.0\]: joint 'LH_hock' sits on its "
                 r"parent 'LH_knee', a bone of zero length", id="zero-length-bone"),
    pytest.param(LEOPARD_PAW, LEOPARD_PAW.replace("-0.17", "-0.57"),
                 r"legs\.LH: over-long leg: at rest its foot 'LH_paw' is 0\.4 m below the ground",
                 id="over-long-leg"),
    pytest.param("max_turn_rate_deg_s", "max_turn_rate_degs",
                 r"\[locomotion\]: unknown key\(s\) \['max_turn_rate_degs'\]",
                 id="misspelt-key"),
])
def test_validate_catches_a_bad_character_file(tmp_path, capsys, old, new, pattern):
    """A config naming a broken character file fails `validate` with the
    character file and its field, before any run reaches a kernel."""
    from quadsim.cli import main

    text = (characters_dir() / "leopard.toml").read_text(encoding="utf-8")
    assert old in text, f"test setup: {old!r} is not in leopard.toml"
    write(tmp_path, text.replace(old, new, 1), "broken_leopard.toml")
    path = write(tmp_path, HEAD.replace('"leopard"', '"broken_leopard.toml"') + WALK)
    with pytest.raises(InputError, match=r"`character`: .*broken_leopard\.toml: " + pattern):
        load_config(path)
    assert main(["validate", str(path)]) == 2
    assert "broken_leopard.toml" in capsys.readouterr().err


# ------------------------------------------------------------------ data mode gaits
DATA_HEAD = 'character = "horse"\nmode = "data"\nduration = 4.0\nfps = 60\n[[command]]\nat = 0.0\n'


def test_data_mode_gait_without_clips_names_file_key_and_the_clip_gaits(tmp_path):
    """The procedural horse paces; its clip database has no pace: said when reading."""
    path = write(tmp_path, DATA_HEAD + 'speed = 3.0\ngait = "pace"\n')
    with pytest.raises(InputError, match=r"`command\[0\]\.gait` = 'pace' has no clips.*"
                       r"allowed: walk, amble, trot, rack, canter, gallop$") as err:
        load_config(path)
    assert str(err.value).startswith(f"{path}: ")
    # a gait the clips have (gallop, also by its procedural name) reads fine
    for name in ("gallop", "transverse_gallop", "rack"):
        cfg = load_config(write(tmp_path, DATA_HEAD + f'speed = 6.0\ngait = "{name}"\n'))
        assert cfg.commands.commands[0].gait is not None


def test_data_mode_gait_flag_without_clips_names_the_flag(tmp_path):
    cfg = load_config(write(tmp_path, DATA_HEAD + "speed = 3.0\n"))
    with pytest.raises(InputError, match=r"`--gait` = 'pace' has no clips in horse's database"):
        with_overrides(cfg, gait="pace")
    assert with_overrides(cfg, gait="canter").commands.commands[0].gait == "canter"
