"""The 3-D scene shared by the preview and the video renderer (pyvista).

A :class:`Scene` holds one :class:`pyvista.Plotter` with

- the character's :class:`~quadsim.viz.body.BodyMesh` (one actor, posed in
  place each frame),
- a ground plane and grid that follow the character in whole grid cells, so
  the lines stay fixed in the world and scroll under it; given a height field
  (the data-driven horse's sloped :class:`~quadsim.horse.slope.Ground`), the
  plane and the grid follow its heights, sampled at a quarter of a grid cell
  (a recorded motion's ground is rebuilt by :mod:`quadsim.viz.terrain`),
- a soft blob shadow under the body,
- a :class:`CameraRig`: ``"follow"`` (behind and to the left, turning with
  the heading), ``"side"`` (from the character's left) or ``"top"``.

pyvista is imported when a scene is built, never at module import.
"""

from __future__ import annotations

import math
import os
import sys

import numpy as np

from quadsim.frames import X, Z

__all__ = ["CAMERAS", "CameraRig", "Scene", "display_available", "grid_spacing", "parse_size"]

#: Camera modes.
CAMERAS = ("follow", "side", "top")
#: Samples per grid cell of a sloped ground: a crease between two ramps is
#: drawn at most ``spacing / GROUND_SUB / 4 * tan(slope)`` off.
GROUND_SUB = 4
SKY = "#dfe8ef"
GROUND = "#c9c3b3"
GRID = "#9d9684"
SHADOW = "#a29c8d"


def display_available() -> bool:
    """Whether a window can be opened: on Linux, ``DISPLAY`` or ``WAYLAND_DISPLAY`` is set."""
    if sys.platform.startswith("linux") or "bsd" in sys.platform:
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def grid_spacing(scale: float) -> float:
    """A round grid spacing near ``scale`` (m): 0.1, 0.25, 0.5, 1, 2 or 5."""
    steps = np.array([0.1, 0.25, 0.5, 1.0, 2.0, 5.0])
    return float(steps[np.argmin(np.abs(np.log(steps / max(scale, 1e-6))))])


def parse_size(text) -> tuple[int, int]:
    """``"640x480"`` or ``(640, 480)`` as ``(width, height)`` pixels.

    Raises
    ------
    ValueError
        Unless both are whole numbers from 16 to 8192.
    """
    if isinstance(text, str):
        parts = text.lower().replace("*", "x").split("x")
        if len(parts) != 2:
            raise ValueError(f"size {text!r}: expected WIDTHxHEIGHT, e.g. 640x480")
        try:
            w, h = int(parts[0]), int(parts[1])
        except ValueError:
            raise ValueError(f"size {text!r}: expected WIDTHxHEIGHT in whole pixels, "
                             "e.g. 640x480") from None
    else:
        try:
            w, h = (int(v) for v in text)
        except (TypeError, ValueError):
            raise ValueError(f"size {text!r}: expected (width, height) in pixels") from None
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise ValueError(f"size {w}x{h}: width and height must be from 16 to 8192 pixels")
    return w, h


