"""A striking hoof tipped toe down is pitched about its joint until its toe tip is no deeper
than TOE_DEPTH under the ground: the toe's distance from the joint and its direction across
kept."""

from __future__ import annotations

import numpy as np
import pytest

from quadsim.horse.ground_kernel import MAX_TURN, TOE_DEPTH, toe_onto_ground
from quadsim.kinematics.rotations import matrices_about_axis, matrices_yaw_pitch

FLAT = np.zeros((0, 6))
#: One ramp from x = z = 0 rising along +Z at 10 %.
RAMP = np.array([[0.0, 0.0, 0.0, 0.0, 1.0, 0.1]])
TOE = np.array([0.0, -0.03, 0.09])  # ahead of and under the joint, in the hoof's frame


def _toe(G, P):
    return P + G @ TOE


@pytest.mark.parametrize("ramps", [FLAT, RAMP], ids=["flat", "ramp"])
@pytest.mark.parametrize("yaw", [0.0, 0.7, -2.0])
def test_a_toe_down_hoof_is_pitched_until_its_toe_is_on_the_ground(ramps, yaw):
    from quadsim.horse.ground_kernel import ground_height

    P = np.array([0.3, 0.0, 0.5])
    P[1] = ground_height(ramps, P[0], P[2]) + 0.01   # joint 1 cm up
    G = matrices_yaw_pitch(np.array([yaw]), np.array([0.5]))[0]  # toe down
    before = _toe(G, P)
    assert before[1] < ground_height(ramps, before[0], before[2])
    # a turn of at most MAX_TURN a call: called again on its own result until done
    W, turns = G.copy(), 0
    while turns < 100:
        prev = W.copy()
        if not toe_onto_ground(prev, P, TOE, ramps, W):
            break
        turn = np.arccos(np.clip((np.trace(W @ prev.T) - 1.0) / 2.0, -1.0, 1.0))
        assert turn <= MAX_TURN + 1e-9
        turns += 1
    assert 5 < turns < 100
    after = _toe(W, P)
    assert after[1] == pytest.approx(ground_height(ramps, after[0], after[2]) - TOE_DEPTH,
                                    abs=1e-4)
    assert np.allclose(W @ W.T, np.eye(3), atol=1e-12) and np.linalg.det(W) > 0
    d0, d1 = before - P, after - P
    assert np.linalg.norm(d1) == pytest.approx(np.linalg.norm(d0), rel=1e-12)
    # turned in the toe's vertical plane: its heading across the ground is kept
    h0, h1 = d0[[0, 2]] / np.linalg.norm(d0[[0, 2]]), d1[[0, 2]] / np.linalg.norm(d1[[0, 2]])
    assert h0 @ h1 == pytest.approx(1.0, abs=1e-12)


def test_a_hoof_whose_toe_is_on_or_above_the_ground_is_left_as_it_is():
    P = np.array([0.0, 0.05, 0.0])
    G = matrices_about_axis(1, np.array([0.4]))[0]
    W = np.empty((3, 3))
    assert not toe_onto_ground(G, P, TOE, FLAT, W)
    assert _toe(G, P)[1] >= 0.0
    assert np.array_equal(W, G)
