"""Video rendering off screen: frame counts read back from the files."""

import io
from pathlib import Path

import imageio.v2 as imageio
import imageio.v3 as iio
import numpy as np
import pytest

from quadsim import load_character
from quadsim.cli import main
from quadsim.io.bvh import write_bvh
from quadsim.locomotion import Command, simulate
from quadsim.viz.render import _Progress, render_frames, render_video

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def trot():
    """30 frames of a trotting leopard at 30 fps."""
    m = simulate(load_character("leopard"), Command(speed=2.5, gait="trot"), 1.0, 30.0)
    assert len(m) == 30
    return m


def mp4_frames(path):
    reader = imageio.get_reader(path, format="FFMPEG")
    try:
        meta = reader.get_meta_data()
        frames = [f for f in reader]
    finally:
        reader.close()
    return meta, frames


def test_gif_has_every_frame(trot, tmp_path):
    seen = []
    out = render_video(trot, tmp_path / "clip.gif", size=(160, 120), progress=seen.append)
    assert out == tmp_path / "clip.gif"
    frames = iio.imread(out, index=None)
    assert frames.shape == (30, 120, 160, 3)
    assert seen == list(range(1, 31))
    # the character moves: consecutive frames differ
    assert np.mean(np.abs(frames[0].astype(int) - frames[15].astype(int))) > 0.5
    props = iio.immeta(out, index=0)
    assert props.get("duration") == pytest.approx(1000 / 30, abs=10)


def test_mp4_is_h264_with_every_frame(trot, tmp_path):
    out = render_video(trot, tmp_path / "clip.mp4", size=(160, 120), progress=False)
    meta, frames = mp4_frames(out)
    assert len(frames) == 30
    assert frames[0].shape == (120, 160, 3)
    assert meta["codec"] == "h264"
    assert meta["fps"] == pytest.approx(30.0)
    assert meta["size"] == (160, 120)
    assert out.stat().st_mode & 0o044  # readable by others, like any new file


def test_cameras_see_different_views(trot):
    views = {}
    for cam in ("follow", "side", "top"):
        views[cam] = next(iter(render_frames(trot[:1], size=(96, 64), camera=cam)))
        assert views[cam].shape == (64, 96, 3)
    assert not np.array_equal(views["follow"], views["side"])
    assert not np.array_equal(views["side"], views["top"])


def test_render_cuts_and_resamples_a_bvh_file(trot, tmp_path):
    write_bvh(trot, tmp_path / "trot.bvh")
    out = render_video(tmp_path / "trot.bvh", tmp_path / "t.gif", size=(64, 48), seconds=0.4,
                       fps=25.0, progress=False)
    # 0.4 s at 30 fps (13 frames, 0 to 0.4 s) shown at 25 fps: 0 to 0.4 s
    assert iio.imread(out, index=None).shape[0] == 11


def test_render_takes_a_motion_not_a_config(tmp_path):
    """Turning a config into a motion is the front door's job, not the renderer's."""
    with pytest.raises(ValueError, match="takes a Motion or a .bvh file"):
        render_video(REPO / "configs" / "dog_cub.toml", tmp_path / "cub.gif", progress=False)
    assert not list(tmp_path.iterdir())


def test_progress_bar_text():
    buf = io.StringIO()
    bar = _Progress("render x.mp4", 8, stream=buf)
    for k in range(1, 9):
        bar(k)
    lines = buf.getvalue().splitlines()
    assert len(lines) == 5       # not a terminal: the first frame, then a line a quarter
    assert lines[-1].startswith("render x.mp4 [" + "#" * 30 + "] 8/8 frames")


def test_bad_input(trot, tmp_path):
    with pytest.raises(ValueError, match="supported: .mp4, .gif"):
        render_video(trot, tmp_path / "clip.avi")
    with pytest.raises(ValueError, match="even width and height"):
        render_video(trot, tmp_path / "clip.mp4", size=(161, 120))
    with pytest.raises(ValueError, match="camera 'front'"):
        render_video(trot, tmp_path / "clip.gif", camera="front")
    with pytest.raises(ValueError, match="WIDTHxHEIGHT"):
        render_video(trot, tmp_path / "clip.gif", size="large")
    with pytest.raises(ValueError, match="from 16 to 8192"):
        render_video(trot, tmp_path / "clip.gif", size=(8, 8))
    assert not list(tmp_path.iterdir())