class CameraRig:
    """A camera that follows a character smoothly.

    Parameters
    ----------
    mode : {"follow", "side", "top"}
    scale : float
        Body size (m, the hip height): distances are multiples of it.
    lag : float
        Time constant (s) of the camera turning after the body's heading
        (0 turns rigidly with it); the camera keeps its distance to the body
        rigidly, so a fast gallop stays in the middle of the frame.
    """

    def __init__(self, mode: str = "follow", scale: float = 1.0, lag: float = 0.6):
        if mode not in CAMERAS:
            raise ValueError(f"camera {mode!r}: choose one of {', '.join(CAMERAS)}")
        self.mode = mode
        self.scale = float(scale)
        self.lag = float(lag)
        self._target: np.ndarray | None = None
        self._heading = 0.0

    def reset(self) -> None:
        """Snap to the body on the next update."""
        self._target = None

    def update(self, root, heading: float, dt: float, floor: float = 0.0):
        """Camera position, focal point and view-up for the body centred at ``root`` (3,).

        Parameters
        ----------
        root : array-like, shape (3,)
        heading : float
            The body's heading (rad).
        dt : float
            Time since the last update (s).
        floor : float
            Height of the ground under the body (m): the camera aims that
            much higher.

        Returns
        -------
        position, focal_point, view_up : ndarray, shape (3,)
        """
        root = np.asarray(root, dtype=float)
        s = self.scale
        want = np.array([root[X], (0.6 if self.mode == "side" else 0.75) * s + float(floor),
                         root[Z]])
        if self._target is None:
            self._heading = float(heading)
        elif self.lag > 0:
            a = 1.0 - math.exp(-max(dt, 0.0) / self.lag)
            dh = (float(heading) - self._heading + math.pi) % (2 * math.pi) - math.pi
            self._heading += a * dh
        else:
            self._heading = float(heading)
        self._target = want
        t = self._target
        h = self._heading
        if self.mode == "top":
            pos = t + np.array([0.0, 9.0 * s, 0.0])
            up = np.array([math.sin(h), 0.0, math.cos(h)])
            return pos, t.copy(), up
        if self.mode == "side":
            az, elev, dist = math.radians(90.0), math.radians(6.0), 5.2 * s
        else:
            az, elev, dist = math.radians(118.0), math.radians(16.0), 6.2 * s
        a = h + az
        d = np.array([math.sin(a) * math.cos(elev), math.sin(elev), math.cos(a) * math.cos(elev)])
        return t + dist * d, t.copy(), np.array([0.0, 1.0, 0.0])


