"""The front door's faults, each reproduced: outputs are whole or absent, signals leave no
temporary files, symlinks are written through and read-only files refused, `metrics`
explains what it cannot measure, centimetre files are detected, GIF memory does not
grow with length, and a quick benchmark never replaces the committed results."""

import errno
import hashlib
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from quadsim import load_character
from quadsim.cli import main
from quadsim.errors import InputError
from quadsim.io.bvh import read_bvh, write_bvh
from quadsim.locomotion import Command, simulate

REPO = Path(__file__).resolve().parents[1]
OLD = b"a good old file that must survive\n"


@pytest.fixture(scope="module")
def trot():
    """1 s of a trotting leopard at 30 fps."""
    return simulate(load_character("leopard"), Command(speed=2.5, gait="trot"), 1.0, 30.0)


@pytest.fixture()
def clip(trot, tmp_path):
    path = tmp_path / "trot.bvh"
    write_bvh(trot, path)
    return path


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# --------------------------------------------------- 1. whole or not at all
@pytest.mark.parametrize("ext", [".gif", ".mp4"])
def test_render_onto_a_failing_disk_keeps_the_old_video(clip, tmp_path, monkeypatch, capsys,
                                                        ext):
    """The disk fills up after two frames: exit 2 with the reason, old file intact."""
    from quadsim.viz import video

    out_dir = tmp_path / "videos"
    out_dir.mkdir()
    out = out_dir / f"clip{ext}"
    out.write_bytes(OLD)
    cls = video.GifStream if ext == ".gif" else video.Mp4Stream
    real = cls.append

    def append(self, frame):
        if self.count == 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(self, frame)

    monkeypatch.setattr(cls, "append", append)
    assert main(["render", str(clip), "--out", str(out), "--size", "64x48", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "No space left on device" in err and str(out) in err
    assert out.read_bytes() == OLD
    assert leftovers(out_dir) == []


def test_an_encoder_that_fails_at_the_end_is_an_error(clip, tmp_path, monkeypatch, capsys):
    """ffmpeg exiting non-zero (it cannot finish the file) is not a finished video."""
    from quadsim.viz import video

    out = tmp_path / "clip.mp4"
    out.write_bytes(OLD)
    real = video.Mp4Stream.close

    def close(self):
        self._proc.stdin.close()
        self._proc.wait()
        self._proc.returncode = 1
        self._log.write(b"Error writing trailer: No space left on device\n")
        real(self)

    monkeypatch.setattr(video.Mp4Stream, "close", close)
    assert main(["render", str(clip), "--out", str(out), "--size", "64x48", "--quiet"]) == 2
    assert "No space left on device" in capsys.readouterr().err
    assert out.read_bytes() == OLD
    assert leftovers(tmp_path) == []


def _can_mount_tmpfs() -> bool:
    if shutil.which("unshare") is None:
        return False
    r = subprocess.run(["unshare", "-rm", "sh", "-c", "mount -t tmpfs -o size=64k tmpfs /mnt"],
                       check=False, capture_output=True)
    return r.returncode == 0


@pytest.mark.skipif(not _can_mount_tmpfs(), reason="cannot mount a tmpfs here (unshare -rm)")
@pytest.mark.parametrize("ext", [".gif", ".mp4"])
def test_render_onto_a_really_full_disk(clip, tmp_path, ext):
    """A 96 KiB tmpfs (in a private mount namespace) holding an old file: the render fails."""
    disk = tmp_path / "disk"
    disk.mkdir()
    script = textwrap.dedent(f"""
        import os, sys
        from quadsim.cli import main
        out = os.path.join({str(disk)!r}, "clip{ext}")
        with open(out, "wb") as f:
            f.write({OLD!r})
        code = main(["render", {str(clip)!r}, "--out", out, "--size", "320x240", "--quiet"])
        with open(out, "rb") as f:
            same = f.read() == {OLD!r}
        left = sorted(os.listdir({str(disk)!r}))
        print("RESULT", code, same, left)
    """)
    env = dict(os.environ, PYTHONPATH=str(REPO))
    shell = f'mount -t tmpfs -o size=96k tmpfs {disk} && exec {sys.executable} -c "$0"'
    r = subprocess.run(["unshare", "-rm", "sh", "-c", shell, script], check=False,
                       capture_output=True, text=True, env=env, timeout=300)
    line = [s for s in r.stdout.splitlines() if s.startswith("RESULT")]
    assert line, r.stdout + r.stderr
    assert line[0] == f"RESULT 2 True ['clip{ext}']", r.stderr
    assert "No space left on device" in r.stderr


# ------------------------------------------------------- 2. stopped by a signal
@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 128 + 15), (signal.SIGINT, 130)])
def test_a_signal_during_a_render_removes_the_temporary_file(tmp_path, sig, code):
    long = simulate(load_character("leopard"), Command(speed=2.5, gait="trot"), 40.0, 30.0)
    write_bvh(long, tmp_path / "long.bvh")
    out_dir = tmp_path / "videos"
    out_dir.mkdir()
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-m", "quadsim", "render", str(tmp_path / "long.bvh"),
                             "--out", str(out_dir / "long.gif"), "--size", "160x120", "--quiet"],
                            env=env, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        # until a few frames are in the temporary file
        while not any((out_dir / n).stat().st_size > 20000 for n in leftovers(out_dir)):
            assert proc.poll() is None, proc.stderr.read()
            assert time.monotonic() < deadline, "no temporary file appeared"
            time.sleep(0.05)
        proc.send_signal(sig)
        err = proc.communicate(timeout=60)[1]
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == code, err
    assert "unfinished files removed" in err
    assert "Traceback" not in err
    assert list(out_dir.iterdir()) == []


