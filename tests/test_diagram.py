"""Gait diagrams: measured footfalls of a walk -> trot -> gallop ramp, and the files."""

from pathlib import Path

import numpy as np
import pytest

from quadsim import load_character
from quadsim.analysis.metrics import foot_contacts
from quadsim.cli import main
from quadsim.io.bvh import read_bvh, write_bvh
from quadsim.locomotion import Command, Script, simulate
from quadsim.locomotion.gaits import gait_table
from quadsim.skeleton.motion import Motion
from quadsim.viz.diagram import (
    IRREGULAR,
    classify_strides,
    footfall_data,
    gait_diagram,
    phase_distance,
    reference_gaits,
)

REPO = Path(__file__).resolve().parents[1]
#: Walk, trot, then gallop: the leopard's automatic gaits at 1, 3 and 8 m/s.
RAMP = Script((0.0, 4.5, 7.0), (Command(speed=1.0), Command(speed=3.0), Command(speed=8.0)))
EXPECTED = ["walk", "trot", "rotary_gallop"]


@pytest.fixture(scope="module")
def leopard():
    return load_character("leopard")


@pytest.fixture(scope="module")
def ramp(leopard):
    return simulate(leopard, RAMP, 10.5, 60.0)


@pytest.fixture(scope="module")
def ramp_data(ramp):
    return footfall_data(ramp)


def test_ramp_shows_three_footfall_patterns_matching_the_tables(ramp_data, leopard):
    steady = ramp_data.steady_segments(min_strides=2)
    assert [s.label for s in steady] == EXPECTED
    table = gait_table(leopard)
    for seg in steady:
        gait = table[seg.label]
        # measured phases (LF, RF, RH after LH) within 0.05 of the table
        assert np.all(phase_distance(seg.phase, gait.phases) < 0.05), (seg.label, seg.phase)
        assert seg.phase_error < 0.05
        # and the duty factor inside the gait's range, give or take 0.05
        lo, hi = sorted(gait.duty_range)
        assert np.all((seg.duty > lo - 0.05) & (seg.duty < hi + 0.05)), (seg.label, seg.duty)
    # segments tile the clip in time order, with the transitions between them
    starts = [s.start for s in ramp_data.segments]
    assert starts == sorted(starts)
    assert any(s.is_transition for s in ramp_data.segments)


def test_bars_are_measured_from_foot_positions_not_planned_contacts(ramp, ramp_data):
    # the planned contacts play no part: replacing them changes nothing
    fake = Motion(ramp.skeleton, ramp.fps, ramp.root_positions, ramp.rotations,
                  contacts=np.ones((len(ramp), 4), bool), gaits=ramp.gaits,
                  foot_joints=ramp.foot_joints, extras=ramp.extras)
    other = footfall_data(fake)
    for a, b in zip(ramp_data.bars, other.bars):
        np.testing.assert_array_equal(a, b)
    # the bars cover the frames metrics.foot_contacts finds
    c = foot_contacts(ramp.contact_points(), ramp.fps)
    np.testing.assert_array_equal(ramp_data.contacts, c)
    t = ramp_data.times
    for i, bars in enumerate(ramp_data.bars):
        inside = np.zeros(len(t), bool)
        for on, off in bars:
            inside |= (t >= on - 1.0 / ramp.fps) & (t <= off + 1.0 / ramp.fps)
        assert np.all(inside[c[:, i]])


def test_per_stride_rows(ramp_data):
    d = ramp_data
    n = len(d.stride_start)
    assert n > 15
    assert d.stride_duty.shape == d.stride_phase.shape == (n, 4)
    assert np.all(d.stride_stop > d.stride_start)
    np.testing.assert_array_equal(d.stride_phase[:, 2], 0.0)  # LH is the reference
    ok = np.isfinite(d.stride_phase)
    assert np.all((d.stride_phase[ok] >= 0) & (d.stride_phase[ok] < 1))
    ok = np.isfinite(d.stride_duty)
    assert np.all((d.stride_duty[ok] > 0) & (d.stride_duty[ok] < 1))
    assert d.cpg_phase.shape == (len(d.times), 4)
    assert d.spine.shape == (len(d.times),)


