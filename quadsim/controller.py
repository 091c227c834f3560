"""The one controller interface both modes implement, and the frame a step returns.

A controller turns commands into motion one fixed step at a time::

    frame = controller.step(command, dt)

:class:`Frame` is what a step gives back: the posed skeleton at the new
time, the gait being played, which feet are down, and a few named
per-frame channels. :class:`Controller` is the protocol: the procedural
controller (:class:`quadsim.locomotion.ProceduralController`) and the
data-driven horse (:class:`quadsim.horse.HorseDataController`) implement it,
and everything above the engines -- :func:`quadsim.simulate`, the CLI, the
live preview -- uses only what is declared here.

This module sits at the bottom of the package (it needs only the skeleton
layer), so both engines can import it without importing each other.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from types import MappingProxyType
from typing import Mapping, Protocol, runtime_checkable

import numpy as np

from quadsim.skeleton.skeleton import Skeleton

__all__ = ["Controller", "Frame"]


def _frozen(a, dtype=float) -> np.ndarray:
    """``a`` as a read-only array. An array that owns its data and has the dtype is
    taken as it is (the frame then owns it; the giver must not write to it again);
    a view (of a controller's state, say) or anything else is copied."""
    out = np.asarray(a, dtype=dtype)
    if out is a and a.base is not None:
        out = a.copy()
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class Frame:
    """One controller step: the posed skeleton and what the controller played.

    Parameters
    ----------
    skeleton : Skeleton
        The skeleton posed.
    time : float
        Time of this frame since the controller started (s).
    root : ndarray, shape (3,)
        World position of the root joint (m).
    local_rotations : ndarray, shape (J, 3, 3)
        Joint rotations relative to the parent joint; the root's is its world
        orientation.
    positions : ndarray, shape (J, 3)
        World position of every joint (m).
    heading : float
        The body's heading (rad about +Y, 0 faces +Z, positive towards +X).
    gait : str
        What is being played: a gait name, a transition (``"walk->trot"``),
        ``"stand"`` or ``"leap"``.
    contacts : ndarray of bool, shape (4,)
        Feet the controller holds on the ground, LF, RF, LH, RH (its plan;
        measure realised contacts from positions with :mod:`quadsim.analysis`).
    speed : float
        Forward speed being played (m/s).
    extras : mapping of str to ndarray
        Further named per-frame channels, kept in a recorded
        :class:`~quadsim.skeleton.motion.Motion`'s ``extras``: the procedural
        mode gives ``phase`` (4,) CPG stride fractions, ``spine`` (rad),
        ``duty``; the data mode ``pitch`` (rad) and ``ground`` (4,) the
        ground height under each foot (m).

    All arrays are read-only. Arrays that own their data and have the right
    dtype are taken, not copied (a controller hands over arrays it made for
    this frame and does not write to them again); views and anything else are
    copied.
    """

    skeleton: Skeleton
    time: float
    root: np.ndarray
    local_rotations: np.ndarray
    positions: np.ndarray
    heading: float
    gait: str
    contacts: np.ndarray
    speed: float
    extras: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        J = self.skeleton.n_joints
        set_ = object.__setattr__
        set_(self, "time", float(self.time))
        set_(self, "heading", float(self.heading))
        set_(self, "speed", float(self.speed))
        set_(self, "gait", str(self.gait))
        for name, shape, dtype in (("root", (3,), float),
                                   ("local_rotations", (J, 3, 3), float),
                                   ("positions", (J, 3), float),
                                   ("contacts", (4,), bool)):
            a = _frozen(getattr(self, name), dtype)
            if a.shape != shape:
                raise ValueError(f"Frame `{name}` has shape {a.shape}, expected {shape}")
            set_(self, name, a)
        set_(self, "extras", MappingProxyType({k: _frozen(v) for k, v in self.extras.items()}))

    @classmethod
    def owned(cls, skeleton: Skeleton, time: float, root: np.ndarray,
              local_rotations: np.ndarray, positions: np.ndarray, heading: float, gait: str,
              contacts: np.ndarray, speed: float, extras: dict) -> Frame:
        """A frame of arrays its controller made for it, taken as they are (a step's fast way).

        The frame a controller's ``step`` returns, without the constructor's
        checks and conversions (those cost a fifth of a data-horse step). The
        caller's promise: ``time``, ``heading`` and ``speed`` are floats,
        ``gait`` a str, every array (``extras``' values too) a fresh ndarray
        owning its data, of the constructor's shape and dtype (float64; bool
        ``contacts``), that nothing writes to again; ``extras`` a new dict.
        The arrays are made read-only here. The parameters are the
        constructor's.

        Returns
        -------
        Frame
            Equal, field by field, to ``Frame(...)`` of the same arguments.
        """
        frame = object.__new__(cls)
        root.setflags(write=False)
        local_rotations.setflags(write=False)
        positions.setflags(write=False)
        contacts.setflags(write=False)
        for v in extras.values():
            v.setflags(write=False)
        frame.__dict__.update(skeleton=skeleton, time=time, root=root,
                              local_rotations=local_rotations, positions=positions,
                              heading=heading, gait=gait, contacts=contacts, speed=speed,
                              extras=MappingProxyType(extras))
        return frame

    @cached_property
    def world_rotations(self) -> np.ndarray:
        """World rotation of every joint, shape (J, 3, 3) (forward kinematics, once)."""
        from quadsim.skeleton.fk import forward_kinematics

        G, _ = forward_kinematics(self.skeleton, self.local_rotations, self.root)
        G.setflags(write=False)
        return G


@runtime_checkable
class Controller(Protocol):
    """What every controller offers, whatever its mode.

    Attributes
    ----------
    mode : str
        ``"procedural"`` or ``"data"``.
    character : Character
        The character animated.
    dt : float
        The default step (s).
    time : float
        Seconds stepped so far.
    gait_order : list of str
        The gaits a user may hold, in a stable order (the preview's number keys).
    auto_gaits : list of str
        The gaits chosen by speed, slowest first.
    max_speed : float
        Fastest speed (m/s) a command is played at; faster ones are clamped
        with a :class:`~quadsim.errors.QuadsimClampWarning`.
    """

    mode: str
    character: object
    dt: float
    time: float
    gait_order: list
    auto_gaits: list
    max_speed: float

    @property
    def ground(self):
        """The ground under the character: ``None`` for the flat plane ``y = 0``,
        else an object with ``height(xz) -> y``."""

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
        """The speed (m/s) a gait is played at when none is asked for."""

    def gait_speed_cap(self, gait: str) -> float:
        """The fastest speed (m/s) a held gait is played at."""

    def step(self, command, dt: float | None = None) -> Frame:
        """Advance one step of ``dt`` seconds (default :attr:`dt`) under ``command``."""
