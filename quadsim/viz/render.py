"""Render a motion to a video file off screen (``.mp4`` or ``.gif``).

:func:`render_video` poses the :class:`~quadsim.viz.body.BodyMesh` for every
frame (forward kinematics for :data:`FK_CHUNK` frames at a time), draws the
:class:`~quadsim.viz.scene.Scene` off screen -- VTK renders through EGL or
OSMesa on a machine without a display -- and streams the frames, one at a
time, to the encoder (:mod:`quadsim.viz.video`), so memory does not grow
with the length of the video:

- ``.mp4``: H.264 through the ffmpeg of imageio-ffmpeg (``yuv420p``, so the
  width and the height must be even);
- ``.gif``: Pillow's GIF encoder, looping, a palette per frame; GIF stores
  frame times in hundredths of a second, so the frame rate is best a divisor
  of 100 (25 or 50 fps play exactly; the CLI's default for a config is 25 fps).

A motion that carries the ground under its feet (``extras["ground"]``, the
data-driven horse on ramps) is drawn on that ground
(:func:`quadsim.viz.terrain.motion_ground`), not on the plane ``y = 0``.

The file is written whole or not at all (:func:`quadsim.io.atomic.atomic_output`):
to a temporary file beside the target, moved into place when the encoder
has finished successfully; a failure (a full disk, an encoder error, a
signal) leaves an existing file as it was and no temporary file.

:func:`render_video` takes a :class:`~quadsim.skeleton.motion.Motion` (or a
BVH file); turning a config into a motion is the job of the front door that
simulates it.
"""

from __future__ import annotations

import gc
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from quadsim.io.atomic import atomic_output, check_signals
from quadsim.viz.scene import CAMERAS, GROUND_SUB, Scene, parse_size

__all__ = ["FORMATS", "render_frames", "render_video"]

#: Video formats by extension.
FORMATS = (".mp4", ".gif")
#: Frames posed together (forward kinematics); memory does not grow with the length.
FK_CHUNK = 128
#: Frame rate of a video of a simulated config, by extension (the CLI's default).
DEFAULT_FPS = {".mp4": 30.0, ".gif": 25.0}


def _motion_from(source, seconds: float | None, fps: float | None):
    """The motion to render: a Motion as given, or a BVH file read; cut and resampled."""
    from quadsim.skeleton.motion import Motion

    if not isinstance(source, Motion):
        path = Path(source)
        if path.suffix.lower() != ".bvh":
            raise ValueError(f"render_video takes a Motion or a .bvh file, got {str(path)!r}; "
                             "simulate the config first and pass its motion")
        from quadsim.io.bvh import read_bvh

        source = read_bvh(path, units=None)
    motion = source
    if seconds is not None:
        motion = motion.time_slice(0.0, seconds + 0.5 / motion.fps)
    if fps is not None and abs(fps - motion.fps) > 1e-9:
        motion = motion.resample(fps)
    return motion


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
        With ``extras["ground"]`` (T, 4) the body is drawn on that ground
        (:func:`~quadsim.viz.terrain.motion_ground`), else on ``y = 0``.
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
    if character is not None and sorted(character.skeleton.names) == sorted(
            motion.skeleton.names):
        # the character's body, its joints picked out of the motion's order
        # (a BVH file lists them depth first)
        perm = motion.skeleton.indices(character.skeleton.names)
        body = BodyMesh.from_character(character)
        scale = character.hip_height
    else:
        perm = np.arange(motion.skeleton.n_joints)
        body = BodyMesh.from_skeleton(motion.skeleton)
        scale = body_scale(motion.skeleton)
    scene = Scene(body, scale, size=size, off_screen=True, camera=camera,
                  anti_aliasing=anti_aliasing)
    try:
        from quadsim.viz.terrain import motion_ground

        ground = motion_ground(motion, cell=scene.spacing / GROUND_SUB)
        dt = 1.0 / motion.fps
        for k in range(len(motion)):
            if k % FK_CHUNK == 0:   # forward kinematics a chunk at a time: memory stays flat
                if k:
                    # the encoders and pyvista leave reference cycles behind every frame;
                    # collect them here so that they cannot pile up over a long video
                    gc.collect()
                part = motion[k:k + FK_CHUNK]
                G = part.world_rotations()[:, perm]
                P = part.world_positions()[:, perm]
                H = _headings(part)
            i = k % FK_CHUNK
            scene.set_pose(G[i], P[i], H[i], ground=ground)
            scene.update_camera(dt if k else 0.0)
            yield scene.image()
            if progress is not None:
                progress(k + 1)
    finally:
        scene.close()


def render_video(source, path: str | os.PathLike, *, size=(640, 480), camera: str = "follow",
                 progress: bool = True, fps: float | None = None, seconds: float | None = None,
                 anti_aliasing: str | None = None, quality: float = 7.0) -> Path:
    """Render a motion to an ``.mp4`` or ``.gif`` file off screen, whole or not at all.

    Parameters
    ----------
    source : Motion, or str or path-like
        A motion, or a ``.bvh`` file (read with its unit detected, see
        :func:`quadsim.io.bvh.read_bvh`).
    path : str or path-like
        Output file; the format follows the extension (``.mp4`` or ``.gif``).
        A symbolic link is written through; a read-only file is refused.
    size : (int, int) or str
        ``(width, height)`` in pixels or ``"WxH"``; even numbers for ``.mp4``.
    camera : {"follow", "side", "top"}
        Behind and to the left of the character, turning with it; from its
        left side; or from above.
    progress : bool or callable
        True prints a progress bar on stderr; a callable receives the number
        of frames done.
    fps : float, optional
        Frame rate of the video (the motion is resampled); default the motion's.
    seconds : float, optional
        Duration to render (the motion is cut).
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
        For an unsupported extension, camera or size, odd MP4 dimensions, a
        source that is neither a motion nor a BVH file, or a motion without
        frames.
    InputError
        When the file cannot be written (a full disk, a read-only file, an
        encoder failure): the message names the file and the reason, and an
        existing file is left as it was.
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
    from quadsim.viz.video import open_stream

    motion = _motion_from(source, seconds, fps)
    if len(motion) == 0:
        raise ValueError("the motion has no frames to render")
    bar = progress if callable(progress) else (
        _Progress(f"render {path.name}", len(motion)) if progress else None)
    with atomic_output(path, suffix=ext, make_folder=True) as tmp:
        frames = render_frames(motion, size=(w, h), camera=camera,
                               anti_aliasing=anti_aliasing, progress=bar)
        stream = None
        try:
            for img in frames:
                check_signals()     # a signal swallowed inside VTK still stops the render
                if stream is None:  # after the first frame: the heavy imports are done
                    stream = open_stream(tmp, ext, (w, h), motion.fps, quality)
                stream.append(img)
        except BaseException:
            if stream is not None:
                stream.abort()
            frames.close()
            raise
        stream.close()
    return path
