"""Robot references played back in PyBullet on the robots it ships (A1, Laikago, Mini Cheetah).

Skipped without pybullet (``pip install "quadsim[robots]"``; wheels for Python
3.11 and older). Each reference is a 6 s trot of the dog cub at 1.0 m/s robot
speed, written by ``quadsim retarget`` and played kinematically (see
tests/robot_playback.py): toes on the ground and not sinking, planted toes
still, diagonal pairs together, joint limits kept, no self-collision, forward
travel.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pybullet_data = pytest.importorskip("pybullet_data")

from quadsim.cli import main  # noqa: E402

from robot_playback import figures, play  # noqa: E402

ROBOTS = {"a1": "a1/a1.urdf", "laikago": "laikago/laikago_toes.urdf",
          "laikago_zup": "laikago/laikago_toes_zup.urdf",
          "laikago_limits": "laikago/laikago_toes_limits.urdf",
          "mini_cheetah": "mini_cheetah/mini_cheetah.urdf"}


@pytest.fixture(scope="module")
def played(tmp_path_factory):
    cache = {}

    def get(robot):
        if robot not in cache:
            urdf = str(Path(pybullet_data.getDataPath()) / ROBOTS[robot])
            out = tmp_path_factory.mktemp(robot) / "trot.npz"
            assert main(["retarget", "dog_cub", "--robot", urdf, "--gait", "trot",
                         "--speed", "1.0", "--seconds", "6", "--out", str(out)]) == 0
            ref = dict(np.load(out))
            cache[robot] = ref, figures(ref, play(urdf, ref))
        return cache[robot]
    return get


@pytest.mark.parametrize("robot", list(ROBOTS))
def test_a_trot_reference_plays_on_the_robot(played, robot):
    ref, f = played(robot)
    assert len(ref["frames"]) == 360
    assert f["lowest_toe_max"] < 0.01      # some toe on the ground on every frame
    assert f["sink_max"] < 1e-3            # and none sinks into it
    assert f["planted_gap_max"] < 1e-3     # a planted toe touches the ground
    assert f["slide_max"] < 0.01           # and stays where it landed
    assert f["diagonal_agreement"] > 0.9   # LF with RH, RF with LH
    assert f["limit_margin_min"] >= 0.0    # PyBullet's own joint limits
    assert f["self_collisions"] == 0
    assert f["forward_travel"] > 4.0 and f["lateral_drift"] < 0.1


def test_the_json_frames_are_the_npz_frames(tmp_path):
    urdf = str(Path(pybullet_data.getDataPath()) / ROBOTS["a1"])
    assert main(["retarget", "dog_cub", "--robot", urdf, "--seconds", "1", "--out",
                 str(tmp_path / "a1.json")]) == 0
    assert main(["retarget", "dog_cub", "--robot", urdf, "--seconds", "1", "--out",
                 str(tmp_path / "a1.npz")]) == 0
    data = json.loads((tmp_path / "a1.json").read_text(encoding="utf-8"))
    z = np.load(tmp_path / "a1.npz")
    assert data["JointNames"] == list(z["joint_names"])
    assert np.allclose(np.array(data["Frames"]), z["frames"], atol=1e-6)