def test_the_signal_handlers_are_restored_after_a_command(clip, tmp_path):
    before = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)
    assert main(["metrics", str(clip)]) == 0
    assert (signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)) == before


# --------------------------------------------------- 3. links and read-only files
def _writers(trot):
    from quadsim.io.gltf import write_glb
    from quadsim.io.npz import write_csv, write_npz
    from quadsim.viz.diagram import gait_diagram
    from quadsim.viz.render import render_video

    return {
        ".bvh": lambda p: write_bvh(trot, p),
        ".glb": lambda p: write_glb(trot, p),
        ".npz": lambda p: write_npz(trot, p),
        ".csv": lambda p: write_csv(trot, p),
        ".mp4": lambda p: render_video(trot[:4], p, size=(32, 24), progress=False),
        ".gif": lambda p: render_video(trot[:4], p, size=(32, 24), progress=False),
        ".png": lambda p: gait_diagram(trot, p),
    }


EXTS = [".bvh", ".glb", ".npz", ".csv", ".mp4", ".gif", ".png"]


@pytest.mark.parametrize("ext", EXTS)
def test_writing_to_a_symlink_writes_through_it(trot, tmp_path, ext):
    real_dir = tmp_path / "real"
    real_dir.mkdir()
    target = real_dir / f"target{ext}"
    target.write_bytes(OLD)
    target.chmod(0o640)
    link = tmp_path / f"link{ext}"
    link.symlink_to(target)
    _writers(trot)[ext](link)
    assert link.is_symlink() and link.resolve() == target.resolve()
    assert target.read_bytes() != OLD and target.stat().st_size > 100
    assert target.stat().st_mode & 0o777 == 0o640       # the replaced file's permissions
    assert leftovers(real_dir) == [] and leftovers(tmp_path) == []


@pytest.mark.parametrize("ext", EXTS)
def test_a_read_only_output_is_refused(trot, tmp_path, ext):
    target = tmp_path / f"locked{ext}"
    target.write_bytes(OLD)
    target.chmod(0o444)
    with pytest.raises(InputError, match=r"locked\.\w+: the file is read-only"):
        _writers(trot)[ext](target)
    assert target.read_bytes() == OLD
    assert leftovers(tmp_path) == []


