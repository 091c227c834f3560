"""Video encoders that take frames one at a time (memory independent of length).

- :class:`Mp4Stream`: H.264 in an MP4 container, through the ffmpeg that
  imageio-ffmpeg ships; frames go down a pipe as they come, and ffmpeg's exit
  status is checked, so a video that could not be written whole (a full disk)
  raises instead of passing for a finished one.
- :class:`GifStream`: an animated, looping GIF written frame by frame with
  Pillow's GIF encoder, each frame with its own 256-colour palette. GIF
  stores frame times in hundredths of a second; the times are rounded so
  that their running total stays on the frame rate's clock (at 30 fps the
  frames last 3, 3, 4, 3, 3, 4... hundredths).

Both write to the path they are given; :func:`quadsim.viz.render.render_video`
gives them a temporary file (:func:`quadsim.io.atomic.atomic_output`) and
moves it into place only once it is complete.
"""

from __future__ import annotations

import os
import subprocess
import tempfile
from fractions import Fraction

import numpy as np

from quadsim.errors import InputError

__all__ = ["GifStream", "Mp4Stream", "open_stream"]


class GifStream:
    """An animated GIF written one frame at a time.

    Parameters
    ----------
    path : str or path-like
    fps : float
        Frame rate (> 0).
    loop : int
        Times to play (0: forever).
    """

    def __init__(self, path, fps: float, loop: int = 0):
        self.fps = float(fps)
        self.loop = int(loop)
        self.count = 0
        self._file = open(path, "wb")  # noqa: SIM115  (closed by close or abort)

    def _centiseconds(self, k: int) -> int:
        """Duration of frame ``k`` in 1/100 s, keeping the running total on the clock."""
        return max(round((k + 1) * 100.0 / self.fps) - round(k * 100.0 / self.fps), 1)

    def append(self, frame) -> None:
        """Add a frame, an RGB uint8 array of shape (H, W, 3)."""
        from PIL import GifImagePlugin, Image

        img = Image.fromarray(np.asarray(frame, dtype=np.uint8), "RGB")
        img = img.convert("P", palette=Image.Palette.ADAPTIVE)
        ms = 10 * self._centiseconds(self.count)
        if self.count == 0:
            header, _ = GifImagePlugin.getheader(img, None, {"loop": self.loop,
                                                              "duration": ms})
            for part in header:
                self._file.write(part)
        for part in GifImagePlugin.getdata(img, (0, 0), duration=ms,
                                           include_color_table=True):
            self._file.write(part)
        self.count += 1

    def close(self) -> None:
        """Write the trailer and close the file (flushing it)."""
        if self._file.closed:
            return
        try:
            self._file.write(b";")
            self._file.flush()
        finally:
            self._file.close()

    def abort(self) -> None:
        """Close without finishing (the file is then to be discarded)."""
        if not self._file.closed:
            self._file.close()


class Mp4Stream:
    """An H.264 MP4 file encoded by an ffmpeg process fed through a pipe.

    Parameters
    ----------
    path : str or path-like
    size : (int, int)
        ``(width, height)`` in pixels, both even.
    fps : float
    quality : float
        0 to 10, imageio-ffmpeg's scale (x264's constant rate factor
        ``int((1 - quality / 10) * 51)``; the default 7 is CRF 15).
    """

    def __init__(self, path, size, fps: float, quality: float = 7.0):
        import imageio_ffmpeg

        w, h = (int(v) for v in size)
        self.size = (w, h)
        self.path = os.fspath(path)
        self.count = 0
        rate = Fraction(float(fps)).limit_denominator(100000)
        crf = int((1.0 - min(max(float(quality), 0.0), 10.0) / 10.0) * 51)
        cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-f", "rawvideo", "-vcodec", "rawvideo",
               "-s", f"{w}x{h}", "-pix_fmt", "rgb24", "-r", str(rate), "-i", "-", "-an",
               "-vcodec", "libx264", "-pix_fmt", "yuv420p", "-crf", str(crf),
               "-v", "error", "-f", "mp4", self.path]
        self._log = tempfile.TemporaryFile()  # noqa: SIM115  (closed by close or abort)
        # its own process group: a Ctrl-C at the terminal reaches quadsim, which
        # stops ffmpeg itself (and removes the unfinished file)
        kw = {"start_new_session": True} if os.name == "posix" else {}
        self._proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                      stderr=self._log, **kw)

    def _error(self, what: str) -> InputError:
        self._log.seek(0)
        text = self._log.read().decode("utf-8", "replace").strip()
        last = text.splitlines()[-1] if text else f"ffmpeg exit status {self._proc.returncode}"
        return InputError(f"{self.path}: {what} ({last})")

    def append(self, frame) -> None:
        """Add a frame, an RGB uint8 array of shape (H, W, 3)."""
        a = np.ascontiguousarray(frame, dtype=np.uint8)
        if a.shape != (self.size[1], self.size[0], 3):
            raise ValueError(f"frame has shape {a.shape}, expected "
                             f"({self.size[1]}, {self.size[0]}, 3)")
        try:
            self._proc.stdin.write(a.data)
        except (BrokenPipeError, OSError):
            self._proc.wait()
            raise self._error("the video encoder stopped") from None
        self.count += 1

    def close(self) -> None:
        """Finish the file and wait for ffmpeg; raises unless it succeeded."""
        try:
            self._proc.stdin.close()
        except OSError:
            pass
        code = self._proc.wait()
        try:
            if code != 0:
                raise self._error("the video could not be written")
        finally:
            self._log.close()

    def abort(self) -> None:
        """Stop ffmpeg at once (the file is then to be discarded)."""
        if self._proc.poll() is None:
            self._proc.kill()
        try:
            self._proc.stdin.close()
        except OSError:
            pass
        self._proc.wait()
        self._log.close()


def open_stream(path, ext: str, size, fps: float, quality: float = 7.0):
    """A :class:`Mp4Stream` (``ext == ".mp4"``) or a :class:`GifStream` (``".gif"``)."""
    if ext == ".mp4":
        return Mp4Stream(path, size, fps, quality)
    if ext == ".gif":
        return GifStream(path, fps)
    raise ValueError(f"no video encoder for {ext!r} files; supported: .mp4, .gif")
