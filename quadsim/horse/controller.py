"""The data-driven horse controller: clips played by generic time, any speed, any moment.

:class:`HorseDataController` steps once per frame on a
:class:`~quadsim.commands.Command`:

* **Gait by speed.** Unless the command names a gait, the gait is chosen from
  the automatic gaits of the clip database by speed bands with a hysteresis
  (:class:`~quadsim.horse.playback.ClipPlayer`).
* **Speed.** The current gait's nearest clip is expanded to the commanded speed
  (:meth:`~quadsim.horse.playback.ClipPlayer.expanded`) and played in
  generic time: the phase advances by ``dt / period`` of the expanded cycle. A
  speed change within a gait swaps the clip at the same phase. A speed beyond
  what the gait's clips are played at
  (:data:`~quadsim.horse.playback.SPEED_REACH`) is clamped and said once
  (:class:`~quadsim.errors.QuadsimClampWarning`).
* **Gait changes** run the asynchronous time warp
  (:func:`quadsim.horse.timewarp.transition_motion`, root moved by the landing
  feet, equation 11) from the current phase; the transition is computed once
  when it starts and played through, then the new clip continues from the
  transition's end posture.
* **Standing.** Speed 0 slows to the slowest automatic gait (the walk) at
  :data:`STOP_SPEED` (or its slowest clip's speed, when slower), then over
  :data:`STAND_TIME` the walk's generic time runs down to a stop while the pose
  blends into the character's rest pose (standing square); the feet on the
  ground stay planted and a foot in the air sets down, so the horse ends with
  all four feet still on the ground. A speed sets it off again: the rest pose
  blends back into the wanted gait's clip. It does not turn while standing.
* **Leap** (when the database has a leap clip; without one a leap command is
  said once and ignored). ``command.leap`` (once per command) moves to the leap clip's start
  gait at the leap clip's speed, starts the leap clip when the reference hind
  foot lands (the leap clip was keyed from that gait's clip, so its first
  frame is that posture: the blend in is seamless), plays it once and goes on
  in the start gait from the leap's last landing (the foot that landed last
  continues from its touchdown in the gait), then to the gait the command asks
  for by the usual transition.

Contact times. The controller plays :func:`~quadsim.horse.speed.expand`'s
clips as they are (the feet are planted through the clip's own contacts), so
a foot's contact time is the expanded clip's: within 10 % of ``a v^b`` for the
walk, trot, rack and canter (their clips are baked to step as the law says at
their own speeds, so expansion moves a foot by at most 7 % over the walk's,
rack's and canter's measured speeds and 10 % over the trot's, at 6.5 m/s), and of the
clip-anchored ``Tc0 (v/v0)^b`` for the amble and gallop, whose absolute law
asks for strides no horse leg of this size reaches (see
:mod:`quadsim.horse.speed`).

World placement (every mode, every frame): the heading
(:mod:`quadsim.horse.steering`), the ground (``command.slope`` starts a planar
ramp :data:`RAMP_AHEAD` m ahead of the shoulders along the heading whenever it
changes, :class:`~quadsim.horse.slope.Ground`), the body lead, pitch and the
planted feet (:mod:`quadsim.horse.placement`).

The controller implements :class:`quadsim.controller.Controller`: ``step``
returns a :class:`~quadsim.controller.Frame` whose ``extras`` hold ``pitch``
(rad) and ``ground`` (4,), the ground height under each foot (m).
"""

from __future__ import annotations

import math

import numpy as np

from ..commands import Command, Script
from ..controller import Frame
from ..errors import InputError
from ..skeleton.character import Character
from ..skeleton.motion import Motion
from .database import ClipDatabase
from .place_kernel import slerp_into
from .placement import Placement
from .playback import AUTO_GAITS, HYSTERESIS, SPEED_STEP, ClipPlayer, start_transition
from .slope import Ground
from .steering import ClampNotices, Steering
from .timewarp import REFERENCE

