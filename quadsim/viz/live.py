"""One interface over the controllers the live preview steers.

The preview (:mod:`quadsim.viz.preview`) steps a controller once per fixed
time step and shows, records and labels what comes out. The two controllers
of quadsim differ in what they return and what they know, so each gets a
small adapter presenting the same :class:`LiveController` interface:

- :class:`ProceduralLive` wraps a
  :class:`~quadsim.locomotion.ProceduralController` (``mode = "procedural"``,
  every character): gaits of the character's gait table.
- :class:`DataLive` wraps a
  :class:`~quadsim.horse.controller.HorseDataController` (``mode = "data"``, a
  character with a clip database: the horse): gaits of the clip database
  (walk, amble, trot, rack, canter, gallop), leaps, sloped ground.

:func:`live_controller` picks one by mode. Each step returns a
:class:`LiveFrame`: the pose (local rotations and root, from which the world
positions follow), the gait label, the heading and what a recording keeps.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["MODES", "DataLive", "LiveController", "LiveFrame", "ProceduralLive",
           "check_mode", "live_controller"]

#: Controller modes, as a config's ``mode``.
MODES = ("procedural", "data")


@dataclass
class LiveFrame:
    """One controller step, posed.

    Attributes
    ----------
    skeleton : Skeleton
    local_rotations : ndarray, shape (J, 3, 3)
        Joint rotations relative to the parent (the root's is its world
        orientation).
    root : ndarray, shape (3,)
        World position of the root joint (m).
    heading : float
        The body's heading (rad, 0 faces +Z, positive left).
    gait : str
        Gait label: a gait, a transition (``"walk->trot"``), ``"leap"`` or
        ``"stand"``.
    contacts : ndarray, shape (4,), bool
        Feet on the ground (LF, RF, LH, RH).
    extras : dict of str to ndarray
        Per-frame channels kept in a recording's ``Motion.extras``.
    """

    skeleton: object
    local_rotations: np.ndarray
    root: np.ndarray
    heading: float
    gait: str
    contacts: np.ndarray
    extras: dict = field(default_factory=dict)
    _world: tuple | None = field(default=None, repr=False)

    def world(self) -> tuple[np.ndarray, np.ndarray]:
        """World rotations (J, 3, 3) and positions (J, 3) of every joint (computed once)."""
        if self._world is None:
            from quadsim.skeleton.fk import forward_kinematics

            self._world = forward_kinematics(self.skeleton, self.local_rotations, self.root)
        return self._world

    @property
    def positions(self) -> np.ndarray:
        """World joint positions (m), shape (J, 3)."""
        return self.world()[1]


@runtime_checkable
class LiveController(Protocol):
    """What the preview needs of a controller.

    Attributes
    ----------
    mode : str
        ``"procedural"`` or ``"data"``.
    character : Character
    controller : object
        The wrapped controller.
    gait_order : list of str
        The gaits the number keys hold, in order (1 is the first).
    auto_gaits : list of str
        The gaits chosen by speed, slowest first.
    max_speed : float
        Fastest speed (m/s) the controller is asked for.
    ground : object or None
        The ground's height field (``height(xz) -> y``), None for flat ground.
    """

    mode: str
    character: object
    controller: object
    gait_order: list
    auto_gaits: list
    max_speed: float

    @property
    def ground(self): ...

    @property
    def speed(self) -> float:
        """The speed being played (m/s)."""

    @property
    def heading(self) -> float:
        """The body's heading (rad)."""

    @property
    def gait(self) -> str:
        """The last frame's gait label."""

    def preferred_speed(self, gait: str) -> float:
        """The speed (m/s) a number key sets with its gait."""

    def gait_speed_cap(self, gait: str) -> float:
        """The fastest speed (m/s) a held gait is asked for."""

    def step(self, command, dt: float) -> LiveFrame:
        """Advance one step of ``dt`` seconds under ``command``."""


