"""The data-driven horse controller (quadsim.horse.controller), measured on its motion."""

import math
from pathlib import Path

import numpy as np
import pytest

from quadsim.analysis.metrics import (
    angular_acceleration,
    duty_factors,
    foot_contacts,
    foot_slide,
    phases,
    stance_intervals,
    stride_table,
)
from quadsim.cli import main
from quadsim.config import load_config
from quadsim.errors import InputError
from quadsim.horse.controller import HorseDataController, simulate
from quadsim.horse.steering import TURN_PER_STANCE
from quadsim.controller import Controller, Frame
from quadsim.horse.database import looped
from quadsim.horse.playback import SPEED_REACH
from quadsim.kinematics.rotations import quaternions_from_matrices
from quadsim.io.clips import load_default_database
from quadsim.horse.speed import HOYT, clip_contact_time, contact_time, measure_contact_time
from quadsim.io.bvh import read_bvh
from quadsim.commands import Command, Script

REPO = Path(__file__).resolve().parents[1]
FPS = 60


@pytest.fixture(scope="module")
def ctl(horse):
    return HorseDataController(horse, load_default_database(horse))


def _run(horse, script, duration, ctl):
    return simulate(horse, script, duration, FPS, database=ctl.db)


def _measured(m, skip=FPS):
    """The toe tips (T, 4, 3) from frame ``skip`` on and their measured contacts: a hoof
    breaking over lifts its joint while its toe stays down."""
    feet = m.contact_points()[skip:]
    c = foot_contacts(feet, m.fps)
    return feet, c


def _speed(m, skip=FPS):
    r = m.root_positions[skip:]
    return float(np.linalg.norm(r[-1, [0, 2]] - r[0, [0, 2]]) / ((len(r) - 1) / m.fps))


def _runs(labels):
    out = []
    for g in labels:
        if not out or out[-1] != g:
            out.append(g)
    return out


GAIT_SPEEDS = {"walk": (1.3, 1.5, 1.8), "trot": (3.0, 4.0, 5.0), "canter": (5.2, 6.0, 7.0),
               "gallop": (9.5, 11.0, 12.0), "amble": (2.9, 3.2, 3.5), "rack": (3.5, 4.2, 5.0)}
#: gaits whose measured contact time and step follow ``a v^b`` itself within 10 %
LAW_MET = ("walk", "trot", "rack", "canter")
#: gaits expanded relative to their clip, ``Tc0 (v/v0)^b`` (the seed's absolute law is out
#: of a leg's reach for them: amble steps of 2 m, gallop contacts of 0.3 s at 11 m/s)
CLIP_LAW = ("amble", "gallop")


def _per_foot(m, skip=FPS):
    """Median contact time (4,) (s) and body travel during a contact (4,) (m), measured."""
    feet, c = _measured(m, skip)
    iv = stance_intervals(c, FPS, feet)
    r = m.root_positions[skip:]
    path = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(r[:, [0, 2]], axis=0),
                                                           axis=1))])
    tc, d = np.zeros(4), np.zeros(4)
    for i in range(4):
        s = iv[i][np.isfinite(iv[i]).all(axis=1)]
        assert len(s) >= 1
        tc[i] = np.median(s[:, 1] - s[:, 0])
        z = np.interp(s * FPS, np.arange(len(r)), path)
        d[i] = np.median(z[:, 1] - z[:, 0])
    return tc, d, feet, c