#: How far ahead of the shoulders (m) a new slope starts (beyond the longest reach of a fore foot).
RAMP_AHEAD = 1.0
#: Walking speed (m/s) from which the horse stops (at most the slowest gait's slowest
#: clip speed), and the time (s) to settle into the stance.
STOP_SPEED = 1.0
STAND_TIME = 0.8
#: Gait label of the standstill.
STAND = "stand"
#: A leap starts from its start gait's clip within this relative speed of the leap clip's.
LEAP_SPEED_MATCH = 0.05
#: The preview's number keys hold at most this many gaits.
MAX_GAIT_KEYS = 9


def _smooth(x: float) -> float:
    if x <= 0.0:                # moving (the usual case): the same 0.0, sooner
        return 0.0
    x = min(x, 1.0)
    return x * x * (3.0 - 2.0 * x)


class HorseDataController:
    """Step the data-driven horse one frame at a time (a :class:`quadsim.controller.Controller`).

    Parameters
    ----------
    character : Character
        The character the clips were read onto (the horse, or any character
        with a clip database).
    database : ClipDatabase
        Its clips (:func:`quadsim.io.clips.load_default_database` reads the
        shipped ones, :func:`quadsim.io.clips.load_database` any folder).
    dt : float
        Default time step (s).

    Attributes
    ----------
    mode : str
        ``"data"``.
    dt, time : float
        The default step and the seconds stepped so far (s).
    gait_order : list of str
        The clip gaits a command may hold, in the database's order.
    auto_gaits : list of str
        The gaits chosen by speed, slowest first.
    max_speed : float
        The fastest speed (m/s) any gait's clips are played at.
    playing : str
        What is being played: ``"steady"`` (a looped clip), ``"transition"`` or ``"leap"``.
    clip_gait : str or None
        The gait of the clip being played (the new one from a transition's end).
    clip : Clip or None
        The expanded clip being played.
    stop_gait : str
        The gait it stops from and sets off in (the slowest automatic gait).
    stop_speed : float
        The speed (m/s) it stops from.
    phase : float
        Generic time in the current clip (cycles, unwrapped).
    """

    mode = "data"

    def __init__(self, character: Character, database: ClipDatabase, dt: float = 1 / 60):
        if not isinstance(database, ClipDatabase):
            raise TypeError(f"HorseDataController: `database` must be a ClipDatabase (read one "
                            f"with quadsim.io.clips.load_default_database), got "
                            f"{type(database).__name__}")
        self.character = character
        self.db = database
        self.dt = float(dt)
        self.player = ClipPlayer(character, database)
        self.leap_clip = self.player.leap_clip
        self.gait_order = self.player.gaits()[:MAX_GAIT_KEYS]
        self.auto_gaits = list(self.player.auto)
        self.max_speed = max(self.gait_speed_cap(g) for g in self.gait_order)
        self.stop_gait = self.auto_gaits[0]
        self.stop_speed = min(STOP_SPEED, database.by_gait(self.stop_gait)[0].speed)
        self.clip_gait: str | None = None
        self.clip = None
        self.phase = 0.0
        self.playing = "steady"
        self.time = 0.0
        self._label = STAND
        self._local_prev = None     # previous local root sample of what is played
        self._tr = None
        self._leap_pending = False
        self._leap_cmd = None
        self._tau = 0.0
        self.stand_w = 0.0          # 0 moving .. 1 standing square
        self._stand_goal_last = 0.0
        self._ground = Ground()
        self._slope = 0.0
        self.steering = Steering(character)
        self.placement = Placement(character)
        self.notices = ClampNotices()
        self._yaw_prev = 0.0
        self._last_dt = self.dt
        J = character.skeleton.n_joints
        self._rest_q = np.zeros((J, 4))
        self._rest_q[:, 0] = 1.0

    # ------------------------------------------------------------ the protocol
    @property
    def ground(self) -> Ground | None:
        """The ground under the horse: None while it is the flat plane ``y = 0``, else the
        :class:`~quadsim.horse.slope.Ground` of the ramps the commands asked for."""
        return self._ground if self._ground.ramps else None

    @property
    def heading(self) -> float:
        """The root's heading (rad)."""
        return float(self.steering.yaw)

    @property
    def gait(self) -> str:
        """The last frame's gait label (``"stand"`` before the first)."""
        return self._label

    @property
    def speed(self) -> float:
        """The speed being played (m/s), 0 before the first step.

        The current clip's speed; in a gait transition it moves from the old
        clip's to the new one's with the transition's progress, in a leap it is
        the leap clip's; it slows to 0 as the horse settles into standing square.
        """
        if self.clip is None:
            return 0.0
        v = float(self.clip.speed)
        if self.playing == "transition":
            tr = self._tr
            v += (float(tr.clip2.speed) - v) * _smooth(tr.progress(self._tau))
        elif self.playing == "leap":
            v = float(self.leap_clip.speed)
        return v * (1.0 - _smooth(self.stand_w))

    def preferred_speed(self, gait: str) -> float:
        """Geometric mean of the gait's clip speeds (m/s)."""
        return self.player.preferred_speed(self.player.check_gait(gait))

    def gait_speed_cap(self, gait: str) -> float:
        """Fastest speed (m/s) the gait's clips are expanded to."""
        return float(self.player.speed_range(self.player.check_gait(gait))[1])

    # ------------------------------------------------------------ other state
    @property
    def yaw(self) -> float:
        """The root's heading (rad), as :attr:`heading`."""
        return self.steering.yaw

    @property
    def omega(self) -> float:
        """Turn rate (rad/s)."""
        return self.steering.omega

    @property
    def pitch(self) -> float:
        """Body pitch (rad), nose up: follows the ground between the hips and the shoulders."""
        return self.placement.pitch

    @property
    def sag(self) -> float:
        """How far the body is lowered for its planted legs (m)."""
        return self.placement.sag

    @property
    def lead(self):
        """The body lead (:class:`~quadsim.horse.turning.BodyLead`)."""
        return self.placement.lead

    @property
    def planter(self):
        """The planted feet (:class:`~quadsim.horse.turning.FootPlanter`)."""
        return self.placement.planter

    def expanded(self, gait: str, speed: float):
        """The gait's nearest clip expanded to ``speed`` (see
        :meth:`~quadsim.horse.playback.ClipPlayer.expanded`)."""
        return self.player.expanded(gait, speed)

    # ------------------------------------------------------------ commands
    def _target(self, command: Command) -> tuple[str, float]:
        if self._leap_pending and self.leap_clip is not None:
            return self.leap_clip.start_gait, self.leap_clip.speed
        speed = command.speed
        if speed <= 0:
            if command.gait is not None:
                self.player.check_gait(command.gait)
            return STAND, 0.0
        if command.gait is not None:
            gait = self.player.check_gait(command.gait)
        else:
            gait = self.player.gait_for(speed, self.clip_gait)
        self._say_speed_clamp(gait, speed)
        return gait, speed

    def _say_speed_clamp(self, gait: str, speed: float) -> None:
        lo, hi = self.player.speed_range(gait)
        if speed > hi:
            self.notices.say(("speed", gait, round(speed, 3)),
                             f"speed {speed:.3g} m/s is beyond the fastest the {gait} clips are "
                             f"played at ({hi:.3g} m/s); clamped to {hi:.3g} m/s", stacklevel=4)
        elif speed < lo:
            self.notices.say(("speed", gait, round(speed, 3)),
                             f"speed {speed:.3g} m/s is below the slowest the {gait} clips are "
                             f"played at ({lo:.3g} m/s); played at {lo:.3g} m/s", stacklevel=4)

    def _steer(self, command: Command, dt: float) -> None:
        """Turn towards ``command.heading`` or at ``command.turn_rate`` (see
        :class:`~quadsim.horse.steering.Steering`)."""
        standing = _smooth(self.stand_w)
        if self.clip is not None:
            v = self.clip.speed * (1.0 - standing)
            tc = self.player.stance_time(self.clip)
            if self.playing == "transition":
                tc = max(tc, self.player.stance_time(self._tr.clip2))
        else:
            v, tc = command.speed, None
        wmax = self.steering.limit(v, tc)
        self.steering.steer(command, dt, wmax, standing if self.stand_w > 0 else 0.0,
                            self.notices, self.clip_gait, v)

    def _slope_command(self, command: Command) -> None:
        """Start a ramp ahead of the fore feet when the commanded slope changes."""
        if command.slope != self._slope:
            yaw = self.steering.yaw
            fwd = np.array([math.sin(yaw), math.cos(yaw)])
            base = self.placement.position[[0, 2]]
            self._ground.add_ramp(base + fwd * (self.placement.girdles[1] + RAMP_AHEAD), yaw,
                                  command.slope)
            self._slope = command.slope

    # ------------------------------------------------------------ stepping
    def step(self, command: Command, dt: float | None = None) -> Frame:
        """Advance one frame under ``command``.

        Parameters
        ----------
        command : Command
            ``speed`` (m/s; 0 stands still), ``turn_rate`` (rad/s) or
            ``heading`` (rad), ``gait``, ``leap`` (one leap per command object),
            ``slope`` (rad, climbing positive: a ramp starts just ahead of the
            fore feet when it changes).
        dt : float, optional
            Time step (s), default :attr:`dt`. The first step is the starting
            pose and does not advance; ``dt = 0`` is allowed for it only.

        Returns
        -------
        Frame
            The pose; ``gait`` the label (a gait, ``"old->new"``, ``"leap"``,
            ``"stand"``, ``"walk->stand"``...), ``contacts`` the feet held on
            the ground, ``extras`` ``pitch`` (rad) and ``ground`` (4,) (m).

        Raises
        ------
        InputError
            For ``dt <= 0`` after the first step, a gait without clips, or a
            slope out of range.
        """
        if self.clip is None and dt is not None and not dt > 0:
            dt = None
        out = self._advance(command, dt)
        # the placement's output arrays are this frame's own (fresh each step)
        return Frame.owned(self.character.skeleton, self.time, out.root, out.local_rotations,
                           out.positions, float(self.steering.yaw), self._label, out.contacts,
                           self.speed, {"pitch": np.array(float(self.placement.state.pitch[0])),
                                        "ground": out.ground, "toe_ground": out.toe_ground})

    def _advance(self, command: Command, dt: float | None):
        """One frame: the mode logic, then the placement; returns the
        :class:`~quadsim.horse.bundles.PlacedPose` (the label in ``self._label``)."""
        dt = self.dt if dt is None else float(dt)
        if not dt > 0:
            raise InputError(f"dt must be > 0 s, got {dt!r}")
        self._last_dt = dt
        self._slope_command(command)
        self._steer(command, dt)
        # leap request (once per command object)
        if (command.leap and command is not self._leap_cmd and self.leap_clip is not None
                and self.playing != "leap"):
            self._leap_cmd = command
            self._leap_pending = True
        elif command.leap and self.leap_clip is None:
            self.notices.say(("leap",), "the clip database has no leap clip: the leap is "
                             "not played (the leap is optional)", stacklevel=3)
        gait, speed = self._target(command)
        first = self.clip is None
        stand_goal = 0.0
        if gait == STAND:
            stop = (self.stop_gait, self.stop_speed)
            ready = (self.playing == "steady" and self.clip_gait == stop[0]
                     and self.clip.speed <= stop[1] * (1 + 2 * SPEED_STEP))
            if first or self.stand_w > 0 or ready:
                stand_goal = 1.0
                gait, speed = stop if first else (self.clip_gait, self.clip.speed)
            else:
                gait, speed = stop
        self._stand_goal_last = stand_goal
        if first:
            self.clip_gait = gait
            self.clip = self.expanded(gait, speed)
            self.phase = 0.0
            self.stand_w = stand_goal
            self._local_prev, _ = self.player.local(self.clip, 0.0)
            return self._emit(*self._steady_pose(), first=True)
        if (self.stand_w > 0 or stand_goal > 0) and self.playing == "steady":
            if stand_goal == 0.0 and self.stand_w >= 1.0 and (
                    gait != self.clip_gait or self.expanded(gait, speed) is not self.clip):
                # standing square: set off straight into the wanted gait
                new = self.expanded(gait, speed)
                self.clip_gait, self.clip = gait, new
                self.phase = 0.0
                self._local_prev, _ = self.player.local(new, 0.0)
            gait, speed = self.clip_gait, self.clip.speed
            step = min(max(stand_goal - self.stand_w, -dt / STAND_TIME), dt / STAND_TIME)
            self.stand_w = min(max(self.stand_w + step, 0.0), 1.0)
        if self.playing == "steady":
            if gait != self.clip_gait:
                self._start_transition(gait, speed)
            else:
                new = self.expanded(gait, speed)
                if new is not self.clip:
                    # same gait: swap the clip at the same phase
                    old_local, _ = self.player.local(self.clip, self.phase)
                    self.clip = new
                    self._local_prev = self.player.local(new, self.phase)[0] - \
                        (old_local - self._local_prev)
        if self.playing == "steady":
            return self._steady_step(dt)
        if self.playing == "transition":
            return self._transition_step(dt)
        return self._leap_step(dt)

    def _steady_step(self, dt: float):
        prev = self.phase
        self.phase += (1.0 - _smooth(self.stand_w)) * dt / self.clip.period
        if (self._leap_pending and self.stand_w == 0.0
                and self.clip_gait == self.leap_clip.start_gait
                and abs(self.clip.speed / self.leap_clip.speed - 1) < LEAP_SPEED_MATCH):
            x = self.clip.touchdown[REFERENCE] / self.clip.frames
            if math.floor(self.phase - x) > math.floor(prev - x):
                self._start_leap()
                return self._emit(*self._leap_pose())
        return self._emit(*self._steady_pose())

    def _transition_step(self, dt: float):
        self._tau += dt
        tr = self._tr
        f = tr.f0 + self._tau * tr.fps
        if f >= tr.f_end:
            self.playing = "steady"
            self.clip_gait = tr.gait
            self.clip = tr.clip2
            self.phase = tr.end + (f - tr.f_end) / self.clip.frames
            end_local = tr.motion.root_positions[tr.f_end]
            self._local_prev = self._local_prev + (
                self.player.local(self.clip, tr.end)[0] - end_local)
            return self._emit(*self._steady_pose())
        root, rot = self.player.sample(tr.motion, f)
        st = tr.stance[min(int(round(f)), len(tr.stance) - 1)]
        return self._emit(root, rot, st, tr.label)

    def _leap_step(self, dt: float):
        self._tau += dt
        lm = self.leap_clip.motion
        f = self._tau * lm.fps
        n = len(lm)
        if f >= n - 1:
            g = self.expanded(self.leap_clip.start_gait, self.leap_clip.speed)
            end_local = lm.root_positions[n - 1]
            # continue the start gait from the leap's last landing: the foot that landed
            # last in the leap is where it is in the gait at its own touchdown
            j = int(np.argmax(self.leap_clip.touchdown))
            td = self.leap_clip.touchdown[j]
            self.playing = "steady"
            self.clip_gait = g.gait
            self.clip = g
            ph0 = (g.touchdown[j] + (n - 1 - td)) / g.frames
            self.phase = ph0 + (f - (n - 1)) / g.frames
            self._local_prev = self.player.local(g, ph0)[0] - (end_local - self._local_prev)
            self._leap_pending = False
            return self._emit(*self._steady_pose())
        return self._emit(*self._leap_pose())

    def _steady_pose(self):
        local, q = self.player.local(self.clip, self.phase)
        st = self.player.stance(self.clip, self.phase)
        label = self.clip_gait
        if self.stand_w > 0:
            s = _smooth(self.stand_w)
            slerp_into(q, self._rest_q, s, q)
            local[1] = local[1] * (1 - s) + self.placement.rest_height * s
            if self.stand_w >= 1.0:
                st = np.ones(4, dtype=bool)
                label = STAND
            else:
                label = (f"{self.clip_gait}->{STAND}" if self._stand_goal_last
                         else f"{STAND}->{self.clip_gait}")
        return local, q, st, label

    def _start_transition(self, gait: str, speed: float) -> None:
        clip1, clip2 = self.clip, self.expanded(gait, speed)
        tr = start_transition(self.character, clip1, clip2, self.phase, self.clip_gait, gait,
                              planted=self.planter.planted)
        cur_local, _ = self.player.local(clip1, self.phase)
        # continue from the current root: re-base the precomputed motion's root
        self._local_prev = tr.motion.root_positions[tr.f0] - (cur_local - self._local_prev)
        self._tr = tr
        self._tau = 0.0
        self.playing = "transition"

    def _start_leap(self) -> None:
        cur_local, _ = self.player.local(self.clip, self.phase)
        lm = self.leap_clip.motion
        self._local_prev = lm.root_positions[0] - (cur_local - self._local_prev)
        self._tau = 0.0
        self.playing = "leap"

    def _leap_pose(self):
        lm = self.leap_clip.motion
        f = self._tau * lm.fps
        root, rot = self.player.sample(lm, f)
        st = self.player.leap_contacts[min(int(round(f)), len(lm) - 1)]
        return root, rot, st, "leap"

    def _emit(self, local, q, contacts, label, first=False):
        """Place the clip-local pose in the world (:class:`~quadsim.horse.placement.Placement`)."""
        dt = 0.0 if first else self._last_dt
        yaw, yaw0 = self.steering.yaw, self._yaw_prev
        self._yaw_prev = yaw
        local = np.asarray(local, dtype=float)
        out = self.placement.place(local, local if first else self._local_prev, q, contacts,
                                   first, dt, yaw, yaw0, self.steering.yaw_lead,
                                   self._ground.table)
        self._local_prev = local
        self.time += dt
        self._label = label
        return out