def test_unlabelled_motion_names_strides_by_pattern(ramp, tmp_path):
    write_bvh(ramp, tmp_path / "ramp.bvh")
    motion = read_bvh(tmp_path / "ramp.bvh")
    assert motion.gaits is None
    data = footfall_data(motion)
    assert not data.labelled
    steady = [s.label for s in data.steady_segments(min_strides=2)]
    for g in EXPECTED:
        assert g in steady
    assert steady.index("walk") < steady.index("trot") < steady.index("rotary_gallop")


def test_classify_strides_names_the_table_patterns():
    gaits = reference_gaits(character=load_character("horse"))
    names = list(gaits)
    duty = np.array([[np.mean(gaits[n][0])] * 4 for n in names])
    phase = np.stack([gaits[n][1] for n in names])
    assert list(classify_strides(duty, phase, gaits)) == names
    # a pattern far from every gait is irregular
    odd = classify_strides([[0.5] * 4], [[0.9, 0.3, 0.0, 0.7]], gaits)
    assert odd[0] == IRREGULAR


def test_phase_distance_wraps():
    assert phase_distance(0.98, 0.02) == pytest.approx(0.04)
    assert phase_distance(0.25, 0.75) == pytest.approx(0.5)
    np.testing.assert_allclose(phase_distance([0.1, 1.1], 0.1), [0.0, 0.0], atol=1e-12)


def test_gait_diagram_writes_png_svg_pdf(ramp, tmp_path):
    png = gait_diagram(ramp, tmp_path / "ramp.png")
    head = png.read_bytes()[:8]
    assert head == b"\x89PNG\r\n\x1a\n"
    import matplotlib.image as mpimg

    img = mpimg.imread(png)
    assert img.shape[0] > 400 and img.shape[1] > 1000
    assert (tmp_path / "d.svg").exists() is False
    svg = gait_diagram(ramp, tmp_path / "d.svg", start=2.0, stop=6.0)
    assert b"<svg" in svg.read_bytes()[:500]
    pdf = gait_diagram(ramp, tmp_path / "d.pdf")
    assert pdf.read_bytes()[:5] == b"%PDF-"
    # deterministic: the same motion gives the same file
    again = gait_diagram(ramp, tmp_path / "again.png")
    assert again.read_bytes() == png.read_bytes()


def test_gait_diagram_bad_input(ramp, tmp_path):
    with pytest.raises(ValueError, match="supported: .png, .svg, .pdf"):
        gait_diagram(ramp, tmp_path / "d.jpg")
    with pytest.raises(ValueError, match="at least 3"):
        footfall_data(ramp, start=10.49)
    bare = Motion(ramp.skeleton, ramp.fps, ramp.root_positions, ramp.rotations)
    with pytest.raises(ValueError, match="foot joints"):
        footfall_data(bare)
    assert not list(tmp_path.iterdir())


def test_cli_diagram_from_config_and_bvh(ramp, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    cfg = REPO / "configs" / "leopard.toml"
    assert main(["diagram", str(cfg), "--out", "leopard.svg", "--seconds", "3"]) == 0
    assert (tmp_path / "leopard.svg").stat().st_size > 10_000
    write_bvh(ramp[120:360], tmp_path / "walk.bvh")
    assert main(["diagram", "walk.bvh", "--out", "walk.png"]) == 0
    assert "wrote walk.png" in capsys.readouterr().out
    assert main(["diagram", "walk.bvh", "--out", "walk.gif"]) == 2
    assert "a diagram is written as .png, .svg, .pdf" in capsys.readouterr().err
    assert main(["diagram", "missing.bvh"]) == 2
    assert "no such file" in capsys.readouterr().err
