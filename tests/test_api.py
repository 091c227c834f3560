"""The front door: one way from a config, a character or a command to a motion and a file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import quadsim
from quadsim.cli import main
from quadsim.errors import InputError
from quadsim.io.bvh import read_bvh
from quadsim.skeleton.contacts import foot_contacts

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def test_import_quadsim_gives_what_a_library_user_needs():
    for name in ("load_character", "list_characters", "make_controller", "simulate", "run",
                 "save", "Command", "Script", "Motion", "Frame", "Controller", "InputError"):
        assert hasattr(quadsim, name), name
    assert set(quadsim.list_characters()) >= {"leopard", "leopard_cub", "dog_cub", "horse"}


def test_run_of_a_character_and_a_gait_trots_at_the_trot_duty_factor():
    motion = quadsim.run("leopard", gait="trot", seconds=4)
    assert motion.n_frames == 240 and set(motion.gaits) == {"trot"}
    # measured from the feet, after the start: diagonal pairs share their contact frames
    c = foot_contacts(motion.contact_points(), motion.fps)[120:]
    lf, rf, lh, rh = c.T
    assert (lf == rh).mean() > 0.9 and (rf == lh).mean() > 0.9
    assert (lf != rf).mean() > 0.5


def test_a_data_mode_config_runs_the_data_driven_horse_on_its_ground():
    """The front door gives the data-mode motion for a data-mode config (not the procedural
    horse), with the ground it walks on, and the feet stand on that ground."""
    cfg = quadsim.resolve(CONFIGS / "horse_data.toml", seconds=14)
    assert cfg.mode == "data"
    motion = quadsim.run(cfg)
    same = quadsim.simulate("horse", cfg.commands, seconds=14, fps=cfg.fps, mode="data")
    np.testing.assert_array_equal(motion.root_positions, same.root_positions)
    ground = motion.extras["ground"]
    assert ground.shape == (motion.n_frames, 4)
    assert np.ptp(ground) > 0.3  # the ramp is climbed
    # contacts measured from the hooves' heights over that ground (not the controller's
    # flags): the horse stands on the ramp, its toe tips on the ground under them
    from quadsim.analysis.appearance import toe_positions
    from quadsim.analysis.metrics import feet_over_ground

    down = foot_contacts(feet_over_ground(motion), motion.fps) & (ground > 0.1)
    assert down.sum() > 100
    toe_gap = np.abs(toe_positions(motion)[..., 1] - ground)[down]
    assert np.percentile(toe_gap, 90) < 0.02


def test_save_picks_the_format_from_the_extension(tmp_path):
    motion = quadsim.run("dog_cub", gait="walk", seconds=1)
    bvh = quadsim.save(motion, tmp_path / "a" / "m.bvh")
    back = read_bvh(bvh)
    order = [back.skeleton.names.index(n) for n in motion.skeleton.names]
    np.testing.assert_allclose(back.world_positions()[:, order], motion.world_positions(),
                               atol=1e-6)
    assert quadsim.save(motion, tmp_path / "m.glb").read_bytes()[:4] == b"glTF"
    assert set(np.load(quadsim.save(motion, tmp_path / "m.npz")).files) >= {"positions"}
    assert quadsim.save(motion, tmp_path / "m.csv").read_text().count("\n") > motion.n_frames
    with pytest.raises(InputError, match=r"cannot write \.fbx files; supported: \.bvh"):
        quadsim.save(motion, tmp_path / "m.fbx")
    with pytest.raises(InputError, match="is a folder"):
        quadsim.save(motion, tmp_path / "a")


def test_a_run_shorter_than_one_frame_is_refused():
    with pytest.raises(InputError, match="less than one frame"):
        quadsim.run("leopard", seconds=0.005)


def test_a_character_without_clips_has_no_data_mode():
    with pytest.raises(InputError, match=r"`--mode` = 'data' needs a character with a clip"):
        quadsim.run("leopard", mode="data")


@pytest.mark.parametrize("mode", ["procedural", "data"])
def test_both_modes_step_behind_one_interface_as_the_offline_run_does(mode):
    """make_controller gives a Controller whose frames are the offline motion's frames."""
    ctl = quadsim.make_controller("horse", mode)
    assert isinstance(ctl, quadsim.Controller) and ctl.mode == mode
    cmd = quadsim.Command(speed=3.0)
    frames = [ctl.step(cmd, 0.0 if k == 0 else 1 / 60) for k in range(90)]
    assert all(isinstance(f, quadsim.Frame) for f in frames)
    offline = quadsim.simulate("horse", cmd, seconds=1.5, fps=60, mode=mode)
    P = offline.world_positions()
    np.testing.assert_allclose(np.stack([f.positions for f in frames]), P, atol=1e-9)
    assert [f.gait for f in frames] == [str(g) for g in offline.gaits]
    assert not frames[-1].positions.flags.writeable
    assert ctl.gait == frames[-1].gait and ctl.speed > 0


def test_cli_runs_a_character_id_with_flags(tmp_path, capsys):
    out = tmp_path / "l.bvh"
    assert main(["run", "leopard", "--gait", "trot", "--seconds", "3", "--out", str(out)]) == 0
    assert "leopard (procedural mode), gaits: trot" in capsys.readouterr().out
    assert read_bvh(out).n_frames == 180
    out = tmp_path / "h.glb"
    assert main(["run", "horse", "--mode", "data", "--speed", "4", "--seconds", "3",
                 "--out", str(out)]) == 0
    assert "horse (data mode)" in capsys.readouterr().out
    assert out.read_bytes()[:4] == b"glTF"


def test_cli_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"quadsim {quadsim.__version__}"


def test_a_users_character_file_runs_by_path_and_as_an_object(tmp_path):
    from quadsim.skeleton.character import characters_dir

    text = (characters_dir() / "dog_cub.toml").read_text(encoding="utf-8")
    mine = tmp_path / "my_dog.toml"
    mine.write_text(text.replace('id = "dog_cub"', 'id = "my_dog"'), encoding="utf-8")
    by_path = quadsim.run(mine, gait="trot", seconds=1)
    ch = quadsim.load_character(mine)
    by_object = quadsim.run(ch, gait="trot", seconds=1)
    assert ch.id == "my_dog"
    np.testing.assert_array_equal(by_path.root_positions, by_object.root_positions)
    assert quadsim.resolve(ch).character == str(mine)


def test_switching_a_configs_mode_checks_its_commands(tmp_path):
    cfg = tmp_path / "pace.toml"
    cfg.write_text('character = "horse"\nduration = 2.0\nfps = 60\n\n'
                   '[[command]]\nat = 0.0\ngait = "pace"\n', encoding="utf-8")
    with pytest.raises(InputError, match=r"`--mode data`: .*`command\[0\]\.gait` = 'pace' "
                                         "has no clips"):
        quadsim.resolve(cfg, mode="data")
    assert quadsim.resolve(cfg, mode="data", gait="trot").mode == "data"   # the flag replaces it
    with pytest.raises(InputError, match=r"`command\[\d\]\.slope_deg` needs the data mode"):
        quadsim.resolve(CONFIGS / "horse_data.toml", mode="procedural")