#: The controller is the horse's by history; it plays any character's clip database.
DataController = HorseDataController


def simulate(character: Character, script: Script | Command, duration: float, fps: float, *,
             database: ClipDatabase) -> Motion:
    """Run a script with the data-driven horse; one step per frame.

    Parameters
    ----------
    character : Character
    script : Script or Command
    duration : float
        Seconds (> 0).
    fps : float
        Frames per second (> 0).
    database : ClipDatabase
        The clips played (see :class:`HorseDataController`).

    Returns
    -------
    Motion
        ``int(round(duration * fps))`` frames with contacts, gait labels, foot
        joints and ``extras``: ``"heading"`` (T,) and ``"pitch"`` (T,) (rad),
        ``"ground"`` (T, 4) the ground height under each foot joint and
        ``"toe_ground"`` (T, 4) under each toe tip (m).
    """
    if isinstance(script, Command):
        script = Script.constant(script)
    if not (duration > 0 and fps > 0):
        raise InputError(f"duration and fps must be > 0, got {duration!r}, {fps!r}")
    n = int(round(duration * fps))
    ctl = HorseDataController(character, database, dt=1.0 / fps)
    roots, rots, cons, gaits, heads, pitch, ground, toe_ground = [], [], [], [], [], [], [], []
    for i in range(n):
        out = ctl._advance(script.command_at(i / fps), None)
        roots.append(out.root)
        rots.append(out.rotations)
        cons.append(out.contacts)
        gaits.append(ctl.gait)
        heads.append(ctl.heading)
        pitch.append(ctl.pitch)
        ground.append(out.ground)
        toe_ground.append(out.toe_ground)
    return Motion(character.skeleton, fps, np.array(roots), np.array(rots),
                  contacts=np.array(cons), gaits=np.array(gaits, dtype=object),
                  foot_joints=character.foot_joints,
                  extras={"heading": np.array(heads), "pitch": np.array(pitch),
                          "ground": np.array(ground), "toe_ground": np.array(toe_ground)})


__all__ = ["AUTO_GAITS", "HYSTERESIS", "LEAP_SPEED_MATCH", "RAMP_AHEAD", "STAND",
           "STAND_TIME", "STOP_SPEED", "DataController", "HorseDataController", "simulate"]
