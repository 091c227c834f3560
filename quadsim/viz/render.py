"""Render a motion to a video file off screen (``.mp4`` or ``.gif``).

:func:`render_video` poses the :class:`~quadsim.viz.body.BodyMesh` for every
frame (forward kinematics once, for all frames), draws the
:class:`~quadsim.viz.scene.Scene` off screen -- VTK renders through EGL or
OSMesa on a machine without a display -- and streams the frames to the file:

- ``.mp4``: H.264 through imageio-ffmpeg (``yuv420p``, so the width and the
  height must be even);
- ``.gif``: Pillow through imageio, looping; GIF stores frame times in
  hundredths of a second, so the frame rate is best a divisor of 100 (25 or
  50 fps play exactly; the default for a config is 25 fps).

The file is written to a temporary name beside the target and renamed when
complete, so a failed render leaves no partial file.
"""

from __future__ import annotations

import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from quadsim.viz.scene import CAMERAS, Scene, parse_size

__all__ = ["FORMATS", "render_frames", "render_video"]

#: Video formats by extension.
FORMATS = (".mp4", ".gif")
#: Frame rate of a video rendered from a config, by extension.
DEFAULT_FPS = {".mp4": 30.0, ".gif": 25.0}


def _motion_from(source, seconds: float | None, fps: float | None, ext: str):
    """(motion, character or None) for a Motion, RunConfig or config path."""
    from quadsim.config import RunConfig, load_config
    from quadsim.skeleton.motion import Motion

    if isinstance(source, Motion):
        motion = source
        if seconds is not None:
            motion = motion.time_slice(0.0, seconds + 0.5 / motion.fps)
        if fps is not None and abs(fps - motion.fps) > 1e-9:
            motion = motion.resample(fps)
        return motion, None
    config = source if isinstance(source, RunConfig) else load_config(source)
    from quadsim.config import with_overrides
    from quadsim.locomotion import simulate

    if seconds is not None:
        config = with_overrides(config, duration=seconds)
    character = config.load_character()
    motion = simulate(character, config.commands, config.duration, config.fps, seed=config.seed)
    want = DEFAULT_FPS.get(ext, 30.0) if fps is None else float(fps)
    if abs(want - motion.fps) > 1e-9:
        motion = motion.resample(want)
    return motion, character


def _character_for(motion):
    """The shipped character whose skeleton the motion has, if any."""
    from quadsim.skeleton.character import list_characters, load_character

    for cid in list_characters():
        try:
            ch = load_character(cid)
        except ValueError:
            continue
        if ch.skeleton is motion.skeleton or sorted(ch.skeleton.names) == sorted(
                motion.skeleton.names):
            return ch
    return None


def _headings(motion) -> np.ndarray:
    """Heading of the body per frame (rad): the motion's own, else from the root's path."""
    h = motion.extras.get("heading") if motion.extras else None
    if h is not None and np.shape(h) == (len(motion),):
        return np.asarray(h, dtype=float)
    R = motion.world_rotations()[:, 0]
    fwd = R[:, :, 2]  # the root's +Z axis in the world
    return np.arctan2(fwd[:, 0], fwd[:, 2])


class _Progress:
    """A text progress bar on a stream (stderr by default).

    On a terminal one line is redrawn (``render clip.mp4 [#####.....] 12/30
    frames, 0.4 s (eta 0.6 s)``); elsewhere (a log, CI) a line is printed at
    every quarter.
    """

    def __init__(self, label: str, total: int, stream=None, width: int = 30):
        self.label, self.total, self.width = label, max(int(total), 1), width
        self.stream = sys.stderr if stream is None else stream
        isatty = getattr(self.stream, "isatty", None)
        self.tty = bool(isatty and isatty())
        self.t0 = time.perf_counter()
        self._last = -1.0
        self._quarter = -1

    def __call__(self, done: int) -> None:
        now = time.perf_counter()
        final = done >= self.total
        if self.tty:
            if not final and now - self._last < 0.1:
                return
        else:
            q = 4 * done // self.total
            if q == self._quarter:
                return
            self._quarter = q
        self._last = now
        k = int(self.width * done / self.total)
        bar = "#" * k + "." * (self.width - k)
        el = now - self.t0
        eta = el / done * (self.total - done) if done else 0.0
        text = (f"{self.label} [{bar}] {done}/{self.total} frames, {el:.1f} s"
                + ("" if final else f" (eta {eta:.1f} s)"))
        if self.tty:
            self.stream.write("\r" + text + ("\n" if final else ""))
        else:
            self.stream.write(text + "\n")
        self.stream.flush()


