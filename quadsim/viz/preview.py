"""Steer a character live in a pyvista window.

:class:`Preview` steps a controller in real time, poses the body, scrolls the
ground under it and follows it with the camera. The controller is the
procedural one (:class:`~quadsim.locomotion.ProceduralController`, every
character) or, in the data mode (a config's ``mode = "data"``, or
``Preview(..., mode="data")``), the data-driven horse
(:class:`~quadsim.horse.controller.HorseDataController`); both are stepped
through the one controller interface (:class:`quadsim.Controller`, made by
:func:`quadsim.make_controller`), so the keys, the text and the recording
work alike. In the data mode the ground grid follows
the controller's sloped ground (a config's ``slope_deg`` commands). Its two
working parts are plain methods, so they can be driven and tested without a
window or an event loop:

- :meth:`Preview.on_key` handles a key by its name (VTK key symbols:
  ``"Up"``, ``"Left"``, ``"space"``, ``"3"``, ``"p"``);
- :meth:`Preview.update` advances the simulation by a wall-clock interval in
  fixed controller steps and updates the scene (no drawing);

:meth:`Preview.run` opens the window and calls both from pyvista's key and
timer events. Keys:

=============  ==============================================================
Up / Down      faster / slower (one speed step)
Left / Right   turn left / right (the wanted heading moves 15 degrees)
1 ... 9        hold a gait at its preferred speed: procedural mode, in the
               character's gait order (``quadsim characters`` lists it);
               data mode, the clip database's gaits (the horse: walk, amble,
               trot, rack, canter, gallop), at the mean of their clips' speeds
0              gaits chosen by speed again
Space          leap: the data mode goes to the leap's gallop, leaps once and
               comes back; the procedural mode has no leap and ignores it
P              pause / resume
R              start / stop recording; on stop the recorded frames are
               written as a BVH file
H              show / hide the help
Q, Escape      quit
=============  ==============================================================

A preview started from a run configuration plays the config's commands until
the first steering key; from then on the keys steer.
"""

from __future__ import annotations

import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from quadsim.frames import wrap_angle
from quadsim.api import MODES, make_controller
from quadsim.viz.scene import display_available

__all__ = ["HELP", "LEAP_HELP", "Preview", "display_available", "resolve_source"]

HELP = """\
Up / Down      faster / slower
Left / Right   turn left / right (15 deg a press)
1-{n}            hold a gait:
               {gaits}
0              gaits chosen by speed
Space          {leap}
P              pause        R  start / stop recording (BVH)
H              this help    Q  quit"""

#: The Space line of :data:`HELP` in each mode.
LEAP_HELP = {
    "data": "leap (to a gallop, one leap, back)",
    "procedural": "leap: data mode only (--mode data, the horse);\n"
                  "               ignored in the procedural mode",
}

#: Most controller steps one update may take (slower frames drop time).
MAX_STEPS_PER_UPDATE = 8
#: How much a Left / Right press turns the wanted heading (rad).
TURN_STEP = math.radians(15.0)
#: Interval between updates of the on-screen text (s of wall time).
HUD_INTERVAL = 0.1


def resolve_source(source):
    """What a preview of ``source`` shows: ``(character, script or None, seed, mode or None)``.

    Parameters
    ----------
    source : Character, RunConfig, or str
        A character, a run configuration, a character identifier, a config
        file path or a character file path.
    """
    from quadsim.config import RunConfig, load_config
    from quadsim.skeleton.character import Character, load_character

    if isinstance(source, Character):
        return source, None, 0, None
    if isinstance(source, RunConfig):
        return source.load_character(), source.commands, source.seed, source.mode
    text = str(source)
    if text.endswith(".toml") and Path(text).is_file():
        try:
            cfg = load_config(text)
        except ValueError:
            return load_character(text), None, 0, None  # a character file
        return cfg.load_character(), cfg.commands, cfg.seed, cfg.mode
    return load_character(text), None, 0, None


