"""The live preview, driven off screen: keys, per-frame updates, screenshots, recording."""

import math
from pathlib import Path

import numpy as np
import pytest

from quadsim.cli import main
from quadsim.io.bvh import read_bvh
from quadsim.viz.diagram import footfall_data, phase_distance
from quadsim.viz.preview import HELP, LEAP_HELP, Preview

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
    assert "coming" not in HELP and "coming" not in LEAP_HELP["procedural"]
    assert "--mode data" in LEAP_HELP["procedural"]
    assert preview.on_key("space")
    assert preview.leap_requested
    assert preview.command().leap
    assert "horse" in preview.message and "--mode data" in preview.message
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


# ------------------------------------------------------------- data mode
def _track(p, seconds, log):
    """Step ``seconds`` one controller step per update, logging joint positions and labels."""
    for _ in range(round(seconds / DT)):
        assert p.update(DT) == 1
        log.append((p.world_positions, p.gait))


def _ground_speed(log, seconds):
    """Mean horizontal root speed (m/s) over the last ``seconds`` of the log."""
    n = round(seconds / DT)
    d = log[-1][0][0] - log[-1 - n][0][0]
    return math.hypot(d[0], d[2]) / seconds


def _travel_heading(log, seconds):
    """Direction of the root's travel (rad, 0 along +Z, positive left) over the last seconds."""
    n = round(seconds / DT)
    d = log[-1][0][0] - log[-1 - n][0][0]
    return math.atan2(d[0], d[2])


@pytest.fixture
def horse_data(tmp_path):
    p = Preview("horse", mode="data", off_screen=True, size=(160, 120),
                record_dir=tmp_path / "rec")
    yield p
    p.close()


def test_data_mode_steps_the_clip_controller(horse_data):
    import quadsim
    from quadsim.horse.controller import HorseDataController

    p = horse_data
    assert p.mode == "data" and isinstance(p.live, quadsim.Controller)
    assert isinstance(p.controller, HorseDataController)
    assert p.gait_order == ["walk", "amble", "trot", "rack", "canter", "gallop"]
    # starts at a walk at the (geometric) mean of the walk clips' speeds (1.30 and 1.70 m/s);
    # at most 1.4 times the gallop clip's
    db = p.controller.db
    walks = [c.speed for c in db.by_gait("walk")]
    assert p.speed_command == pytest.approx(math.sqrt(walks[0] * walks[-1]), rel=1e-3)
    assert p.max_speed == pytest.approx(1.4 * db.by_gait("gallop")[-1].speed, rel=1e-3)
    log = []
    _track(p, 3.0, log)
    assert p.steps == 180 and p.gait == "walk"
    assert _ground_speed(log, 2.0) == pytest.approx(p.speed_command, rel=0.05)
    assert p.speed == pytest.approx(_ground_speed(log, 2.0), rel=0.05)   # the HUD's speed
    assert abs(log[-1][0][0][0]) < 0.01          # straight along +Z
    text = p._text.GetText(2)
    assert "(data)" in text and "gait walk" in text and "fps" in text


def test_data_mode_keys_steer_the_measured_motion(horse_data):
    """Gait, speed, heading keys, each measured from the joint positions."""
    p = horse_data
    log = []
    _track(p, 2.0, log)
    p.on_key("r")
    assert p.on_key("3")                          # trot, at 3.87 m/s
    assert p.gait_command == "trot"
    trots = [c.speed for c in p.controller.db.by_gait("trot")]
    assert p.speed_command == pytest.approx(math.sqrt(trots[0] * trots[-1]), rel=1e-3)
    _track(p, 5.0, log)
    assert p.gait == "trot"
    assert "walk->trot" in {g for _, g in log}
    assert _ground_speed(log, 2.0) == pytest.approx(p.speed_command, rel=0.05)
    # the recorded feet show the trot's footfalls: diagonal pairs together, half a stride apart
    motion = p.recorded_motion()
    steady = {s.label: s for s in footfall_data(motion).steady_segments(min_strides=2)}
    assert np.all(phase_distance(steady["trot"].phase, p.gaits["trot"].phases) < 0.05)
    # Up twice: 2 x 0.64 m/s faster, still a (held) trot
    v0 = p.speed_command
    p.on_key("Up")
    p.on_key("Up")
    assert p.speed_command == pytest.approx(v0 + 2 * p.speed_step)
    assert p.speed_step == pytest.approx(0.64)
    _track(p, 4.0, log)
    assert p.gait == "trot"
    assert _ground_speed(log, 2.0) == pytest.approx(p.speed_command, rel=0.05)
    assert p.speed == pytest.approx(_ground_speed(log, 2.0), rel=0.05)
    # a held trot tops out at its fastest clip's reach (1.4 x 5.0 m/s)
    for _ in range(20):
        p.on_key("Up")
    assert p.speed_command == pytest.approx(1.4 * p.controller.db.by_gait("trot")[-1].speed,
                                            rel=1e-3)
    assert "tops out" in p.message
    p.on_key("Down")
    p.on_key("Down")
    # Left twice: travel turns to +30 degrees
    assert p.on_key("Left") and p.on_key("Left")
    assert p.heading_command == pytest.approx(math.radians(30.0))
    _track(p, 4.0, log)
    assert math.degrees(_travel_heading(log, 1.0)) == pytest.approx(30.0, abs=2.0)
    assert math.degrees(p.heading) == pytest.approx(30.0, abs=0.5)
    # 0: gaits by speed again; at 5.7 m/s that is the canter (clear of the trot -> canter
    # switch, 4.8 m/s, and its 6 % hysteresis)
    v = p.speed_command
    assert 5.5 < v < 5.8
    assert v > 1.1 * p.controller.player.bounds[1]
    p.on_key("0")
    _track(p, 4.0, log)
    assert p.gait == "canter"
    assert _ground_speed(log, 1.5) == pytest.approx(v, rel=0.08)
    assert p.recorded_frames == round(17.0 / DT)
    path = p.stop_recording()
    m = read_bvh(path)
    assert len(m) == round(17.0 / DT)
    # the file's last frame is the pose on screen
    idx = m.skeleton.indices(p.character.skeleton.names)
    np.testing.assert_allclose(m.world_positions()[-1][idx], p.world_positions, atol=1e-5)