def render_frames(motion, *, size=(640, 480), camera: str = "follow", character=None,
                  anti_aliasing: str | None = None, progress=None):
    """Yield the rendered frames of a motion, RGB uint8 arrays of shape (H, W, 3).

    Parameters
    ----------
    motion : Motion
    size : (int, int) or str
    camera : {"follow", "side", "top"}
    character : Character, optional
        Gives the body its parts and colour (default: the shipped character
        with the motion's skeleton, else a generic body).
    anti_aliasing : {None, "ssaa"}
        "ssaa" smooths edges at several times the cost of a frame.
    progress : callable, optional
        Called with the number of frames done.
    """
    from quadsim.viz.body import BodyMesh, body_scale

    if camera not in CAMERAS:
        raise ValueError(f"camera {camera!r}: choose one of {', '.join(CAMERAS)}")
    if character is None:
        character = _character_for(motion)
    G = motion.world_rotations()
    P = motion.world_positions()
    if character is not None and sorted(character.skeleton.names) == sorted(
            motion.skeleton.names):
        # the character's body, its joints picked out of the motion's order
        # (a BVH file lists them depth first)
        perm = motion.skeleton.indices(character.skeleton.names)
        G, P = G[:, perm], P[:, perm]
        body = BodyMesh.from_character(character)
        scale = character.hip_height
    else:
        body = BodyMesh.from_skeleton(motion.skeleton)
        scale = body_scale(motion.skeleton)
    scene = Scene(body, scale, size=size, off_screen=True, camera=camera,
                  anti_aliasing=anti_aliasing)
    try:
        H = _headings(motion)
        dt = 1.0 / motion.fps
        for k in range(len(motion)):
            scene.set_pose(G[k], P[k], H[k])
            scene.update_camera(dt if k else 0.0)
            yield scene.image()
            if progress is not None:
                progress(k + 1)
    finally:
        scene.close()


def render_video(source, path: str | os.PathLike, *, size=(640, 480), camera: str = "follow",
                 progress: bool = True, fps: float | None = None, seconds: float | None = None,
                 anti_aliasing: str | None = None, quality: float = 7.0) -> Path:
    """Render a motion, or a run configuration, to an ``.mp4`` or ``.gif`` file off screen.

    Parameters
    ----------
    source : Motion, RunConfig, or str or path-like
        A motion, a run configuration, or a config file path (simulated first).
    path : str or path-like
        Output file; the format follows the extension (``.mp4`` or ``.gif``).
    size : (int, int) or str
        ``(width, height)`` in pixels or ``"WxH"``; even numbers for ``.mp4``.
    camera : {"follow", "side", "top"}
        Behind and to the left of the character, turning with it; from its
        left side; or from above.
    progress : bool or callable
        True prints a progress bar on stderr; a callable receives the number
        of frames done.
    fps : float, optional
        Frame rate of the video. Default: a motion's own; a config's
        simulation is resampled to 30 fps (``.mp4``) or 25 fps (``.gif``).
    seconds : float, optional
        Duration to render (a config's duration is replaced; a motion is cut).
    anti_aliasing : {None, "ssaa"}
        "ssaa" smooths edges at several times the cost of a frame.
    quality : float
        MP4 quality from 0 to 10 (imageio-ffmpeg's scale).

    Returns
    -------
    Path
        The file written: one video frame per motion frame.

    Raises
    ------
    ValueError
        For an unsupported extension, camera or size, or odd MP4 dimensions.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in FORMATS:
        kind = f"{path.suffix} files" if path.suffix else "files without an extension"
        raise ValueError(f"cannot render a video to {kind} ({str(path)!r}); "
                         f"supported: {', '.join(FORMATS)}")
    if camera not in CAMERAS:
        raise ValueError(f"camera {camera!r}: choose one of {', '.join(CAMERAS)}")
    w, h = parse_size(size)
    if ext == ".mp4" and (w % 2 or h % 2):
        raise ValueError(f"size {w}x{h}: an .mp4 needs an even width and height")
    if fps is not None and not (math.isfinite(fps) and 0 < fps <= 240):
        raise ValueError(f"fps {fps!r}: must be a number of frames per second from 0 to 240")
    if seconds is not None and not (math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"seconds {seconds!r}: must be a positive duration")
    import imageio.v2 as imageio

    motion, character = _motion_from(source, seconds, fps, ext)
    if len(motion) == 0:
        raise ValueError("the motion has no frames to render")
    bar = progress if callable(progress) else (
        _Progress(f"render {path.name}", len(motion)) if progress else None)
    frames = render_frames(motion, size=(w, h), camera=camera, character=character,
                           anti_aliasing=anti_aliasing, progress=bar)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=ext, dir=path.parent)
    os.close(fd)
    try:
        if ext == ".mp4":
            writer = imageio.get_writer(tmp, format="FFMPEG", mode="I", fps=motion.fps,
                                        codec="libx264", quality=quality,
                                        pixelformat="yuv420p", macro_block_size=1,
                                        ffmpeg_log_level="error")
            try:
                for img in frames:
                    writer.append_data(img)
            finally:
                writer.close()
        else:
            import imageio.v3 as iio

            stack = np.stack(list(frames))
            iio.imwrite(tmp, stack, extension=".gif", plugin="pillow",
                        duration=1000.0 / motion.fps, loop=0)
        _publish(tmp, path)
    except BaseException:
        frames.close()
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path


def _publish(tmp: str, path: Path) -> None:
    """Give a finished temporary file the usual permissions and move it into place."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    os.replace(tmp, path)
