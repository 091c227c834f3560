"""Long runs under random commands: the engine stays finite, bounded and above ground.

A property-based test (hypothesis, derandomised so CI is repeatable) draws
command sequences -- speeds from standing to beyond the fastest gait, turn
rates beyond the maximum, explicit gaits and automatic choice, changing every
0.2 to 4 s -- and checks the produced motion. CI runs a few minutes of
simulated time; ``QUADSIM_LONG=1`` runs a full hour per character.
"""

from __future__ import annotations

import math
import os
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from quadsim import list_characters, load_character
from quadsim.analysis import metrics as M
from quadsim.locomotion import Command, ProceduralController, simulate
from quadsim.locomotion.offline import stack_plans
from quadsim.locomotion.gaits import gait_table, max_speed
from quadsim.skeleton.anatomy import find_anatomy
from quadsim.skeleton.fk import forward_kinematics

FPS = 60
LONG = os.environ.get("QUADSIM_LONG") == "1"


def commands_for(character):
    ch = load_character(character)
    gaits = [None] + list(gait_table(ch))
    top = max_speed(ch)
    return st.lists(
        st.tuples(
            st.floats(0.2, 4.0),  # how long the command holds (s)
            st.floats(0.0, 1.3 * top),  # speed, sometimes beyond the fastest gait
            st.floats(-4.0, 4.0),  # turn rate (rad/s), sometimes beyond the maximum
            st.sampled_from(gaits),
        ),
        min_size=3, max_size=40,
    )


def run_and_check(character, segments, seconds):
    ch = load_character(character)
    ctl = ProceduralController(ch, dt=1.0 / FPS, seed=7)
    foot_idx = ch.skeleton.indices(ch.foot_joints)
    n = int(seconds * FPS)
    times = np.cumsum([s[0] for s in segments])
    chunk: list[dict] = []
    lowest, peak_amp = np.inf, 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # clamping warnings are expected here
        for k in range(n):
            t = (k / FPS) % times[-1]
            _, v, w, g = segments[int(np.searchsorted(times, t, side="right"))
                                  if t < times[-1] else -1]
            chunk.append(ctl.plan_step(Command(speed=v, turn_rate=w, gait=g)))
            if len(chunk) == 1800 or k == n - 1:
                plan = stack_plans(chunk)
                local, root, _ = ctl.pose(plan)
                assert np.all(np.isfinite(local)) and np.all(np.isfinite(root))
                _, P = forward_kinematics(ch.skeleton, local, root)
                assert np.all(np.isfinite(P))
                lowest = min(lowest, float(P[:, foot_idx, 1].min()))
                peak_amp = max(peak_amp, float(np.abs(plan["amplitude"]).max()))
                chunk = []
    assert lowest > -0.005, f"a foot went {-lowest * 1000:.1f} mm below the ground"
    assert peak_amp < 1.5, f"CPG amplitude reached {peak_amp}"
    assert math.isfinite(ctl.heading) and ctl.speed <= max_speed(ch) + 1e-9


@pytest.mark.parametrize("character", list_characters())
def test_random_commands_keep_the_motion_finite_bounded_and_above_ground(character):
    @settings(max_examples=2, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(segments=commands_for(character))
    def check(segments):
        run_and_check(character, segments, 30.0)

    check()


@pytest.mark.slow
@pytest.mark.skipif(not LONG, reason="hour-long soak; set QUADSIM_LONG=1")
@pytest.mark.parametrize("character", list_characters())
def test_one_hour_of_random_commands(character):
    @settings(max_examples=1, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(segments=commands_for(character))
    def check(segments):
        run_and_check(character, segments, 3600.0)

    check()


#: A steady command's motion, over three minutes, in windows of this many seconds.
STEADY_WINDOW = 20.0
#: Known: the dog cub's trot and pace stride 21.998 frames at 60 fps and the leopard
#: cub's transverse gallop 16.004 (the other steady gaits are 0.01-0.12 frames off a
#: whole, half, third or quarter number but for the leopard's pace, 30.502, which
#: measures steady), so the frames fall at nearly the same phase of every stride
#: for minutes and drift across a whole frame in about three: the trunk's mean height
#: depends on that phase (the dog cub's trot 275.6-280.2 mm per 20 s; the same
#: frame-rate dependence shows as the trunk's mean height at 240 fps up to 6 mm under
#: the 60 fps one in the trots, up to 21 mm in the leopard's transverse gallop), and so, by
#: 0.4 of a frame, does the time a trotting or pacing foot stays down.
UNSTEADY = {
    ("dog_cub", "trot"): "trunk 4.5 mm, time down 0.018",
    ("dog_cub", "pace"): "trunk 7.7 mm, time down 0.022",
    ("leopard_cub", "transverse_gallop"): "trunk 8.6 mm",
}


def share_of_time_down(stances, start, seconds, end):
    """The feet's share of the time from ``start`` for ``seconds`` (s) that they
    are down, from :func:`~quadsim.analysis.metrics.stance_intervals`'
    ``[touchdown, lift-off]`` times (a contact cut by the clip, NaN, runs to the
    clip's start or ``end``)."""
    down = 0.0
    for leg in stances:
        on = np.nan_to_num(leg[:, 0], nan=0.0)
        off = np.nan_to_num(leg[:, 1], nan=end)
        down += float(np.clip(np.minimum(off, start + seconds) - np.maximum(on, start),
                              0.0, None).sum())
    return down / (len(stances) * seconds)


@pytest.mark.parametrize("character,gait", [
    pytest.param(c, g, marks=pytest.mark.xfail((c, g) in UNSTEADY, strict=True,
                                               reason=UNSTEADY.get((c, g), "")))
    for c in list_characters()
    for g in ("walk", "trot", "pace", "canter", "transverse_gallop")
    if g in gait_table(load_character(c))])
def test_a_steady_command_keeps_its_gait_steady_for_minutes(character, gait):
    """A user steering a character live holds a command for minutes: over three
    minutes at a gait's preferred speed (after 4 s of start-up), the trunk's mean
    height (the pelvis's and withers' mean, from the joints) differs by at most 3 mm
    and the feet's share of the time down (toe tips planted; each contact's touchdown
    and lift-off refined below a frame from the toe tips' positions) by at most 0.01
    between windows of 20 s. (Measured: at most 1.9 mm and 0.0065 but for the known
    cases. Counted in whole frames, a stride of 21.998 frames at 60 fps showed 8 or 9
    frames of an 8.25-frame stance for a minute at a time: 0.046 between windows
    whatever the motion.)"""
    ch = load_character(character)
    v = gait_table(ch)[gait].preferred_speed
    m = simulate(ch, Command(speed=v, gait=gait), 184.0, FPS).time_slice(4.0, 185.0)
    a = find_anatomy(m.skeleton, m.foot_joints)
    y = m.world_positions()[:, [a.pelvis, a.withers], 1].mean(axis=1)
    feet = m.contact_points()
    stances = M.stance_intervals(M.foot_contacts(feet, FPS), FPS, feet)
    w = int(STEADY_WINDOW * FPS)
    starts = range(0, len(y) - w + 1, w)
    heights = [float(y[k:k + w].mean()) for k in starts]
    shares = [share_of_time_down(stances, k / FPS, STEADY_WINDOW, len(y) / FPS)
              for k in starts]
    assert len(heights) == 9
    assert max(heights) - min(heights) <= 0.003, heights
    assert max(shares) - min(shares) <= 0.01, shares