class Scene:
    """A character, the ground and a camera in one pyvista plotter.

    Parameters
    ----------
    body : BodyMesh
    scale : float
        The character's size (m, its hip height): sets the grid, the shadow
        and the camera distance.
    size : (int, int)
        Window or image size in pixels.
    off_screen : bool
        Render without a window (EGL or OSMesa where there is no display).
    camera : {"follow", "side", "top"}
    anti_aliasing : {None, "ssaa"}
        None is fastest (the preview, videos); "ssaa" (super-sampling) is for
        still pictures. (FXAA is not offered: VTK's EGL and OSMesa builds do
        not support it and fall back to SSAA.)
    title : str, optional
        Window title.
    """

    def __init__(self, body, scale: float, *, size=(640, 480), off_screen: bool = True,
                 camera: str = "follow", anti_aliasing: str | None = None,
                 title: str | None = None):
        import pyvista as pv

        if off_screen and not display_available() and sys.platform.startswith("linux"):
            # go straight to EGL instead of trying X first (and logging a warning)
            os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
        if anti_aliasing not in (None, "ssaa"):
            raise ValueError(f"anti_aliasing {anti_aliasing!r}: choose None or 'ssaa'")
        self.body = body
        self.scale = float(scale)
        self.size = parse_size(size)
        self.rig = CameraRig(camera, self.scale)
        theme = pv.themes.DocumentTheme()
        theme.anti_aliasing = None
        theme.background = SKY
        theme.window_size = list(self.size)
        kw = {"title": title} if title else {}
        self.plotter = pv.Plotter(off_screen=off_screen, window_size=list(self.size),
                                  theme=theme, lighting="light kit", **kw)
        if anti_aliasing:
            self.plotter.enable_anti_aliasing(anti_aliasing)
        self.plotter.set_background(SKY)
        self._ground()
        self._shadow()
        self.mesh = body.polydata()
        self.actor = self.plotter.add_mesh(self.mesh, scalars="rgb", rgb=True,
                                           show_scalar_bar=False, reset_camera=False,
                                           specular=0.15, specular_power=12.0)
        self.actor.prop.interpolation = "phong"

    # ------------------------------------------------------------ ground
    def _ground(self) -> None:
        import pyvista as pv

        self.spacing = grid_spacing(self.scale)
        n = self._cells = 24
        half = n * self.spacing
        plane = pv.Plane(center=(0.0, -0.002 * self.scale, 0.0), direction=(0.0, 1.0, 0.0),
                         i_size=2 * half, j_size=2 * half, i_resolution=1, j_resolution=1)
        ticks = np.arange(-n, n + 1) * self.spacing
        m = len(ticks)
        a = np.zeros((2 * m, 2, 3))
        a[:m, 0, X], a[:m, 1, X] = ticks, ticks
        a[:m, 0, Z], a[:m, 1, Z] = -half, half
        a[m:, 0, Z], a[m:, 1, Z] = ticks, ticks
        a[m:, 0, X], a[m:, 1, X] = -half, half
        pts = a.reshape(-1, 3)
        lines = np.hstack([np.full((2 * m, 1), 2), np.arange(4 * m).reshape(-1, 2)]).ravel()
        grid = pv.PolyData(pts, lines=lines)
        # unlit: the ground fills most of the frame, and lighting it costs more
        # than everything else in the scene with a software renderer
        self.ground_actor = self.plotter.add_mesh(plane, color=GROUND, lighting=False,
                                                  reset_camera=False)
        self.grid_actor = self.plotter.add_mesh(grid, color=GRID, line_width=1,
                                                reset_camera=False, lighting=False)
        self._relief = None          # the sloped ground's meshes, built on first use
        self._relief_key = None
        self._floor = 0.0

    def _build_relief(self) -> None:
        """Finer ground plane and grid lines (:data:`GROUND_SUB` samples a cell) whose
        heights follow a height field."""
        import pyvista as pv

        n, s, k = self._cells, self.spacing, GROUND_SUB
        half = n * s
        plane = pv.Plane(center=(0.0, 0.0, 0.0), direction=(0.0, 1.0, 0.0),
                         i_size=2 * half, j_size=2 * half, i_resolution=2 * n * k,
                         j_resolution=2 * n * k)
        ticks = np.arange(-n, n + 1) * s
        along = np.linspace(-half, half, 2 * n * k + 1)
        m, q = len(ticks), len(along)
        pts = np.zeros((2 * m, q, 3))
        pts[:m, :, X] = ticks[:, None]
        pts[:m, :, Z] = along[None, :]
        pts[m:, :, Z] = ticks[:, None]
        pts[m:, :, X] = along[None, :]
        pts = pts.reshape(-1, 3)
        idx = np.arange(2 * m * q).reshape(2 * m, q)
        segs = np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], axis=1)
        lines = np.hstack([np.full((len(segs), 1), 2), segs]).ravel()
        grid = pv.PolyData(pts, lines=lines)
        self.plotter.remove_actor(self.ground_actor, render=False)
        self.plotter.remove_actor(self.grid_actor, render=False)
        self.ground_actor = self.plotter.add_mesh(plane, color=GROUND, lighting=False,
                                                  reset_camera=False)
        self.grid_actor = self.plotter.add_mesh(grid, color=GRID, line_width=1,
                                                reset_camera=False, lighting=False)
        self._relief = (plane, np.array(plane.points), grid, np.array(grid.points))

    def _follow_ground(self, ground, offset) -> None:
        """Lift the plane and grid onto ``ground`` about the grid cell ``offset`` (x, z)."""
        if ground is None and self._relief is None:
            return
        key = None if ground is None else (id(ground), len(ground.ramps), offset)
        if key == self._relief_key:
            return
        if self._relief is None:
            self._build_relief()
        self._relief_key = key
        plane, plane0, grid, grid0 = self._relief
        for mesh, base, drop in ((plane, plane0, 0.002 * self.scale), (grid, grid0, 0.0)):
            pts = base.copy()
            if ground is not None:
                pts[:, 1] = ground.height(pts[:, [X, Z]] + np.asarray(offset)) - drop
            else:
                pts[:, 1] = -drop
            mesh.points = pts

    def _shadow(self) -> None:
        import pyvista as pv

        disc = pv.Disc(center=(0.0, 0.0, 0.0), inner=0.0, outer=1.0, normal=(0.0, 1.0, 0.0),
                       r_res=1, c_res=32)
        # opaque (a translucent actor would cost extra render passes)
        self.shadow_actor = self.plotter.add_mesh(disc, color=SHADOW, lighting=False,
                                                  reset_camera=False)

    # ------------------------------------------------------------ per frame
    def set_pose(self, world_rotations, world_positions, heading: float,
                 ground=None) -> None:
        """Pose the body and move the ground grid and shadow under it.

        Parameters
        ----------
        world_rotations : array-like, shape (J, 3, 3)
        world_positions : array-like, shape (J, 3)
        heading : float
            The body's heading (rad).
        ground : object, optional
            A height field with ``height(xz) -> y`` for points (..., 2) [x, z]
            and a ``ramps`` sequence whose length changes when it does
            (:class:`~quadsim.horse.slope.Ground`,
            :class:`~quadsim.viz.terrain.TrackGround`); None is the plane y = 0.
            The plane, the grid, the shadow and the camera follow it.
        """
        self.body.update(self.mesh, world_rotations, world_positions)
        root = np.asarray(world_positions, dtype=float)[0]
        s = self.spacing
        offset = (round(root[X] / s) * s, round(root[Z] / s) * s)
        self._follow_ground(ground, offset)
        self.grid_actor.SetPosition(offset[0], 0.0, offset[1])
        self.ground_actor.SetPosition(offset[0], 0.0, offset[1])
        P = np.asarray(world_positions, dtype=float)
        centre = P[self.body.focus].mean(axis=0)
        fwd = np.array([math.sin(heading), math.cos(heading)])
        along = (P[:, [X, Z]] - centre[[X, Z]]) @ fwd
        half_len = max(0.4 * float(np.ptp(along)), 0.3 * self.scale)
        self.shadow_actor.SetScale(0.24 * self.scale, 1.0, half_len)
        floor, pitch, roll = 0.0, 0.0, 0.0
        if ground is not None:
            # the ground's height and its gradient along and across the heading
            side = np.array([fwd[1], -fwd[0]])     # the body's local +X, horizontally
            c = centre[[X, Z]]
            d = 0.5 * half_len
            h = ground.height(np.stack([c, c + d * fwd, c - d * fwd, c + d * side,
                                        c - d * side]))
            floor = float(h[0])
            pitch = -math.degrees(math.atan2(h[1] - h[2], 2 * d))
            roll = math.degrees(math.atan2(h[3] - h[4], 2 * d))
        # VTK turns by Z (roll), then X (pitch), then Y (heading)
        self.shadow_actor.SetOrientation(pitch, math.degrees(heading), roll)
        self.shadow_actor.SetPosition(centre[X], floor + (0.001 if ground is None else 0.004)
                                      * self.scale, centre[Z])
        self._root = centre
        self._heading = float(heading)
        self._floor = floor

    def update_camera(self, dt: float) -> None:
        """Move the camera after the body (call after :meth:`set_pose`)."""
        pos, focal, up = self.rig.update(self._root, self._heading, dt, floor=self._floor)
        cam = self.plotter.renderer.GetActiveCamera()  # plain VTK: no per-call re-clipping
        cam.SetPosition(*pos)
        cam.SetFocalPoint(*focal)
        cam.SetViewUp(*up)
        dist = float(np.linalg.norm(pos - focal))
        cam.SetClippingRange(0.05 * dist, dist + 30.0 * self.spacing)
        self.plotter.renderer.camera_set = True  # keep pyvista from resetting it on show

    def render(self) -> None:
        """Draw the frame (also before the plotter has been shown, off screen)."""
        self.plotter.render_window.Render()

    def image(self) -> np.ndarray:
        """Render and return the frame as RGB, shape (height, width, 3), uint8."""
        self.render()
        return self.plotter.screenshot(return_img=True)

    def close(self) -> None:
        self.plotter.close()
