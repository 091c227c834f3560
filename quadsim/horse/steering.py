"""The data-driven horse's heading: turn rate limits, steering to a heading, clamp notices.

:class:`Steering` turns the root's heading at ``command.turn_rate`` or towards
``command.heading`` (gain :data:`STEER_GAIN`), at most the character's
``max_turn_rate_deg_s``, :data:`LATERAL_ACCEL` / speed, and
:data:`TURN_PER_STANCE` / contact time (a planted leg twists by at most that
much in one contact: slow gaits turn slowly, as the seed's smaller turning
angle at low speed), the rate changing by at most :data:`TURN_ACCEL`. Turning
goes on through transitions and leaps; a horse standing square does not turn.

:class:`ClampNotices` says each distinct clamp of a command once, as a
:class:`~quadsim.errors.QuadsimClampWarning`.
"""

from __future__ import annotations

import math
import warnings

from ..commands import Command
from ..errors import QuadsimClampWarning
from ..frames import GRAVITY
from ..skeleton.character import Character
from .turning import LOOK_AHEAD

#: Turn rate limit (rad/s) when the character sets none.
MAX_TURN_RATE = math.radians(60.0)
#: Sideways acceleration a turn may ask for (m/s^2): the turn rate is at most this / speed.
LATERAL_ACCEL = 0.5 * GRAVITY
#: Largest turn of the body during one contact (rad): the planted legs twist by this much
#: at most, so the turn rate is at most this / contact time (slow gaits turn slowly).
TURN_PER_STANCE = math.radians(15.0)
#: Steering gain towards a commanded heading (1/s).
STEER_GAIN = 2.5
#: Largest change of turn rate (rad/s^2).
TURN_ACCEL = math.radians(240.0)
#: Slowest speed (m/s) the sideways-acceleration limit divides by.
MIN_TURN_SPEED = 1e-6
#: A commanded turn rate this close (rad/s) to the limit is not a clamp.
TURN_SLACK = 1e-9


class ClampNotices:
    """Warn once for each distinct clamp of a command.

    A clamp is named by a key (what was clamped and to what); the first time a
    key comes, its message is warned as a
    :class:`~quadsim.errors.QuadsimClampWarning`, later times are silent.
    """

    def __init__(self) -> None:
        self._said: set = set()

    def say(self, key, message: str, stacklevel: int = 2) -> None:
        """Warn ``message`` unless ``key`` was said before."""
        if key in self._said:
            return
        self._said.add(key)
        warnings.warn(message, QuadsimClampWarning, stacklevel=stacklevel + 1)


class Steering:
    """The root's heading and turn rate.

    Parameters
    ----------
    character : Character
        Its ``locomotion.max_turn_rate_deg_s`` limits the turn rate
        (default :data:`MAX_TURN_RATE`).

    Attributes
    ----------
    yaw : float
        Heading (rad about +Y, 0 faces +Z).
    omega : float
        Turn rate (rad/s).
    yaw_lead : float
        How far the head should lead the root in yaw (rad): the heading error
        and :data:`~quadsim.horse.turning.LOOK_AHEAD` s of the turn.
    max_turn_rate : float
        The character's limit (rad/s).
    """

    def __init__(self, character: Character):
        self.yaw = 0.0
        self.omega = 0.0
        self.yaw_lead = 0.0
        self.max_turn_rate = math.radians(float(
            character.locomotion.get("max_turn_rate_deg_s", math.degrees(MAX_TURN_RATE))))

    def limit(self, speed: float, contact_time: float | None) -> float:
        """The largest turn rate (rad/s) at ``speed`` (m/s) with feet down for
        ``contact_time`` (s; None before the first clip)."""
        wmax = min(self.max_turn_rate, LATERAL_ACCEL / max(speed, MIN_TURN_SPEED))
        if contact_time is not None:
            wmax = min(wmax, TURN_PER_STANCE / contact_time)
        return wmax

    def steer(self, command: Command, dt: float, wmax: float, standing: float,
              notices: ClampNotices, gait: str | None, speed: float) -> None:
        """Turn for ``dt`` s towards ``command.heading`` or at ``command.turn_rate``.

        ``wmax`` is :meth:`limit`, ``standing`` how far (0..1, smoothed) the horse
        has settled into standing square (no turning there); a turn rate beyond
        the limit is clamped and said once per rate and gait (``gait``, ``speed``
        name the circumstances in the message).
        """
        wmax *= 1.0 - standing
        lead = 0.0
        if command.heading is not None:
            err = (command.heading - self.yaw + math.pi) % (2 * math.pi) - math.pi
            want = STEER_GAIN * err
            lead = err
        elif command.turn_rate is not None:
            want = command.turn_rate
            if abs(want) > wmax + TURN_SLACK and standing == 0.0:
                notices.say(
                    ("turn_rate", round(math.degrees(abs(want)), 1), gait),
                    f"turn rate {math.degrees(abs(want)):.1f} deg/s is beyond the horse's "
                    f"maximum at {speed:.2f} m/s ({math.degrees(wmax):.1f} deg/s, from "
                    "max_turn_rate_deg_s, sideways acceleration and the contact time); "
                    "clamped", stacklevel=4)
        else:
            want = 0.0
        want = min(max(want, -wmax), wmax)
        self.omega += min(max(want - self.omega, -TURN_ACCEL * dt), TURN_ACCEL * dt)
        if command.heading is not None and abs(self.omega * dt) > abs(lead) \
                and self.omega * lead >= 0:
            self.omega = lead / dt
        self.yaw += self.omega * dt
        self.yaw_lead = lead + self.omega * LOOK_AHEAD


__all__ = ["LATERAL_ACCEL", "MAX_TURN_RATE", "STEER_GAIN", "TURN_ACCEL", "TURN_PER_STANCE",
           "ClampNotices", "Steering"]