class ProceduralLive:
    """The procedural controller behind the :class:`LiveController` interface.

    Parameters
    ----------
    character : Character
    dt : float
        Fixed step (s).
    seed : int
    gait : str, optional
        Starting gait (a config's first command's).
    """

    mode = "procedural"

    def __init__(self, character, *, dt: float, seed: int = 0, gait: str | None = None):
        from quadsim.locomotion import ProceduralController

        self.character = character
        self.controller = ProceduralController(character, dt=dt, seed=seed, gait=gait)
        self.gait_order = list(self.controller.gait_order)
        self.auto_gaits = list(self.controller.auto_gaits)
        self.max_speed = float(self.controller.max_speed)

    ground = None

    @property
    def speed(self) -> float:
        return float(self.controller.speed)

    @property
    def heading(self) -> float:
        return float(self.controller.heading)

    @property
    def gait(self) -> str:
        return self.controller.gait

    def preferred_speed(self, gait: str) -> float:
        """The gait table's preferred speed (m/s)."""
        return self.controller.preferred_speed(gait)

    def gait_speed_cap(self, gait: str) -> float:
        """The controller's cap for a requested gait (15 % above its range), at most
        :attr:`max_speed`."""
        return self.controller.gait_speed_cap(gait)

    def step(self, command, dt: float) -> LiveFrame:
        """One controller step, posed (the frame's channels kept as extras)."""
        f = self.controller.step(command, dt)
        extras = {k: np.array(f.extras[k], dtype=float)
                  for k in ("phase", "spine", "duty", "speed", "heading")}
        return LiveFrame(self.character.skeleton, np.array(f.local_rotations), np.array(f.root),
                         f.heading, f.gait, np.array(f.contacts), extras)


class DataLive:
    """The data-driven horse controller behind the :class:`LiveController` interface.

    A thin wrapper: :class:`~quadsim.horse.controller.HorseDataController`
    implements the controller protocol itself (gait keys, speeds, the ground,
    the first step at ``dt = 0``); this only turns its frames into
    :class:`LiveFrame` s.

    Parameters
    ----------
    character : Character
        A character with a clip database (``characters/<id>/clips``).
    dt : float
        Fixed step (s).
    database : ClipDatabase, optional
        Default: the character's shipped clips.
    """

    mode = "data"

    def __init__(self, character, *, dt: float, database=None):
        from quadsim.horse.controller import HorseDataController
        from quadsim.io.clips import load_default_database

        if database is None:
            database = load_default_database(character)
        self.character = character
        self.controller = HorseDataController(character, database, dt=dt)
        self.gait_order = self.controller.gait_order
        self.auto_gaits = self.controller.auto_gaits
        self.max_speed = self.controller.max_speed

    @property
    def ground(self):
        return self.controller.ground

    @property
    def speed(self) -> float:
        return self.controller.speed

    @property
    def heading(self) -> float:
        return self.controller.heading

    @property
    def gait(self) -> str:
        return self.controller.gait

    def preferred_speed(self, gait: str) -> float:
        return self.controller.preferred_speed(gait)

    def gait_speed_cap(self, gait: str) -> float:
        return self.controller.gait_speed_cap(gait)

    def step(self, command, dt: float) -> LiveFrame:
        """One controller step (heading, pitch and the ground under the feet as extras)."""
        f = self.controller.step(command, dt)
        extras = {"heading": np.asarray(f.heading, dtype=float), **f.extras}
        return LiveFrame(self.character.skeleton, f.local_rotations, f.root, f.heading,
                         f.gait, f.contacts, extras)


def live_controller(character, mode: str = "procedural", *, dt: float, seed: int = 0,
                    gait: str | None = None) -> ProceduralLive | DataLive:
    """The adapter for ``mode``.

    Parameters
    ----------
    character : Character
    mode : {"procedural", "data"}
    dt : float
        Fixed step (s).
    seed : int
        Procedural mode only.
    gait : str, optional
        Procedural mode only: the starting gait.

    Raises
    ------
    InputError
        For an unknown mode, or ``"data"`` with a character that has no clip
        database.
    """
    check_mode(character, mode)
    if mode == "procedural":
        return ProceduralLive(character, dt=dt, seed=seed, gait=gait)
    return DataLive(character, dt=dt)


def check_mode(character, mode: str) -> None:
    """Raise unless ``character`` can be previewed in ``mode``.

    Raises
    ------
    InputError
        For an unknown mode, or ``"data"`` with a character that has no clip
        database (``characters/<id>/clips/manifest.toml``); the message names
        the ``--mode`` flag and the fix.
    """
    from quadsim.errors import InputError

    if mode not in MODES:
        raise InputError(f"`--mode` {mode!r} is not a known mode; allowed: "
                         f"{', '.join(map(repr, MODES))}")
    if mode != "data":
        return
    from quadsim.io.clips import clip_folder

    if clip_folder(character) is None:
        raise InputError(f"`--mode data`: character {character.id!r} has no clip database "
                         f"(characters/{character.id}/clips/manifest.toml), which the data "
                         "mode plays; drop `--mode data` to preview it with the procedural "
                         "controller, or pick a character with clips "
                         "(`quadsim preview horse --mode data`)")
