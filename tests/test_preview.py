"""The live preview, driven off screen: keys, per-frame updates, screenshots, recording."""

import math
from pathlib import Path

import numpy as np
import pytest

from quadsim.cli import main
from quadsim.io.bvh import read_bvh
from quadsim.viz.diagram import footfall_data, phase_distance
from quadsim.viz.preview import HELP, Preview

REPO = Path(__file__).resolve().parents[1]
DT = 1.0 / 60.0


@pytest.fixture
def preview(tmp_path):
    p = Preview("leopard", off_screen=True, size=(320, 240), record_dir=tmp_path / "rec")
    yield p
    p.close()


def run(p, seconds):
    for _ in range(round(seconds / DT)):
        p.update(DT)


def test_character_moves_and_screenshots_change(preview):
    first = preview.screenshot()
    assert first.shape == (240, 320, 3) and first.dtype == np.uint8
    r0 = preview.root
    run(preview, 2.0)
    r1 = preview.root
    assert preview.steps == 120
    assert r1[2] - r0[2] > 0.5          # walked forward (+Z), at least half a metre
    assert abs(r1[0] - r0[0]) < 0.1     # straight
    second = preview.screenshot()
    assert second.shape == first.shape
    assert np.mean(np.abs(second.astype(int) - first.astype(int))) > 0.5
    # the body is drawn: a good part of the picture is not sky or ground
    colours = np.unique(second.reshape(-1, 3) // 16, axis=0)
    assert len(colours) > 20


def test_update_takes_fixed_steps(preview):
    assert preview.update(DT) == 1
    assert preview.update(0.5 * DT) == 0
    assert preview.update(0.5 * DT) == 1
    assert preview.update(3 * DT) == 3
    assert preview.update(100 * DT) == 8   # a stalled frame drops time instead of catching up
    assert preview.time == pytest.approx(13 * DT)
    assert preview.steps == 13
    with pytest.raises(ValueError, match="dt must be"):
        preview.update(-1.0)


def test_speed_keys(preview):
    v0 = preview.speed_command
    assert preview.on_key("Up")
    assert preview.speed_command == pytest.approx(v0 + preview.speed_step)
    assert preview.on_key("Down") and preview.on_key("Down")
    assert preview.speed_command == pytest.approx(max(v0 - preview.speed_step, 0.0))
    for _ in range(100):
        preview.on_key("Down")
    assert preview.speed_command == 0.0
    for _ in range(200):
        preview.on_key("Up")
    assert preview.speed_command == pytest.approx(preview.max_speed)
    preview.on_key("2")  # a held trot caps the speed at what a trot reaches
    for _ in range(100):
        preview.on_key("Up")
    assert preview.speed_command <= preview.controller.gait_speed_cap("trot") + 1e-9
    assert "tops out" in preview.message


def test_turn_keys_steer_left(preview):
    run(preview, 1.0)
    assert preview.on_key("Left") and preview.on_key("Left")
    assert preview.heading_command == pytest.approx(2 * math.radians(15.0))
    x0 = preview.root[0]
    run(preview, 3.0)
    assert preview.heading > math.radians(15.0)   # turned left, towards +X
    assert preview.root[0] > x0 + 0.1
    preview.on_key("Right")
    assert preview.heading_command == pytest.approx(math.radians(15.0))


def test_gait_key_changes_the_measured_footfalls(preview):
    """Walk, then press 2 (trot): the recorded feet show both patterns."""
    order = preview.gait_order
    assert order[:2] == ["walk", "trot"]
    preview.on_key("1")
    preview.on_key("r")
    run(preview, 5.0)                  # set off from standing, then walk
    pose_walk = preview.world_positions
    preview.on_key("2")
    assert preview.gait_command == "trot"
    assert preview.speed_command == pytest.approx(preview.gaits["trot"].preferred_speed)
    run(preview, 4.0)
    assert preview.controller.scheduler.current == "trot"
    assert preview.gait == "trot"
    assert not np.allclose(preview.world_positions, pose_walk)
    motion = preview.recorded_motion()
    data = footfall_data(motion)
    steady = {s.label: s for s in data.steady_segments(min_strides=2)}
    assert {"walk", "trot"} <= set(steady)
    for g in ("walk", "trot"):
        assert np.all(phase_distance(steady[g].phase, preview.gaits[g].phases) < 0.05), g
    preview.on_key("0")
    assert preview.gait_command is None


def test_recording_writes_a_bvh_with_every_step(preview, tmp_path):
    run(preview, 0.25)
    assert preview.on_key("R")
    assert preview.recording
    run(preview, 0.5)
    preview.update(0.5 * DT)           # no step, no frame
    assert preview.recorded_frames == 30
    assert preview.on_key("r")
    assert not preview.recording
    path = preview.last_recording
    assert path is not None and path.parent == tmp_path / "rec" and path.suffix == ".bvh"
    assert preview.message == f"wrote {path}"
    motion = read_bvh(path)
    assert len(motion) == 30
    assert motion.fps == pytest.approx(60.0)
    assert sorted(motion.skeleton.names) == sorted(preview.character.skeleton.names)
    # the file's last frame is the pose on screen
    idx = motion.skeleton.indices(preview.character.skeleton.names)
    np.testing.assert_allclose(motion.world_positions()[-1][idx], preview.world_positions,
                               atol=1e-6)
    # a second recording goes to a new file; an empty one writes nothing
    preview.on_key("r")
    run(preview, 0.1)
    preview.on_key("r")
    assert preview.last_recording != path and preview.last_recording.exists()
    preview.on_key("r")
    preview.on_key("r")
    assert "no frames" in preview.message


def test_pause_freezes_the_character(preview):
    run(preview, 0.5)
    assert preview.on_key("p") and preview.paused
    r = preview.root
    t = preview.time
    assert preview.update(10 * DT) == 0
    assert preview.time == t
    np.testing.assert_array_equal(preview.root, r)
    preview.on_key("P")
    run(preview, 0.5)
    assert preview.root[2] > r[2]


def test_leap_request_is_stored_and_passed_on(preview):
    assert "horse" in HELP and "coming" in HELP
    assert preview.on_key("space")
    assert preview.leap_requested
    assert preview.command().leap
    assert "horse" in preview.message
    preview.update(DT)
    assert not preview.leap_requested


def test_help_and_unknown_keys(preview):
    assert not preview.show_help
    assert preview.on_key("h") and preview.show_help
    shot = preview.screenshot()
    assert preview.on_key("H") and not preview.show_help
    assert not np.array_equal(shot, preview.screenshot())  # the overlay was drawn
    assert preview.on_key("x") is False
    assert preview.on_key("9") is False       # the leopard has six gaits
    assert preview.on_key("F5") is False


def test_config_script_plays_until_a_steering_key(tmp_path):
    cfg = REPO / "configs" / "leopard.toml"
    p = Preview(str(cfg), off_screen=True, size=(160, 120), record_dir=tmp_path)
    try:
        assert not p.manual
        run(p, 1.0)
        assert p.speed > 0.2
        p.on_key("p")            # pausing does not take over
        assert not p.manual
        p.on_key("p")
        p.on_key("Up")
        assert p.manual
        assert p.command().gait == p.gait_command
        with pytest.raises(RuntimeError, match="off screen"):
            p.run()
    finally:
        p.close()


def test_cli_preview_without_display_fails_cleanly(monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    assert main(["preview", "leopard"]) == 2
    err = capsys.readouterr().err
    assert "quadsim: error: no display" in err and "Traceback" not in err


def test_cli_preview_screenshot(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["preview", "dog_cub", "--screenshot", "shot.png", "--seconds", "0.5",
                 "--size", "200x150"]) == 0
    import matplotlib.image as mpimg

    assert mpimg.imread(tmp_path / "shot.png").shape[:2] == (150, 200)
    assert main(["preview", "no_such_animal", "--screenshot", "x.png"]) == 2
    assert "unknown character" in capsys.readouterr().err
    assert main(["preview", "leopard", "--size", "big"]) == 2
