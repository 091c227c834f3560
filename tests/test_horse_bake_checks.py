"""The bake's checks (tools/bake_horse_clips.py): the shipped clips pass them, and each
catches the defect it names."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from quadsim.horse.database import Cycle
from quadsim.skeleton.motion import Motion

TOOL = Path(__file__).resolve().parents[1] / "tools" / "bake_horse_clips.py"


@pytest.fixture(scope="module")
def bake():
    spec = importlib.util.spec_from_file_location("bake_horse_clips", TOOL)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _cycle(clip, **change):
    fields = dict(motion=clip.motion, frames=clip.frames, touchdown=clip.touchdown,
                  speed=clip.speed, lead=clip.lead, loop_error_deg=0.0, start_time=0.0)
    fields.update(change)
    return Cycle(**fields)


def test_the_shipped_clips_pass_the_bake_checks(bake, db):
    for c in db.clips.values():
        if c.gait == "leap":
            continue
        assert bake.cycle_defects(_cycle(c)) == [], c.name


def test_a_wrong_touchdown_label_is_named(bake, db):
    c = db.clips["trot_3.0"]
    td = c.touchdown.copy()
    td[0] = (td[0] + 5) % c.frames
    bad = bake.cycle_defects(_cycle(c, touchdown=td))
    # a label is the frame the foot comes to rest on, up to a frame after its refined
    # touchdown: the landing is named 4-6 frames off (the shipped trot's left fore
    # lands 0.8 frame before its own label: 5.8)
    off = [float(b.split()[2]) for b in bad if b.startswith("LF lands ") and "from its label" in b]
    assert len(off) == 1 and 4.0 <= off[0] <= 6.0, bad
    assert not any(b.startswith(("RF", "LH", "RH")) for b in bad), bad


def test_a_root_running_ahead_of_the_stride_slides_the_planted_feet(bake, db):
    # the root carried 5 cm further over the cycle than the clip's speed takes it (and
    # back at the seam): a trot's foot planted for 20 of 48 frames drifts about 2 cm
    c = db.clips["trot_3.0"]
    root = c.motion.root_positions.copy()
    root[:, 2] += 0.05 * np.arange(c.frames) / c.frames
    m = Motion(c.motion.skeleton, c.motion.fps, root, c.motion.rotations,
               foot_joints=c.motion.foot_joints)
    bad = bake.cycle_defects(_cycle(c, motion=m))
    assert any("slides" in b for b in bad), bad


def test_the_served_spans_split_a_gait_at_the_geometric_means(bake):
    lo, hi = bake.SERVED["trot"]
    a = bake.served_span("trot", 3.0)
    b = bake.served_span("trot", 5.0)
    assert a[0] == lo and b[1] == hi
    assert a[1] == b[0] == pytest.approx(np.sqrt(15.0))
    assert bake.served_span("gallop", 11.0) == bake.SERVED["gallop"]


def test_the_shipped_trot_expands_over_its_span_without_defects(bake, db, horse):
    c = db.clips["trot_5.0"]
    assert bake.expansion_defects(c, horse, bake.served_span("trot", 5.0)) == []


def test_an_expansion_past_the_legs_reach_is_named(bake, db, horse):
    # the trot's 5 m/s clip asked for 9 m/s, far past the trot's span (measured: a joint
    # at 2.4x the clip's fastest)
    c = db.clips["trot_5.0"]
    bad = bake.expansion_defects(c, horse, [9.0])
    assert bad and all(b.startswith("at 9.00 m/s") for b in bad), bad


def test_a_take_with_no_cycle_to_ship_stops_the_bake_and_writes_nothing(bake, tmp_path,
                                                                        monkeypatch, capsys):
    monkeypatch.setattr(bake, "CLIPS", [("trot", "trot", 3.0, {"drop": 0.10, "stride": 2.08})])
    monkeypatch.setattr(bake, "BAKE_TOE_DEPTH", -1.0)       # every toe counts as dipping
    out = tmp_path / "clips"
    assert bake.main(["--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "trot 3.0 m/s take: no cycle of the take can ship" in err
    assert "a toe tip dips" in err and "Traceback" not in err
    assert not out.exists()
