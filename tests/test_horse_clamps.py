"""The data-driven horse says what it clamps: each distinct clamp of a command once.

A speed beyond what a gait's clips are played at, or a turn rate beyond what
the horse turns at, is played clamped; the clamp is said as a
:class:`~quadsim.errors.QuadsimClampWarning` naming the value asked for and
the cap, once per distinct clamp (not once per frame, and not only the first
of a kind).
"""

import math
import warnings

import pytest

from quadsim.cli import main
from quadsim.commands import Command
from quadsim.errors import QuadsimClampWarning
from quadsim.horse.controller import HorseDataController


def _said(ctl, commands, frames=30):
    """Step ``frames`` frames under each command in turn; the clamp messages said."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for cmd in commands:
            for _ in range(frames):
                ctl.step(cmd)
    return [str(w.message) for w in caught if issubclass(w.category, QuadsimClampWarning)]


def test_a_speed_beyond_the_gallop_clips_is_clamped_and_said_once(horse, db):
    ctl = HorseDataController(horse, db)
    cap = ctl.gait_speed_cap("gallop")
    assert cap < 20.0
    said = _said(ctl, [Command(speed=20.0)], frames=120)
    assert len(said) == 1
    assert "20 m/s" in said[0] and f"{cap:.3g} m/s" in said[0] and "gallop" in said[0]
    assert ctl.speed == pytest.approx(cap, rel=0.03)          # played at the cap


def test_each_distinct_speed_clamp_is_said(horse, db):
    ctl = HorseDataController(horse, db)
    walk_cap = ctl.gait_speed_cap("walk")
    said = _said(ctl, [Command(speed=20.0), Command(speed=25.0), Command(speed=20.0),
                       Command(speed=4.0, gait="walk")], frames=20)
    assert len(said) == 3, said
    assert "20 m/s" in said[0] and "25 m/s" in said[1]
    assert "4 m/s" in said[2] and "walk" in said[2] and f"{walk_cap:.3g} m/s" in said[2]


def test_a_speed_within_the_clips_is_not_a_clamp(horse, db):
    ctl = HorseDataController(horse, db)
    assert _said(ctl, [Command(speed=4.0), Command(speed=11.0), Command(speed=0.0)]) == []


def test_each_distinct_turn_rate_clamp_is_said_once(horse, db):
    ctl = HorseDataController(horse, db)
    fast, faster = math.radians(200.0), math.radians(300.0)
    said = _said(ctl, [Command(speed=4.0), Command(speed=4.0, turn_rate=fast),
                       Command(speed=4.0, turn_rate=fast), Command(speed=4.0, turn_rate=faster)],
                 frames=40)
    assert len(said) == 2, said
    assert "200.0 deg/s" in said[0] and "300.0 deg/s" in said[1]
    assert all("clamped" in s for s in said)


def test_the_cli_prints_the_speed_clamp(tmp_path, capsys):
    cfg = tmp_path / "fast.toml"
    cfg.write_text('character = "horse"\nmode = "data"\nduration = 1.0\nfps = 30\n'
                   '[[command]]\nat = 0.0\nspeed = 19.0\n', encoding="utf-8")
    assert main(["run", str(cfg), "--out", str(tmp_path / "fast.bvh")]) == 0
    err = capsys.readouterr().err
    assert "warning: speed 19 m/s is beyond the fastest the gallop clips" in err