@pytest.mark.parametrize("gait", list(GAIT_SPEEDS))
def test_steady_gaits_at_three_speeds(horse, ctl, gait):
    for v in GAIT_SPEEDS[gait]:
        m = _run(horse, Command(speed=v, gait=gait), 4.0, ctl)
        assert len(m) == 4 * FPS
        assert np.isfinite(m.root_positions).all() and np.isfinite(m.rotations).all()
        assert set(m.gaits) == {gait}
        assert abs(_speed(m) / v - 1) < 0.10, (gait, v, _speed(m))
        feet, c = _measured(m)
        duty = duty_factors(c, FPS, feet)
        assert np.all((duty > 0.15) & (duty < 0.8)), (gait, v, duty)
        # stance time as the expanded clip's own (expand owns the law)
        st = np.median(stride_table(c, FPS, feet)["stance"])
        e = ctl.expanded(gait, v)
        tc = float(np.nanmean(measure_contact_time(looped(e.motion, 3, e.speed))))
        assert abs(st / tc - 1) < 0.10, (gait, v, st, tc)
        if gait in LAW_MET:
            assert abs(st / float(contact_time(gait, v)) - 1) < 0.10, (gait, v, st)
        # the clip-labelled contacts agree with the measured ones; no labelled foot floats
        assert np.mean(m.contacts[FPS:] == c) > 0.95
        assert np.abs(feet[..., 1][np.asarray(m.contacts[FPS:], bool)]).max() < 0.005
        _, slide = foot_slide(feet, c)
        assert slide < 0.005, (gait, v, slide)
        # every foot's contact time and step D against the law, per foot
        tc_foot, d_foot, _, _ = _per_foot(m)
        if gait in LAW_MET + CLIP_LAW:
            if gait in LAW_MET:
                want = float(contact_time(gait, v))
            else:
                base = ctl.db.nearest(gait, v)
                want = clip_contact_time(base) * (v / base.speed) ** HOYT[gait][1]
            assert np.all(np.abs(tc_foot / want - 1) < 0.10), (gait, v, tc_foot, want)
            assert np.all(np.abs(d_foot / (v * want) - 1) < 0.10), (gait, v, d_foot, v * want)
        # the footfall order of the gait: feet land in the clip's order after the left
        # hind, feet landing together in the clip within 0.12 of a stride of each other
        want = _template(ctl, gait)
        ph = phases(c, FPS, feet)
        ph = want + (ph - want + 0.5) % 1.0 - 0.5       # nearest turn of the circle
        # (measured: the phases stay within 0.035 of the clip's)
        assert np.all(np.abs(ph - want) < 0.1), (gait, v, ph, want)
        for i in range(4):
            for j in range(i + 1, 4):
                if abs(want[i] - want[j]) < 0.05:
                    assert abs(ph[i] - ph[j]) < 0.12, (gait, v, i, j, ph)
                else:
                    assert np.sign(ph[i] - ph[j]) == np.sign(want[i] - want[j]), (gait, v, ph)


@pytest.mark.parametrize("gait", ["walk", "trot", "rack"])
def test_contact_time_follows_the_absolute_law(horse, ctl, gait):
    # the clips these gaits are expanded from step as Hoyt's law says at their own
    # speed (baked so), so expand stretches their steps by a few per cent (r = D'/D0
    # measured 0.97-1.04 here) and the feet stay within the legs' reach: every
    # foot's contact time and step D within 10 % of a v^b and v a v^b at three
    # speeds across the range (measured: within 4 %)
    for v in GAIT_SPEEDS[gait]:
        e = ctl.expanded(gait, v)                           # at v quantised (2 %)
        base = ctl.db.nearest(gait, e.speed)
        assert abs(clip_contact_time(base) / float(contact_time(gait, base.speed)) - 1) < 0.05
        r = e.speed * (e.frames / base.frames) / base.speed  # expand's step scale D'/D0
        assert 0.9 < r < 1.06, (gait, v, r)
        m = _run(horse, Command(speed=v, gait=gait), 4.0, ctl)
        tc_foot, d_foot, feet, c = _per_foot(m)
        want = float(contact_time(gait, v))
        assert np.all(np.abs(tc_foot / want - 1) < 0.10), (gait, v, tc_foot, want)
        assert np.all(np.abs(d_foot / (v * want) - 1) < 0.10), (gait, v, d_foot, v * want)
        # planted feet on the ground, none below it
        lab = np.asarray(m.contacts[FPS:], bool)
        assert np.abs(feet[..., 1][lab]).max() < 0.005 and feet[..., 1].min() > -0.001


def _template(ctl, gait):
    clip = ctl.db.by_gait(gait)[0]
    return (clip.touchdown - clip.touchdown[2]) / clip.frames % 1.0


def _classify(ctl, ph):
    def dist(a, b):
        d = np.abs((a - b + 0.5) % 1.0 - 0.5)
        return float(np.nansum(d))
    return min(ctl.auto_gaits, key=lambda g: dist(ph, _template(ctl, g)))