def test_render_refuses_a_read_only_output_before_rendering(clip, tmp_path, capsys):
    out = tmp_path / "locked.mp4"
    out.write_bytes(OLD)
    out.chmod(0o444)
    assert main(["render", str(clip), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "locked.mp4: the file is read-only" in err and "chmod u+w" in err
    assert out.read_bytes() == OLD


# ------------------------------------------------------------------ 4. metrics
def _renamed(text: str) -> str:
    """A file whose joints are named in another convention (no LF_/RF_/LH_/RH_)."""
    for old, new in (("LF_", "FrontLeft"), ("RF_", "FrontRight"), ("LH_", "BackLeft"),
                     ("RH_", "BackRight")):
        text = text.replace(old, new)
    return text


def test_metrics_finds_the_feet_of_other_joint_names(clip, tmp_path, capsys):
    other = tmp_path / "other.bvh"
    other.write_text(_renamed(clip.read_text()))
    assert main(["metrics", str(clip), "--json"]) == 0
    named = json.loads(capsys.readouterr().out)
    assert main(["metrics", str(other), "--json"]) == 0
    out = capsys.readouterr()
    assert "feet taken from the skeleton's shape" in out.err
    assert "LF FrontLeft" in out.err
    got = json.loads(out.out)
    assert got["mean_speed"] == pytest.approx(named["mean_speed"], rel=1e-9)
    assert got["legs"] == named["legs"]


FLAT = """HIERARCHY
ROOT hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT spine
  {
    OFFSET 0 0 0.5
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 0 0.5
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.1
0 0.5 0 0 0 0 0 0 0
0 0.5 0.1 0 0 0 0 0 0
0 0.5 0.2 0 0 0 0 0 0
"""


def test_metrics_without_four_legs_lists_what_it_expects(tmp_path, capsys):
    path = tmp_path / "snake.bvh"
    path.write_text(FLAT)
    assert main(["metrics", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}: cannot tell which joints are the feet" in err
    assert "LF_, RF_, LH_ and RH_" in err and "end joints are spine" in err
    assert "Traceback" not in err


def test_metrics_on_a_file_without_frames(trot, tmp_path, capsys):
    path = write_bvh(trot[:0], tmp_path / "empty.bvh")
    assert main(["metrics", str(path)]) == 2
    assert f"{path}: the file has 0 frames" in capsys.readouterr().err


def test_metrics_with_start_past_the_end(clip, capsys):
    assert main(["metrics", str(clip), "--start", "5"]) == 2
    err = capsys.readouterr().err
    assert str(clip) in err and "`--start` = 5 s" in err and "lasts 0.967 s" in err


# ------------------------------------------------------------- 5. centimetres
def test_a_centimetre_file_is_detected_and_said(trot, clip, tmp_path, capsys):
    cm = write_bvh(trot, tmp_path / "cm.bvh", units="cm")
    assert main(["metrics", str(clip), "--json"]) == 0
    metres = json.loads(capsys.readouterr().out)
    assert main(["metrics", str(cm), "--json"]) == 0
    out = capsys.readouterr()
    assert f"warning: {cm}: read as centimetres" in out.err and "--units m" in out.err
    assert json.loads(out.out)["mean_speed"] == pytest.approx(metres["mean_speed"], rel=1e-6)
    # forced, the old reading: a hundred times too fast
    assert main(["metrics", str(cm), "--json", "--units", "m"]) == 0
    out = capsys.readouterr()
    assert "warning" not in out.err
    assert json.loads(out.out)["mean_speed"] == pytest.approx(100 * metres["mean_speed"],
                                                              rel=1e-6)


def test_a_centimetre_file_renders_like_the_metre_file(trot, clip, tmp_path):
    from quadsim.viz.render import render_frames

    cm = write_bvh(trot[:1], tmp_path / "cm.bvh", units="cm")
    with pytest.warns(UserWarning, match="read as centimetres"):
        back = read_bvh(cm)
    a = next(iter(render_frames(read_bvh(clip)[:1], size=(96, 64), camera="side")))
    b = next(iter(render_frames(back, size=(96, 64), camera="side")))
    assert np.mean(np.abs(a.astype(int) - b.astype(int))) < 1.0


def test_render_of_a_centimetre_file_says_which_unit_it_read(trot, tmp_path, capsys):
    cm = write_bvh(trot[:4], tmp_path / "cm.bvh", units="cm")
    assert main(["render", str(cm), "--out", str(tmp_path / "cm.gif"), "--size", "32x24",
                 "--quiet"]) == 0
    err = capsys.readouterr().err
    assert f"quadsim: warning: {cm}: read as centimetres" in err and "--units m" in err
    assert main(["render", str(cm), "--units", "cm", "--out", str(tmp_path / "cm.gif"),
                 "--size", "32x24", "--quiet"]) == 0
    assert "warning" not in capsys.readouterr().err


# ------------------------------------------------------------- 6. GIF memory
def _peak_bytes(motion, path) -> int:
    from quadsim.viz.render import render_video

    tracemalloc.start()
    try:
        render_video(motion, path, size=(64, 48), progress=False)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_gif_memory_does_not_grow_with_length(tmp_path):
    """Three times the frames, about the same peak: the frames are not held."""
    from quadsim.viz.render import FK_CHUNK

    m = simulate(load_character("leopard"), Command(speed=2.5, gait="trot"), 15.6, 25.0)
    _peak_bytes(m[:5], tmp_path / "warm.gif")                     # imports, caches
    n_short, n_long = FK_CHUNK + 2, len(m)                        # 130 and 390 frames
    short = _peak_bytes(m[:n_short], tmp_path / "short.gif")
    long = _peak_bytes(m, tmp_path / "long.gif")
    # holding the frames would add at least a palette image per frame (64 x 48 bytes;
    # 3 times that as RGB); allow a sixth of it
    per_frame = (long - short) / (n_long - n_short)
    assert per_frame < 64 * 48 / 6, (short, long)
    assert (tmp_path / "long.gif").stat().st_size > 2 * (tmp_path / "short.gif").stat().st_size


# ------------------------------------------------------------- 7. bench --quick
def test_bench_quick_does_not_touch_the_committed_results(tmp_path, monkeypatch, capsys):
    sys.path.insert(0, str(REPO))
    from benchmarks import command

    committed = sorted((REPO / "benchmarks" / "results").glob("*.json"))
    before = {p: digest(p) for p in committed}
    monkeypatch.setattr(command, "run", lambda **kw: {"machine": {"cpu": "x", "cores": 2},
                                                      "quick": kw["quick"]})
    monkeypatch.chdir(tmp_path)
    assert main(["bench", "--quick"]) == 0
    assert json.loads((tmp_path / "out" / "bench-quick.json").read_text())["quick"] is True
    assert "wrote out/bench-quick.json" in capsys.readouterr().out
    assert main(["bench", "--quick", "--out", "mine.json"]) == 0
    assert (tmp_path / "mine.json").is_file()
    assert {p: digest(p) for p in committed} == before
    assert command.result_path(None, False, {"cpu": "x", "cores": 2}).parent == \
        REPO / "benchmarks" / "results"


# ------------------------------------------------------------- 8. render's input
def test_render_of_a_config_is_simulated_by_the_front_door(tmp_path, capsys):
    """`quadsim render CONFIG` passes the config's motion (data mode included) to the renderer."""
    import imageio.v3 as iio

    assert main(["render", str(REPO / "configs" / "dog_cub.toml"), "--out",
                 str(tmp_path / "cub.gif"), "--seconds", "0.4", "--size", "48x32",
                 "--quiet"]) == 0
    # 0.4 s at the config's 60 fps (24 frames, 0 to 0.383 s) shown at 25 fps
    assert iio.imread(tmp_path / "cub.gif", index=None).shape[0] == 10
    assert math.isfinite(os.path.getsize(tmp_path / "cub.gif"))


# --------------------------------------------------------- 8. the ground walked on
@pytest.fixture(scope="module")
def climb(horse):
    """The data-mode horse cantering up an 8 degree ramp, then on the level top."""
    import quadsim
    from quadsim.commands import Script

    script = Script((0.0, 1.0, 4.0), (Command(speed=6.0),
                                      Command(speed=6.0, slope=math.radians(8)),
                                      Command(speed=6.0)))
    return quadsim.simulate(horse, script, seconds=6.0, fps=25.0, mode="data")


def test_the_rendered_ground_is_under_the_hooves(climb):
    from quadsim.viz.terrain import motion_ground

    ground = motion_ground(climb, cell=0.25)
    assert ground is not None
    want = climb.extras["ground"]
    assert want.max() > 0.5                          # it climbs
    feet = climb.foot_positions()[..., [0, 2]]
    got = ground.height(feet)
    planted = climb.contacts
    assert np.abs(got - want)[planted].max() < 0.02  # 2 cm where the hooves stand
    assert np.abs(got - want).max() < 0.05
    # the ground is a ramp across the path: a metre to the side is as high
    side = feet + np.array([1.0, 0.0])
    assert np.abs(ground.height(side) - want)[planted].max() < 0.05


def test_a_flat_motion_has_no_ground_of_its_own(trot):
    from quadsim.viz.terrain import motion_ground

    assert motion_ground(trot) is None


def test_render_draws_the_ramp_under_the_data_mode_horse(climb):
    from quadsim.viz.render import render_frames
    from quadsim.viz.scene import GROUND_SUB

    top = climb[100:101]                              # 4 s: on the level top, about 0.4 m up
    flat = top._replace(slice(None), extras={k: v for k, v in top.extras.items()
                                             if k != "ground"})
    on_ramp = next(iter(render_frames(top, size=(96, 64), camera="side")))
    floating = next(iter(render_frames(flat, size=(96, 64), camera="side")))
    assert not np.array_equal(on_ramp, floating)
    from quadsim.viz.terrain import motion_ground

    g = motion_ground(top, cell=1.0 / GROUND_SUB)
    assert g.height(top.root_positions[:, [0, 2]])[0] == pytest.approx(
        top.extras["ground"][0].mean(), abs=0.05)
