"""An adopted rig steps like the built-in characters (issue "Your own quadruped").

The same checks as ``test_locomotion_quality``'s steady gaits, on a user's rig:
each gait of the adopted character (its speeds scaled by hip height through the
Froude number, as ``quadsim rig`` writes them) held at its preferred speed for
10 s realises its footfall table (duty factors and phases within 0.05), moves
at the asked speed, and its planted feet neither slide nor sink by more than
5 mm -- measured from the motion's joint world positions. The rigs: the Khronos
Fox (``../shared/assets/fox``, skipped when absent) and a Blender-style dog
built here (Z up, centimetres, face and helper bones).
"""

from __future__ import annotations

import warnings
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from quadsim.analysis import metrics as M
from quadsim.api import adopted_character_file
from quadsim.commands import Command
from quadsim.locomotion import simulate
from quadsim.locomotion.gaits import gait_table
from quadsim.skeleton.character import load_character
from rig_builders import quadruped, write_gltf

FPS = 60
SLIDE_LIMIT = 0.005       # m, as the built-in characters'
PENETRATION_LIMIT = 0.005  # m
FOX = Path(__file__).resolve().parents[2] / "shared" / "assets" / "fox" / "Fox.gltf"
#: The gaits checked: the automatic ones a user's quadruped walks, trots, canters and
#: gallops through (the table's phases; the pace's and rack's are the same test).
GAITS = ("walk", "trot", "canter", "transverse_gallop")


@cache
def _character(kind: str, folder: str):
    if kind == "fox":
        if not FOX.is_file():
            pytest.skip("the Fox test rig is not on this machine (../shared/assets/fox)")
        model = FOX
    else:
        model = write_gltf(quadruped("dog", style="blender", hind_bones=3, scapula=True),
                           Path(folder) / "dog.glb", up="Z", unit="cm")
    return load_character(adopted_character_file(model))


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return str(tmp_path_factory.mktemp("rig_gaits"))


def _cases():
    for kind in ("fox", "blender_dog"):
        for gait in GAITS:
            yield pytest.param(kind, gait, id=f"{kind}-{gait}")


@pytest.mark.parametrize("kind,gait", list(_cases()))
def test_an_adopted_rig_realises_each_gaits_footfall_table(kind, gait, folder):
    ch = _character(kind, folder)
    table = gait_table(ch)
    if gait not in table:
        pytest.skip(f"{kind} has no {gait}")
    g = table[gait]
    v = g.preferred_speed
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = simulate(ch, Command(speed=v, gait=gait), 14.0, FPS).time_slice(4.0, 15.0)
    feet = m.foot_positions()
    contacts = M.foot_contacts(feet, FPS)
    duty = M.duty_factors(contacts, FPS, feet)
    phase = M.phases(contacts, FPS, feet)
    assert np.all(np.abs(duty - g.duty(v)) < 0.05), (duty, g.duty(v))
    dist = np.abs(np.mod(np.asarray(phase) - np.asarray(g.phases) + 0.5, 1.0) - 0.5)
    assert np.all(dist < 0.05), (phase, g.phases)
    speed, _ = M.root_speed(m.root_positions, FPS)
    assert abs(speed / v - 1.0) < 0.05, (speed, v)
    slide = M.foot_slide(feet, contacts)[1]
    assert slide < SLIDE_LIMIT, slide
    assert M.ground_penetration(feet) < PENETRATION_LIMIT