def test_speed_ramp_gait_sequence_from_footfalls(horse, ctl):
    # a ramp slow enough that every gait is steady for over a second between its
    # transitions (each 2.5 strides: with strides of Alexander's length the walk -> trot
    # change takes 3 s, the trot -> canter one 2 s)
    times = tuple(float(t) for t in np.arange(0.0, 20.0, 0.5))
    speeds = np.linspace(1.4, 11.5, len(times))
    m = _run(horse, Script(times, tuple(Command(speed=float(v)) for v in speeds)), 21.0, ctl)
    assert np.isfinite(m.root_positions).all()
    labels = [str(g) for g in m.gaits]
    steady = [g for g in _runs(labels) if "->" not in g]
    assert steady == ["walk", "trot", "canter", "gallop"]      # no flicker
    # each steady stretch, classified by its measured footfall phases
    found = []
    i = 0
    while i < len(labels):
        j = i
        while j < len(labels) and labels[j] == labels[i]:
            j += 1
        if "->" not in labels[i] and j - i > FPS:
            feet = m.foot_positions()[i:j]
            c = foot_contacts(feet, FPS)
            found.append(_classify(ctl, phases(c, FPS, feet)))
        i = j
    assert found == ["walk", "trot", "canter", "gallop"]


def test_hysteresis_holds_gait_near_boundary(horse, ctl):
    b = ctl.player.bounds[0]
    times = tuple(float(t) for t in np.arange(0.0, 6.0, 0.25))
    speeds = [b * (1.0 + 0.03 * (-1) ** k) for k in range(len(times))]
    m = _run(horse, Script(times, tuple(Command(speed=float(v)) for v in speeds)), 6.0, ctl)
    assert len(_runs([str(g) for g in m.gaits])) == 1


