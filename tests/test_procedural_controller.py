"""The procedural controller behind the one controller interface.

Specification: :class:`ProceduralController` is a
:class:`quadsim.controller.Controller`; ``step(command, dt)`` returns a
read-only :class:`quadsim.controller.Frame` at the controller's new time
with the procedural extras; the limits it reports are the ones its steps
apply; the gait ids are the gait table's, so a gait added to the table is
known without code; leaving the standing state takes 0.6 s, any other
change 1.5 strides within [0.5, 2] s.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from quadsim.commands import Command
from quadsim.controller import Controller, Frame
from quadsim.errors import QuadsimClampWarning
from quadsim.locomotion import ProceduralController
from quadsim.locomotion.gaits import STAND, gait_ids, gait_names, gait_table
from quadsim.locomotion.tables import standing
from quadsim.locomotion.transition import (
    MAX_TRANSITION_TIME,
    MIN_TRANSITION_TIME,
    STAND_TRANSITION_TIME,
    TRANSITION_STRIDES,
    GaitScheduler,
)
from quadsim.skeleton.character import load_character


def test_it_is_a_controller_with_the_protocol_attributes():
    ch = load_character("horse")
    ctl = ProceduralController(ch, dt=1 / 50)
    assert isinstance(ctl, Controller)
    assert ctl.mode == "procedural" and ctl.ground is None and ctl.dt == 1 / 50
    assert ctl.time == 0.0 and ctl.gait == STAND and ctl.speed == 0.0 and ctl.heading == 0.0
    assert ctl.gait_order == list(ch.locomotion["gaits"])[:9]
    assert ctl.auto_gaits == ["walk", "trot", "canter", "transverse_gallop"]
    table = gait_table(ch)
    assert ctl.max_speed == max(g.speed_range[1] for g in table.values())
    assert ctl.preferred_speed("gallop") == table["transverse_gallop"].preferred_speed
    assert ctl.gait_speed_cap("walk") == pytest.approx(1.15 * table["walk"].speed_range[1])
    assert ctl.gait_speed_cap("transverse_gallop") == ctl.max_speed  # never above the top


def test_step_returns_a_read_only_frame_with_the_procedural_extras():
    ch = load_character("leopard")
    ctl = ProceduralController(ch)
    for k in range(1, 91):
        f = ctl.step(Command(speed=2.0, turn_rate=0.2))
        assert isinstance(f, Frame) and f.time == pytest.approx(k / 60)
    J = ch.skeleton.n_joints
    assert f.local_rotations.shape == (J, 3, 3) and f.positions.shape == (J, 3)
    np.testing.assert_array_equal(f.root, f.positions[0])
    assert f.gait == ctl.gait and f.speed == ctl.speed and f.heading == ctl.heading
    assert f.contacts.dtype == bool and f.contacts.shape == (4,)
    shapes = {"phase": (4,), "spine": (), "duty": (), "speed": (), "heading": (),
              "feet": (4, 3), "ik_error": (4,), "cpg_amplitude": (5,)}
    assert {k: v.shape for k, v in f.extras.items()} == shapes
    assert np.all((f.extras["phase"] >= 0) & (f.extras["phase"] < 1))
    with pytest.raises(ValueError):
        f.positions[0, 0] = 1.0
    # the frame is a copy: the next step leaves it as it was
    before = f.positions.copy()
    ctl.step(Command(speed=2.0))
    np.testing.assert_array_equal(f.positions, before)


def test_a_requested_gait_is_held_up_to_its_cap_and_the_cap_is_what_the_step_applies():
    ctl = ProceduralController(load_character("leopard"), gait="trot")
    cap = ctl.gait_speed_cap("trot")
    cmd = Command(speed=50.0, gait="trot")
    with pytest.warns(QuadsimClampWarning, match="clamped"):
        f = ctl.step(cmd)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # said once: no more warnings
        for _ in range(600):
            f = ctl.step(cmd)
    assert f.gait == "trot" and f.speed == pytest.approx(cap, rel=1e-6)


def test_gait_ids_come_from_the_gait_table():
    ids = gait_ids()
    assert ids[:-1] == gait_names() and ids[-1] == STAND
    assert {"walk", "trot", "amble", "rack", "rotary_gallop"} <= set(ids)
    assert len(set(ids)) == len(ids)


@pytest.fixture(scope="module")
def horse_gaits():
    ch = load_character("horse")
    gaits = dict(gait_table(ch))
    gaits[STAND] = standing(gaits["walk"])
    return gaits


def test_leaving_the_standing_state_takes_its_own_transition_time(horse_gaits):
    s = GaitScheduler(horse_gaits, ["walk", "trot"], STAND)
    s.update("walk", 0.5, 1 / 60, 0.9)
    assert s.label == "stand->walk" and s.duration == STAND_TRANSITION_TIME
    for period, want in ((0.2, MIN_TRANSITION_TIME), (0.9, TRANSITION_STRIDES * 0.9),
                         (3.0, MAX_TRANSITION_TIME)):
        s = GaitScheduler(horse_gaits, ["walk", "trot"], "walk")
        s.update("trot", 3.0, 1 / 60, period)
        assert s.label == "walk->trot" and s.duration == pytest.approx(want)


@pytest.mark.parametrize("gait", ["walk", "trot", "transverse_gallop"])
def test_the_plans_load_is_a_planted_feet_half_sine_of_the_body_weight(gait):
    """The plan's ``load`` (what a digit sinks under, ``fetlock_sink_deg``): 0 for a
    swinging foot; through a stance it rises from near 0 to about ``pi / (8 duty)`` of
    the body's weight (the peak of a half sine of force that carries a quarter of
    the weight over a stride) and falls back (``sin^2`` of the way through: a gallop's
    stance of six frames samples it at a quarter of its peak on its first and last)."""
    ch = load_character("horse")
    g = gait_table(ch)[gait]
    ctl = ProceduralController(ch, dt=1 / 60, gait=gait)
    plans = [ctl.plan_step(Command(speed=g.preferred_speed, gait=gait)) for _ in range(600)]
    load = np.array([p["load"] for p in plans[240:]])
    down = np.array([p["contacts"] for p in plans[240:]])
    duty = np.array([p["duty"] for p in plans[240:]]).mean()
    assert (load[~down] == 0.0).all() and (load >= 0.0).all()
    peak = np.pi / (8.0 * duty)
    for leg in range(4):
        edges = np.flatnonzero(np.diff(down[:, leg].astype(int)))
        for a, b in zip(edges[:-1], edges[1:]):
            if not down[a + 1, leg]:
                continue
            stance = load[a + 1:b + 1, leg]
            assert stance.max() == pytest.approx(peak, rel=0.08), (leg, stance.max(), peak)
            assert stance[0] < 0.3 * peak and stance[-1] < 0.3 * peak, stance
            top = int(np.argmax(stance))
            assert (np.diff(stance[:top + 1]) > 0).all() and (np.diff(stance[top:]) < 0).all()