def test_cli_render(tmp_path, trot, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    write_bvh(trot[:12], tmp_path / "trot.bvh")
    assert main(["render", "trot.bvh", "--out", "t.mp4", "--size", "96x64",
                 "--camera", "side"]) == 0
    out = capsys.readouterr()
    assert "wrote t.mp4: 12 frames at 30 fps, 96x64, camera side" in out.out
    assert "12/12 frames" in out.err           # the progress bar
    assert len(mp4_frames(tmp_path / "t.mp4")[1]) == 12
    assert main(["render", "trot.bvh", "--out", "t.gif", "--size", "64x48", "--fps", "15",
                 "--quiet"]) == 0
    assert "frames" not in capsys.readouterr().err
    assert iio.imread(tmp_path / "t.gif", index=None).shape[0] == 6
    assert main(["render", "trot.bvh", "--out", "t.mov"]) == 2
    assert main(["render", "trot.bvh", "--out", "t.mp4", "--size", "97x64"]) == 2
    assert main(["render", "trot.bvh", "--camera", "front"]) == 2
    err = capsys.readouterr().err
    assert "a video is written as .mp4, .gif" in err and "even width" in err


# ------------------------------------------------------------------ the body
def test_body_mesh_follows_forward_kinematics(trot):
    """The preview's body is linear blend skinning of the one rest mesh."""
    from quadsim.io.body_mesh import body_mesh
    from quadsim.viz.body import BodyMesh

    ch = load_character("leopard")
    body = BodyMesh.from_character(ch)
    glb = body_mesh(ch.skeleton)
    np.testing.assert_array_equal(body.points, glb.positions)      # the GLB's mesh
    np.testing.assert_array_equal(body.faces, glb.triangles)
    assert body.faces.max() < body.n_points and body.joints.max() < ch.skeleton.n_joints
    G, P = trot.world_rotations()[7], trot.world_positions()[7]
    pts, nrm = body.posed(G, P)
    np.testing.assert_allclose(np.linalg.norm(nrm, axis=1), 1.0, atol=1e-9)
    # a few vertices skinned by hand: sum of w * (G_j (x - B_j) + P_j)
    B = ch.skeleton.rest_positions
    for v in (0, 123, body.n_points // 2, body.n_points - 1):
        want = sum(w * (G[j] @ (body.points[v] - B[j]) + P[j])
                   for j, w in zip(body.joints[v], body.weights[v]))
        np.testing.assert_allclose(pts[v], want, atol=1e-12)
    # vertices moved by one joint only keep their distance to it
    rigid = body.weights[:, 0] == 1.0
    assert rigid.sum() > 0.05 * body.n_points
    own = body.owner[rigid]
    np.testing.assert_allclose(np.linalg.norm(pts[rigid] - P[own], axis=1),
                               np.linalg.norm(body.points[rigid] - B[own], axis=1), atol=1e-9)
    # one PolyData, posed in place
    mesh = body.polydata(G, P)
    before = mesh.points.copy()
    body.update(mesh, trot.world_rotations()[20], trot.world_positions()[20])
    assert mesh.n_points == body.n_points and not np.allclose(mesh.points, before)
    with pytest.raises(ValueError, match="expected \\(34, 3, 3\\)"):
        body.posed(G[:3], P)


def test_bvh_motion_gets_its_characters_body(trot, tmp_path):
    """A BVH file lists joints depth first; the render maps them to the character."""
    from quadsim.io.bvh import read_bvh

    write_bvh(trot[:1], tmp_path / "one.bvh")
    back = read_bvh(tmp_path / "one.bvh")
    a = next(iter(render_frames(trot[:1], size=(96, 64), camera="side")))
    b = next(iter(render_frames(back, size=(96, 64), camera="side")))
    assert np.mean(np.abs(a.astype(int) - b.astype(int))) < 1.0