def test_transition_steady_parts_do_not_slide(horse, ctl):
    m = _run(horse, Script((0.0, 2.0), (Command(gait="walk", speed=1.5),
                                        Command(gait="trot", speed=3.5))), 6.0, ctl)
    labels = [str(g) for g in m.gaits]
    assert _runs(labels) == ["walk", "walk->trot", "trot"]
    feet = m.foot_positions()
    c = foot_contacts(feet, FPS)
    first = labels.index("walk->trot")
    last = len(labels) - 1 - labels[::-1].index("walk->trot")
    # steady walk before, steady trot from one stride after the transition
    for a, b in ((FPS // 2, first), (last + FPS // 2, len(labels))):
        _, slide = foot_slide(feet[a:b], c[a:b])
        assert slide < 0.005, slide
    assert abs(_speed(m[last + FPS // 2:], 0) / 3.5 - 1) < 0.10


def test_turning_follows_the_commanded_rate(horse, ctl):
    rate = math.radians(45.0)
    m = _run(horse, Script((0.0, 1.0, 3.0), (Command(speed=3.5), Command(speed=3.5, turn_rate=rate),
                                             Command(speed=3.5))), 4.5, ctl)
    r = m.root_positions

    def heading(a, b):
        d = r[b] - r[a]
        return math.atan2(d[0], d[2])

    turned = heading(len(r) - 31, len(r) - 1) - heading(20, 50)
    assert abs(turned / math.radians(90.0) - 1) < 0.10, math.degrees(turned)
    # the walk turns at most TURN_PER_STANCE per contact: 15 deg per Hoyt's 0.71 s at
    # 1.5 m/s, 21 deg/s, so the 60 deg turn takes about 3.5 s with the steering's approach
    m2 = _run(horse, Command(speed=1.5, heading=math.radians(-60.0)), 4.0, ctl)
    assert abs(m2.extras["heading"][-1] - math.radians(-60.0)) < math.radians(1.0)
    peak = np.abs(np.diff(m2.extras["heading"])).max() * FPS
    assert abs(peak / (TURN_PER_STANCE / float(contact_time("walk", 1.5))) - 1) < 0.05, peak


def test_leap_rises_and_returns_to_the_gait(horse, ctl):
    m = _run(horse, Script((0.0, 1.0), (Command(speed=6.0), Command(speed=6.0, leap=True))),
             7.0, ctl)
    labels = [str(g) for g in m.gaits]
    assert "leap" in labels
    steady = [g for g in _runs(labels) if "->" not in g]
    assert steady[-1] == "canter" and steady.count("leap") == 1
    y = m.root_positions[:, 1]
    rise = y.max() - np.median(y[:FPS])
    assert rise >= 0.3, rise
    assert np.isfinite(m.root_positions).all()


def test_step_returns_a_frame_of_the_controller_protocol(horse, ctl):
    c = HorseDataController(horse, ctl.db)
    assert isinstance(c, Controller) and c.mode == "data"
    assert c.gait == "stand" and c.ground is None and c.speed == 0.0
    first = c.step(Command(speed=3.5), 0.0)            # the starting pose: dt 0 allowed
    assert first.time == 0.0
    out = c.step(Command(speed=3.5), 1 / 30)
    J = horse.skeleton.n_joints
    assert isinstance(out, Frame) and out.skeleton is horse.skeleton
    assert out.local_rotations.shape == (J, 3, 3)
    assert out.positions.shape == (J, 3) and out.root.shape == (3,)
    assert out.contacts.shape == (4,) and out.gait == "trot" == c.gait
    assert out.time == pytest.approx(1 / 30) == c.time
    assert out.speed == c.speed > 0 and out.heading == c.heading
    assert set(out.extras) == {"pitch", "ground", "toe_ground"}
    assert out.extras["ground"].shape == out.extras["toe_ground"].shape == (4,)
    np.testing.assert_allclose(out.positions[0], out.root)
    with pytest.raises(InputError, match="dt must be > 0"):
        c.step(Command(speed=3.5), 0.0)
    with pytest.raises(InputError, match="gait 'pace'"):
        c.step(Command(speed=3.5, gait="pace"))


def test_protocol_speeds_come_from_the_clips(horse, ctl):
    """A held gait's preferred speed is the geometric mean of its clips' speeds; its cap
    the fastest clip expanded by SPEED_REACH; the top speed the fastest cap."""
    c = HorseDataController(horse, ctl.db)
    assert c.gait_order == [g for g in ctl.db.gaits if g != "leap"]
    assert c.auto_gaits == ["walk", "trot", "canter", "gallop"]
    for g in c.gait_order:
        speeds = [clip.speed for clip in ctl.db.by_gait(g)]
        assert c.preferred_speed(g) == pytest.approx(np.exp(np.mean(np.log(speeds))))
        assert c.gait_speed_cap(g) == pytest.approx(max(speeds) * SPEED_REACH[1])
    assert c.max_speed == max(c.gait_speed_cap(g) for g in c.gait_order)
    with pytest.raises(InputError, match="gait 'pace'"):
        c.preferred_speed("pace")


def test_step_frames_are_the_motion_simulate_records(horse, ctl):
    script = Script((0.0, 1.0), (Command(speed=2.0), Command(speed=6.0, turn_rate=0.3)))
    m = _run(horse, script, 2.5, ctl)
    c = HorseDataController(horse, ctl.db, dt=1 / FPS)
    frames = [c.step(script.command_at(i / FPS)) for i in range(len(m))]
    np.testing.assert_array_equal(np.array([f.root for f in frames]), m.root_positions)
    np.testing.assert_array_equal(quaternions_from_matrices(np.array(
        [f.local_rotations for f in frames])), m.rotations)
    assert [f.gait for f in frames] == list(m.gaits)
    np.testing.assert_array_equal([f.extras["pitch"] for f in frames], m.extras["pitch"])


HEAD = 'character = "{}"\nmode = "data"\nduration = 2.0\nfps = 30\n'
CMD = '[[command]]\nat = 0.0\nspeed = 1.5\n'


def test_config_mode_data_needs_a_clip_database(tmp_path):
    p = tmp_path / "leo.toml"
    p.write_text(HEAD.format("leopard") + CMD)
    with pytest.raises(InputError, match=r"`mode`.*'data'.*clip database.*'procedural'"):
        load_config(p)
    p = tmp_path / "horse.toml"
    p.write_text(HEAD.format("horse") + CMD)
    assert load_config(p).mode == "data"


def test_cli_runs_the_data_config(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    cfg = tmp_path / "h.toml"
    cfg.write_text(HEAD.format("horse") + CMD + '[[command]]\nat = 1.0\nspeed = 3.5\n')
    assert main(["run", str(cfg), "--out", "h.bvh"]) == 0
    m = read_bvh(tmp_path / "h.bvh")
    assert len(m) == 60 and np.isfinite(m.root_positions).all()
    assert "walk" in capsys.readouterr().out
    full = load_config(REPO / "configs" / "horse_data.toml")
    assert full.mode == "data" and any(c.leap for c in full.commands.commands)


def test_shipped_tour_config(horse, ctl):
    cfg = load_config(REPO / "configs" / "horse_data.toml")
    m = simulate(horse, cfg.commands, cfg.duration, cfg.fps, database=ctl.db)
    labels = [str(g) for g in m.gaits]
    steady = set(g for g in labels if "->" not in g)
    assert steady == {"stand", "walk", "amble", "trot", "rack", "canter", "gallop", "leap"}
    assert labels[0] == "stand" and labels[-1] == "stand"
    # measured against the ground the run made (a climb and a descent)
    feet = m.foot_positions()
    rel = np.array(feet)
    rel[..., 1] -= m.extras["ground"]
    c = foot_contacts(rel, cfg.fps)
    _, slide = foot_slide(feet, c)
    assert slide < 0.005, slide
    assert np.abs(rel[..., 1][c]).max() < 0.005 and rel[..., 1].min() > -0.001
    assert m.extras["ground"].max() > 1.5 and abs(m.extras["ground"][-1]).max() < 0.1
    # the heading from the hip joints: the left turn past 80 deg, back to 0 at the end
    P = m.world_positions()
    names = horse.skeleton.names
    left = P[:, names.index("LH_hip")] - P[:, names.index("RH_hip")]
    heading = np.degrees(np.unwrap(np.arctan2(-left[:, 2], left[:, 0])))
    assert heading.max() > 80.0 and np.abs(heading[-FPS:]).max() < 1.0   # standing square


PAIR_SPEEDS = {"walk": 1.5, "amble": 3.2, "trot": 3.8, "rack": 4.2, "canter": 6.0, "gallop": 11.0}


@pytest.mark.parametrize("old", list(PAIR_SPEEDS))
def test_transitions_between_all_gaits_hold_the_feet(horse, ctl, old):
    # the controller's own transitions (started wherever the old gait happens to be at
    # 1.3 s): no foot slides while down, no joint acceleration spike over the steady gaits'
    for new in PAIR_SPEEDS:
        if new == old:
            continue
        m = _run(horse, Script((0.0, 1.3), (Command(speed=PAIR_SPEEDS[old], gait=old),
                                            Command(speed=PAIR_SPEEDS[new], gait=new))),
                 5.5, ctl)
        labels = [str(g) for g in m.gaits]
        tr = [i for i, g in enumerate(labels) if "->" in g]
        assert tr and labels[tr[0]] == f"{old}->{new}" and labels[-1] == new
        feet = m.foot_positions()
        _, slide = foot_slide(feet, foot_contacts(feet, FPS))
        assert slide < 0.005, (old, new, slide)
        acc = angular_acceleration(m).max(axis=1)
        steady = max(acc[FPS // 2:tr[0] - 2].max(), acc[tr[-1] + 2:].max())
        assert acc[tr[0] - 2:tr[-1] + 2].max() < 3.0 * steady, (old, new)


def test_the_compiled_calls_keep_one_signature_over_the_tour(horse, ctl):
    """The placement and the looped clips' samplers call their kernels' entry points
    directly (:class:`~quadsim.kinematics.compiled.FixedEntry`), which trusts the
    arguments to keep the first call's types: over the shipped tour (standing, six
    gaits, transitions, turns, slopes, a leap) every call has the same numba types."""
    from numba import typeof

    cfg = load_config(REPO / "configs" / "horse_data.toml")
    c = HorseDataController(horse, ctl.db, dt=1 / 30)
    seen = {}

    def spy(name, call):
        def wrapped(*args):
            seen.setdefault(name, set()).add(tuple(typeof(a) for a in args))
            return call(*args)
        return wrapped

    c.placement._place_row = spy("place_row", c.placement._place_row)
    c.player._sample_row = spy("sample_row", c.player._sample_row)
    c.player._stance_row = spy("stance_row", c.player._stance_row)
    labels = set()
    for i in range(int(cfg.duration * 30)):
        labels.add(c.step(cfg.commands.command_at(i / 30)).gait)
    assert {"stand", "leap", "walk->amble"} <= labels
    assert set(seen) == {"place_row", "sample_row", "stance_row"}
    assert {k: len(v) for k, v in seen.items()} == {k: 1 for k in seen}
