"""What a user asks a character to do: commands and scripted sequences."""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Command:
    """A locomotion command, held until the next one.

    Attributes
    ----------
    speed : float
        Forward speed (m/s), >= 0.
    turn_rate : float or None
        Yaw rate (rad/s), positive turns left (towards +X). Ignored when
        ``heading`` is given.
    heading : float or None
        Heading to steer towards (rad about +Y, 0 faces +Z, positive left).
    gait : str or None
        Gait to use; ``None`` chooses by speed.
    leap : bool
        Request one leap (horse data mode).
    slope : float
        Ground slope under the character (rad, positive climbing) -- used by
        the horse data mode.
    """

    speed: float = 0.0
    turn_rate: float | None = None
    heading: float | None = None
    gait: str | None = None
    leap: bool = False
    slope: float = 0.0

    def __post_init__(self) -> None:
        for name in ("speed", "turn_rate", "heading", "slope"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise ValueError(f"Command.{name} must be a finite number, got {v!r}")
        if self.speed < 0:
            raise ValueError(f"Command.speed must be >= 0 m/s, got {self.speed}")


@dataclass(frozen=True)
class Script:
    """Commands over time: each command holds from its start time to the next.

    Attributes
    ----------
    times : tuple of float
        Start time of each command (s), increasing, the first 0.
    commands : tuple of Command
    """

    times: tuple[float, ...]
    commands: tuple[Command, ...]

    def __post_init__(self) -> None:
        if len(self.times) != len(self.commands) or not self.commands:
            raise ValueError("a script needs as many start times as commands, at least one")
        t = np.asarray(self.times, dtype=float)
        if t[0] != 0.0 or np.any(np.diff(t) <= 0):
            raise ValueError("script times must start at 0 and increase")

    @classmethod
    def constant(cls, command: Command) -> Script:
        return cls((0.0,), (command,))

    def command_at(self, t: float) -> Command:
        """The command in force at time ``t`` (s)."""
        k = bisect.bisect_right(self.times, t) - 1
        return self.commands[max(k, 0)]

    def leap_times(self) -> list[float]:
        """Start times of the commands that request a leap."""
        return [t for t, c in zip(self.times, self.commands) if c.leap]