def test_data_mode_space_leaps(horse_data):
    """Space: all four hooves leave the ground for over 0.3 s (a gallop's float is shorter)."""
    p = horse_data
    feet = p.character.skeleton.indices(p.character.foot_joints)
    log = []
    _track(p, 2.0, log)
    assert p.on_key("space") and p.leap_requested
    assert "coming" not in p.message and "leap" in p.message
    _track(p, 9.0, log)
    labels = [g for _, g in log]
    assert "leap" in labels and labels[-1] == "walk"
    # hooves off the ground: more than 3 cm up (a planted hoof is at 0)
    hooves = np.array([P[feet, 1] for P, _ in log])
    assert np.percentile(hooves, 5, axis=0) == pytest.approx(0.0, abs=0.005)
    air = (hooves > 0.03).all(axis=1)
    runs, start = [], None
    for i, a in enumerate(np.append(air, False)):
        if a and start is None:
            start = i
        elif not a and start is not None:
            runs.append((start, i - start))
            start = None
    long = [(s, n) for s, n in runs if n * DT > 0.3]
    assert len(long) == 1, runs
    s, n = long[0]
    assert 0.4 < n * DT < 0.7                    # the leap clip's 0.55 s flight
    assert all(labels[k] == "leap" for k in range(s, s + n))
    assert all(k * DT < 0.3 for _, k in runs if (_, k) != long[0])


def test_data_config_ground_follows_the_slope(tmp_path):
    """horse_data.toml climbs 8 degrees: the grid, the shadow and the camera follow."""
    p = Preview(str(REPO / "configs" / "horse_data.toml"), off_screen=True, size=(160, 120),
                record_dir=tmp_path)
    try:
        assert p.mode == "data" and p.gait == "stand" and p.live.ground is None
        run(p, 13.5)
        ground = p.live.ground
        assert ground is not None and math.degrees(ground.slope) == pytest.approx(8.0)
        scene = p.scene
        # every grid point sits on the controller's ground
        plane, _, grid, _ = scene._relief
        off = np.array(scene.grid_actor.GetPosition())
        pts = np.asarray(grid.points) + off
        np.testing.assert_allclose(pts[:, 1], ground.height(pts[:, [0, 2]]), atol=1e-9)
        assert np.ptp(pts[:, 1]) > 5.0            # a real slope across the 96 m grid
        # the horse is up the slope, its hooves on it, and the camera looks at it there
        P = p.world_positions
        hooves = P[p.character.skeleton.indices(p.character.foot_joints)]
        floor = ground.height(hooves[:, [0, 2]])
        assert floor.min() > 0.5
        assert (hooves[:, 1] - floor).min() > -0.02
        focal = np.array(scene.plotter.renderer.GetActiveCamera().GetFocalPoint())
        assert focal[1] == pytest.approx(scene._floor + 0.75 * scene.scale, abs=1e-6)
        assert scene._floor > 0.5
        p._update_text(force=True)      # the HUD refreshes at most every HUD_INTERVAL of wall time
        assert "ground slope +8.0 deg" in p._text.GetText(2)
    finally:
        p.close()


def test_cli_preview_data_mode(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["preview", "horse", "--mode", "data", "--screenshot", "shot.png",
                 "--seconds", "1", "--size", "200x150"]) == 0
    import matplotlib.image as mpimg

    assert mpimg.imread(tmp_path / "shot.png").shape[:2] == (150, 200)
    out = capsys.readouterr().out
    assert "(data mode)" in out and "gait walk" in out


def test_cli_preview_data_mode_needs_clips(monkeypatch, capsys):
    # the mode is checked before the display
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    for argv in (["preview", "leopard", "--mode", "data"],
                 ["preview", "leopard", "--mode", "data", "--screenshot", "x.png"]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "quadsim: error: `--mode` = 'data' needs a character with a clip database" in err
        assert "'leopard' has none" in err
        assert "drop `--mode data`" in err and "Traceback" not in err