class Preview:
    """A live, steerable view of one character.

    Parameters
    ----------
    source : Character, RunConfig, or str
        A character, a run configuration (its commands play until the first
        steering key), a character identifier or a config file path.
    mode : {"procedural", "data"}, optional
        The controller: default the config's ``mode``, else procedural.
        ``"data"`` needs a character with a clip database (the horse).
    size : (int, int) or str
        Window size in pixels (``(960, 640)`` or ``"960x640"``).
    off_screen : bool
        Render without a window (tests, benchmarks, screenshots).
    camera : {"follow", "side", "top"}
    dt : float
        Fixed controller step (s).
    seed : int, optional
        Controller seed (default: the config's, else 0).
    record_dir : str or path-like
        Folder for recordings (``<character>-NNN.bvh``).

    Attributes
    ----------
    mode : str
        ``"procedural"`` or ``"data"``.
    live, controller : Controller
        The controller (:class:`~quadsim.locomotion.ProceduralController` or
        :class:`~quadsim.horse.controller.HorseDataController`), both names
        for the same object.
    gaits : dict of str to Gait
        The character's (procedural) gait table.
    gait_order : list of str
        The gaits of the number keys 1, 2, ...
    max_speed : float
        Fastest speed the keys ask for (m/s).
    scene : Scene
    speed_command : float
        Wanted speed (m/s).
    heading_command : float
        Wanted heading (rad).
    gait_command : str or None
        Held gait (None: chosen by speed).
    slope_command : float
        Ground slope passed on (rad; data mode): the config's, held when the
        keys take over.
    paused, recording, show_help : bool
    leap_requested : bool
        A leap was asked for and not yet passed to the controller.
    last_recording : Path or None
        The BVH file the last recording went to.
    message : str
        The last event, shown on screen.

    Raises
    ------
    InputError
        An unknown ``mode``, or ``"data"`` for a character without a clip
        database.
    """

    def __init__(self, source, *, mode: str | None = None, size=(960, 640),
                 off_screen: bool = False, camera: str = "follow", dt: float = 1.0 / 60.0,
                 seed: int | None = None, record_dir: str | os.PathLike = "out"):
        from quadsim.locomotion.gaits import gait_table
        from quadsim.viz.body import BodyMesh
        from quadsim.viz.scene import Scene

        character, script, cfg_seed, cfg_mode = resolve_source(source)
        self.mode = str(mode or cfg_mode or MODES[0])
        self.character = character
        self.script = script
        self.dt = float(dt)
        first = script.commands[0] if script is not None else None
        self.live = make_controller(
            character, self.mode, dt=self.dt, seed=cfg_seed if seed is None else int(seed),
            gait=first.gait if first is not None and self.mode == "procedural" else None)
        self.controller = self.live
        self.gaits = gait_table(character)
        self.gait_order = list(self.live.gait_order)
        self.max_speed = float(self.live.max_speed)
        self.speed_step = max(0.05, round(self.max_speed / 24.0, 2))
        self.record_dir = Path(record_dir)
        self.body = BodyMesh.from_character(character)
        self.off_screen = bool(off_screen)
        self.scene = Scene(self.body, character.hip_height, size=size, off_screen=off_screen,
                           camera=camera, title=f"quadsim preview: {character.name}")
        self.plotter = self.scene.plotter

        self.manual = script is None
        self.speed_command = (float(first.speed) if first is not None
                              else self.live.preferred_speed(self.live.auto_gaits[0]))
        self.heading_command = 0.0
        self.gait_command = first.gait if first is not None else None
        self.slope_command = float(first.slope) if first is not None else 0.0
        self.paused = False
        self.recording = False
        self.show_help = False
        self.leap_requested = False
        self.last_recording: Path | None = None
        self.message = "H: help"
        self.time = 0.0
        self.steps = 0
        self.fps = 0.0
        self._acc = 0.0
        self._last_wall: float | None = None
        self._tick: float | None = None
        self._hud_wall = -1.0
        self._rec: list = []

        # one corner annotation: the status upper left, the help lower left
        self._text = self.plotter.add_text(" ", position="upper_left", font_size=12,
                                           color="#1d2a36", font="courier",
                                           name="quadsim-hud")
        # frame 0: the starting state (as simulate does)
        self._show([self.live.step(self.command(), 0.0)], record=False)
        self.scene.rig.reset()
        self.scene.update_camera(0.0)
        self._update_text(force=True)

    # -------------------------------------------------------------- state
    @property
    def root(self) -> np.ndarray:
        """World position of the root joint (m), shape (3,)."""
        return self._P[0].copy()

    @property
    def gait(self) -> str:
        """The controller's gait label (``"trot"``, ``"walk->trot"``, ``"leap"``, ``"stand"``)."""
        return self.live.gait

    @property
    def speed(self) -> float:
        """The controller's speed (m/s)."""
        return self.live.speed

    @property
    def heading(self) -> float:
        """The controller's heading (rad)."""
        return self.live.heading

    @property
    def world_positions(self) -> np.ndarray:
        """Joint world positions of the shown frame, shape (J, 3)."""
        return self._P.copy()

    @property
    def recorded_frames(self) -> int:
        """Controller steps recorded so far."""
        return len(self._rec)

    def command(self):
        """The :class:`~quadsim.commands.Command` the next step will get."""
        from quadsim.commands import Command

        if not self.manual and self.script is not None:
            c = self.script.command_at(self.time)
            if self.leap_requested:
                from dataclasses import replace

                c = replace(c, leap=True)
            return c
        return Command(speed=self.speed_command, heading=self.heading_command,
                       gait=self.gait_command, leap=self.leap_requested,
                       slope=self.slope_command)

    def _take_control(self) -> None:
        """Leave the config's script: the keys steer from the current state."""
        if self.manual:
            return
        c = self.script.command_at(self.time)
        self.speed_command = float(c.speed)
        self.gait_command = c.gait
        self.heading_command = float(c.heading) if c.heading is not None else self.heading
        self.slope_command = float(c.slope)
        self.manual = True

    def _speed_cap(self) -> float:
        if self.gait_command:
            return min(self.max_speed, self.live.gait_speed_cap(self.gait_command))
        return self.max_speed

    # ---------------------------------------------------------------- keys
    def on_key(self, name: str) -> bool:
        """Handle a key by its VTK key symbol; returns whether it did anything.

        Parameters
        ----------
        name : str
            ``"Up"``, ``"Down"``, ``"Left"``, ``"Right"``, ``"0"`` to ``"9"``,
            ``"space"``, ``"p"``, ``"r"``, ``"h"`` (letters in either case).
        """
        key = str(name)
        low = key.lower()
        if low in ("up", "down"):
            self._take_control()
            sign = 1.0 if low == "up" else -1.0
            want = self.speed_command + sign * self.speed_step
            cap = self._speed_cap()
            self.speed_command = float(np.clip(want, 0.0, cap))
            self.message = f"speed {self.speed_command:.2f} m/s"
            if want > cap + 1e-9:
                who = self.gait_command.replace("_", " ") if self.gait_command else "fastest gait"
                self.message += f" (the {who} tops out at {cap:.2f} m/s)"
        elif low in ("left", "right"):
            self._take_control()
            sign = 1.0 if low == "left" else -1.0
            self.heading_command = float(self.heading_command + sign * TURN_STEP)
            self.message = f"heading {math.degrees(wrap_angle(self.heading_command)):+.0f} deg"
        elif low.isdigit() and len(low) == 1:
            k = int(low)
            if k == 0:
                self._take_control()
                self.gait_command = None
                self.message = "gaits chosen by speed"
            elif k <= len(self.gait_order):
                self._take_control()
                g = self.gait_order[k - 1]
                self.gait_command = g
                self.speed_command = float(self.live.preferred_speed(g))
                self.message = (f"gait {g.replace('_', ' ')} at "
                                f"{self.speed_command:.2f} m/s")
            else:
                return False
        elif low in ("space", " "):
            self.leap_requested = True
            if self.mode == "data":
                self.message = "leap: to a gallop, one leap, then back"
            else:
                self.message = ("leap requested: the procedural mode has none (the horse's "
                                "data mode leaps: --mode data)")
        elif low == "p":
            self.paused = not self.paused
            self.message = "paused" if self.paused else "running"
        elif low == "r":
            if self.recording:
                path = self.stop_recording()
                self.message = (f"wrote {path}" if path is not None
                                else "recording stopped: no frames")
            else:
                self.start_recording()
                self.message = "recording"
        elif low in ("h", "question"):
            self.show_help = not self.show_help
        else:
            return False
        self._update_text(force=True)
        return True

    # ----------------------------------------------------------- recording
    def start_recording(self) -> None:
        """Record every controller step from now on."""
        self.recording = True
        self._rec = []

    def recorded_motion(self):
        """The frames recorded so far as a :class:`~quadsim.skeleton.motion.Motion` (or None).

        It has the steps' contacts, gait labels and per-frame extras
        (procedural: ``phase``, ``spine``, ``duty``, ``speed``, ``heading``;
        data: ``heading``, ``pitch``, ``ground``).
        """
        from quadsim.skeleton.motion import Motion

        if not self._rec:
            return None
        fr = self._rec
        extras = {k: np.stack([f.extras[k] for f in fr]) for k in fr[0].extras}
        return Motion.from_matrices(
            self.character.skeleton, 1.0 / self.dt, np.stack([f.root for f in fr]),
            np.stack([f.local_rotations for f in fr]),
            contacts=np.stack([f.contacts for f in fr]),
            gaits=np.array([f.gait for f in fr], dtype=object),
            foot_joints=self.character.foot_joints, extras=extras)

    def stop_recording(self, path: str | os.PathLike | None = None) -> Path | None:
        """Stop recording and write the frames as BVH.

        Parameters
        ----------
        path : str or path-like, optional
            Default: the next free ``<record_dir>/<character>-NNN.bvh``.

        Returns
        -------
        Path or None
            The file written, None when nothing was recorded.
        """
        from quadsim.io.bvh import write_bvh

        self.recording = False
        motion = self.recorded_motion()
        self._rec = []
        if motion is None:
            return None
        if path is None:
            self.record_dir.mkdir(parents=True, exist_ok=True)
            n = 1
            while (self.record_dir / f"{self.character.id}-{n:03d}.bvh").exists():
                n += 1
            path = self.record_dir / f"{self.character.id}-{n:03d}.bvh"
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        write_bvh(motion, path)
        self.last_recording = path
        return path

    # -------------------------------------------------------------- frames
    def update(self, dt: float) -> int:
        """Advance by ``dt`` seconds of wall time and update the scene (no drawing).

        The controller takes as many fixed steps as the time owed allows (at
        most ``MAX_STEPS_PER_UPDATE``; a slower frame drops the rest). Paused,
        it takes none; the camera and text still update.

        Returns
        -------
        int
            Controller steps taken.
        """
        if not (math.isfinite(dt) and dt >= 0):
            raise ValueError(f"dt must be a non-negative number of seconds, got {dt!r}")
        now = time.perf_counter()
        if self._last_wall is not None:
            gap = now - self._last_wall
            if gap > 0:
                self.fps = 1.0 / gap if self.fps == 0 else 0.9 * self.fps + 0.1 / gap
        self._last_wall = now
        n = 0
        if not self.paused:
            self._acc += dt
            n = math.floor(self._acc / self.dt + 1e-9)
            if n > MAX_STEPS_PER_UPDATE:
                n = MAX_STEPS_PER_UPDATE
                self._acc = 0.0
            else:
                self._acc = max(self._acc - n * self.dt, 0.0)
            if n:
                frames = []
                for _ in range(n):
                    frames.append(self.live.step(self.command(), self.dt))
                    self.leap_requested = False
                    self.time += self.dt
                self.steps += n
                self._show(frames, record=self.recording)
        self.scene.update_camera(dt)
        self._update_text()
        return n

    def _show(self, frames: list, record: bool) -> None:
        if record:
            self._rec.extend(frames)
        G, P = frames[-1].world_rotations, frames[-1].positions
        self._P = P
        self.scene.set_pose(G, P, frames[-1].heading, ground=self.live.ground)

    def _update_text(self, force: bool = False) -> None:
        now = time.perf_counter()
        if not force and now - self._hud_wall < HUD_INTERVAL:
            return
        self._hud_wall = now
        cmd = self.command()
        held = (cmd.gait.replace("_", " ") + " held") if cmd.gait else "auto"
        mode = "keys" if self.manual else "config script (a steering key takes over)"
        if cmd.heading is not None:
            turn = f"wanted {math.degrees(wrap_angle(cmd.heading)):+.0f}"
        else:
            turn = f"turning {math.degrees(cmd.turn_rate or 0.0):+.0f} deg/s"
        lines = [
            f"{self.character.name} ({self.mode})   gait {self.gait.replace('_', ' ')} ({held})",
            f"speed {self.speed:5.2f} m/s  (wanted {cmd.speed:.2f})",
            f"heading {math.degrees(wrap_angle(self.heading)):+5.0f} deg  ({turn})",
            f"{self.fps:4.0f} fps   t {self.time:6.1f} s   {mode}",
        ]
        ground = self.live.ground
        if ground is not None:
            lines.insert(3, f"ground slope {math.degrees(ground.slope):+.1f} deg")
        if self.paused:
            lines.append("PAUSED (P resumes)")
        if self.recording:
            lines.append(f"REC {self.recorded_frames} frames (R stops and writes BVH)")
        lines.append(self.message)
        if self.show_help:
            items = [f"{i + 1} {g.replace('_', ' ')}" for i, g in enumerate(self.gait_order)]
            names = "\n               ".join(", ".join(items[k:k + 3])
                                               for k in range(0, len(items), 3))
            help_text = HELP.format(n=len(self.gait_order), gaits=names,
                                    leap=LEAP_HELP[self.mode])
        else:
            help_text = "H: help"
        self._text.SetText(2, "\n".join(lines))
        self._text.SetText(0, help_text)

    # --------------------------------------------------------------- window
    def render(self) -> None:
        """Draw the current frame."""
        self.scene.render()

    def screenshot(self, path: str | os.PathLike | None = None) -> np.ndarray:
        """Draw and return the frame as RGB (H, W, 3), writing it to ``path`` if given."""
        self.render()
        return self.plotter.screenshot(filename=None if path is None else str(path),
                                       return_img=True)

    def frame(self, dt: float | None = None) -> None:
        """One frame: :meth:`update` by ``dt`` (default one step) and :meth:`render`."""
        self.update(self.dt if dt is None else dt)
        self.render()

    def _bind_keys(self) -> None:
        iren = self.plotter.iren
        iren.clear_key_event_callbacks()
        keys = ["Up", "Down", "Left", "Right", "space", "p", "P", "r", "R", "h", "H",
                "question"] + [str(k) for k in range(10)]
        for k in keys:
            self.plotter.add_key_event(k, lambda k=k: self.on_key(k))
        for k in ("q", "Q", "Escape"):
            self.plotter.add_key_event(k, self._quit)
        # VTK's default character keys (w, s, 3 for stereo, r to reset the camera...)
        # would fight the preview's: an observer on the style replaces them
        style = iren.interactor.GetInteractorStyle()
        if style is not None:
            style.AddObserver("CharEvent", lambda *a: None)

    def _quit(self) -> None:
        if self.recording:
            path = self.stop_recording()
            if path is not None:
                print(f"wrote {path}", file=sys.stderr)
        self.plotter.close()

    def _on_timer(self, _step) -> None:
        now = time.perf_counter()
        dt = now - self._tick if self._tick is not None else self.dt
        self._tick = now
        self.update(min(dt, MAX_STEPS_PER_UPDATE * self.dt))

    def run(self) -> None:
        """Open the window and run until it is closed (Q or Escape).

        Raises
        ------
        RuntimeError
            For an off-screen preview, or without a display.
        """
        if self.off_screen:
            raise RuntimeError("this Preview renders off screen; create it with "
                               "off_screen=False to open a window")
        if not display_available():
            raise RuntimeError("no display: set DISPLAY (or WAYLAND_DISPLAY) to open a "
                               "window, or render a video off screen with `quadsim render`")
        self._bind_keys()
        self._tick = None
        interval = max(round(1000.0 * self.dt), 1)
        self.plotter.add_timer_event(max_steps=2**31 - 1, duration=interval,
                                     callback=self._on_timer)
        try:
            self.plotter.show(auto_close=False, interactive_update=False)
        finally:
            if self.recording:
                self.stop_recording()

    def close(self) -> None:
        """Release the window and its graphics resources."""
        self.scene.close()

