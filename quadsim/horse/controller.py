"""The data-driven horse controller: clips played by generic time, any speed, any moment.

:class:`HorseDataController` steps once per frame on a
:class:`~quadsim.commands.Command`:

* **Gait by speed.** Unless the command names a gait, the gait is chosen from
  the automatic gaits of the clip database (walk, trot, canter, gallop; amble
  and rack only when asked for) by speed bands whose boundaries are the
  geometric means of neighbouring gaits' clip speeds, with a hysteresis of
  :data:`HYSTERESIS` either side so a speed near a boundary does not flicker.
* **Speed.** The current gait's nearest clip is expanded to the commanded speed
  (:func:`quadsim.horse.speed.expand`; speeds are quantised to
  :data:`SPEED_STEP` relative steps and the expansions cached), and played in
  generic time: the phase advances by ``dt / period`` of the expanded cycle. A
  speed change within a gait swaps the clip at the same phase.
* **Gait changes** run the asynchronous time warp
  (:func:`quadsim.horse.timewarp.transition_motion`, root moved by the landing
  feet, equation 11) from the current phase; the transition is computed once
  when it starts and played through, then the new clip continues from the
  transition's end posture.
* **Standing.** Speed 0 slows to a walk at :data:`STOP_SPEED`, then over
  :data:`STAND_TIME` the walk's generic time runs down to a stop while the pose
  blends into the character's rest pose (standing square); the feet on the
  ground stay planted and a foot in the air sets down, so the horse ends with
  all four feet still on the ground. A speed sets it off again: the rest pose
  blends back into the wanted gait's clip. It does not turn while standing.
* **Leap.** ``command.leap`` (once per command) moves to the leap clip's start
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
their own speeds, so expansion moves a foot by at most about 6 %), and of the
clip-anchored ``Tc0 (v/v0)^b`` for the amble and gallop, whose absolute law
asks for strides no horse leg of this size reaches (see
:mod:`quadsim.horse.speed`).

World placement (every mode, every frame; :mod:`quadsim.horse.turning`):

* **Heading.** The root's heading turns at ``turn_rate`` or towards
  ``command.heading`` (gain :data:`STEER_GAIN`), at most the character's
  ``max_turn_rate_deg_s``, :data:`LATERAL_ACCEL` / speed, and
  :data:`TURN_PER_STANCE` / contact time (a planted leg twists by at most that
  much in one contact: slow gaits turn slowly, as the seed's smaller turning
  angle at low speed), the rate changing by at most :data:`TURN_ACCEL`. Turning
  goes on through transitions and leaps. The heading change turns the body
  about its middle; the clip's travel goes along the new heading.
* **Head to root.** The body joints lead the root towards the turn (and
  towards the slope ahead): the head first and most, the neck, then the back
  (:class:`~quadsim.horse.turning.BodyLead`), as the seed's head-down turning.
* **Slopes.** ``command.slope`` (rad, climbing positive) starts a planar ramp
  :data:`RAMP_AHEAD` m ahead of the shoulders along the heading whenever it
  changes (:class:`~quadsim.horse.slope.Ground`, a height field). The body
  pitches with the ground between the hips and the shoulders (time constant
  :data:`PITCH_TAU`) -- the seed's "turning in the vertical" -- and is lifted
  so the clip's feet meet the slope.
* **Planted feet.** A foot on the ground (the clip's contact, or at the clip's
  ground) is held where it struck, on the ground; between two clip frames a foot
  counts as down only if it is down on both (the clip's own foot is lifting or
  landing there). The root moves by the mean offset of the planted feet the
  clip holds within :data:`ROOT_BAND` of its ground (equation 11 in the world,
  at most :data:`SHIFT_SPEED`), the legs reach the plants by two-bone IK, and when a
  planted foot is beyond its leg's reach the body is lowered a little
  (:data:`REACH`, recovering over :data:`SAG_TAU`). A lifted foot's offset from
  the clip (the IK's correction on its last planted frame) fades over its first
  :data:`~quadsim.horse.turning.SWING_FADE` s of swing, and a swing foot keeps
  the clip's height above the ground (high up over ground rising above the
  body's plane it follows the pose). Where the clip's own feet stay put (a
  steady gait, straight on), the legs thus replay the clip's rotations: no
  joint turns faster in a frame than in the clip (``tests/test_horse_smoothness.py``).
"""

from __future__ import annotations

import bisect
import math
import warnings

import numpy as np

from ..skeleton.contacts import foot_contacts
from ..errors import InputError
from ..commands import Command, Script
from ..errors import QuadsimClampWarning
from ..skeleton.character import Character
from ..skeleton.motion import Motion
from .database import ClipDatabase
from .bundles import PlacedPose, PlaceFrame, PlaceRig, PlaceState, PlaceTuning
from .place_kernel import (
    FixedTypeCall,
    pack_contacts,
    place_row,
    sample_row,
    slerp_into,
    stance_row,
)
from .root import FLIGHT, clip_stance_cycles
from .slope import Ground
from .speed import HOYT, expand
from .timewarp import REFERENCE, leg_times, transition_motion
from .turning import (
    GROUND_BAND,
    LOOK_AHEAD,
    MAX_PITCH_LEAD,
    MAX_YAW_LEAD,
    SWING_FADE,
    SWING_HIGH,
    SWING_LOW,
    BodyLead,
    FootPlanter,
)

#: Gaits chosen by speed, slowest first (amble and rack only on request).
AUTO_GAITS = ("walk", "trot", "canter", "gallop")
#: Relative hysteresis about each gait boundary.
HYSTERESIS = 0.06
#: Relative speed quantum of the expansion cache.
SPEED_STEP = 0.02
#: Gaits expanded relative to their clip (the absolute law is out of the leg's reach).
CLIP_ANCHORED = ("amble", "gallop")
#: Lowest and highest speed played, as multiples of the gait's slowest / fastest clip.
SPEED_REACH = (0.6, 1.4)
#: Turn rate limit (rad/s) when the character sets none.
MAX_TURN_RATE = math.radians(60.0)
#: Sideways acceleration a turn may ask for (m/s^2): the turn rate is at most this / speed.
LATERAL_ACCEL = 0.5 * 9.81
#: Largest turn of the body during one contact (rad): the planted legs twist by this much
#: at most, so the turn rate is at most this / contact time (slow gaits turn slowly).
TURN_PER_STANCE = math.radians(15.0)
#: A foot lifted for at most this long (s) between two contacts in a transition stays planted.
MIN_AIR = 0.05
#: Fastest the root is moved onto the planted feet (m/s), over the clip's own travel.
SHIFT_SPEED = 1.0
#: A planted foot at most this high (m) above the clip's ground moves the root (equation 11).
ROOT_BAND = 0.01
#: Fraction of a leg's two-bone reach a planted foot may use before the body is lowered.
REACH = 0.995
#: Time constant (s) of the body rising again after it was lowered.
SAG_TAU = 0.25
#: Steering gain towards a commanded heading (1/s).
STEER_GAIN = 2.5
#: Largest change of turn rate (rad/s^2).
TURN_ACCEL = math.radians(240.0)
#: Time constant (s) of the body's pitch following the ground.
PITCH_TAU = 0.12
#: How far ahead of the shoulders (m) the head looks for the slope.
LOOK_DISTANCE = 1.0
#: How far ahead of the shoulders (m) a new slope starts (beyond the longest reach of a fore foot).
RAMP_AHEAD = 1.0
#: Walking speed (m/s) from which the horse stops, and the time (s) to settle into the stance.
STOP_SPEED = 1.0
STAND_TIME = 0.8
#: Gait label of the standstill.
STAND = "stand"


def _fill_gaps(stance: np.ndarray, n: int) -> np.ndarray:
    """``stance`` (T, 4) bool with each foot's gaps of at most ``n`` frames between contacts
    closed (a transition's per-leg switch of clips can lift a foot for a frame or two)."""
    out = np.array(stance, dtype=bool)
    for j in range(out.shape[1]):
        d = np.diff(np.concatenate([[1], out[:, j].astype(np.int8), [1]]))
        starts, ends = np.nonzero(d == -1)[0], np.nonzero(d == 1)[0]
        for a, b in zip(starts, ends):
            if 0 < a and b < len(out) and b - a <= n:
                out[a:b, j] = True
    return out


def _smooth(x: float) -> float:
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


class _Packed:
    """A clip's arrays for the compiled sampling: one cycle closed by its first frame
    (the root's travel added), and its contacts (:func:`~.place_kernel.stance_row`)."""

    def __init__(self, clip, stance: list[np.ndarray]):
        m = clip.motion
        self.root = np.ascontiguousarray(np.concatenate(
            [m.root_positions, m.root_positions[:1] + [0.0, 0.0, clip.speed * clip.period]]),
            dtype=float)
        self.rot = np.ascontiguousarray(np.concatenate([m.rotations, m.rotations[:1]]),
                                        dtype=float)
        self.on_off, self.count = pack_contacts(stance)


class HorseDataController:
    """Step the data-driven horse one frame at a time.

    Parameters
    ----------
    character : Character
        The character the clips were read onto (the horse).
    database : ClipDatabase
        Its clips (:func:`quadsim.io.clips.load_default_database` reads the
        shipped ones, :func:`quadsim.io.clips.load_database` any folder).
    dt : float
        Default time step (s).
    """

    def __init__(self, character: Character, database: ClipDatabase, dt: float = 1 / 60):
        if not isinstance(database, ClipDatabase):
            raise TypeError(f"HorseDataController: `database` must be a ClipDatabase (read one "
                             f"with quadsim.io.clips.load_default_database), got "
                             f"{type(database).__name__}")
        self.character = character
        self.db = database
        self.dt = float(dt)
        self.auto = [g for g in AUTO_GAITS if self.db.by_gait(g)]
        if not self.auto:
            raise InputError("the clip database has none of the gaits walk, trot, canter, gallop")
        mean = [float(np.exp(np.mean([np.log(c.speed) for c in self.db.by_gait(g)])))
                for g in self.auto]
        self.bounds = [math.sqrt(a * b) for a, b in zip(mean[:-1], mean[1:])]
        leaps = self.db.by_gait("leap")
        self.leap_clip = leaps[0] if leaps else None
        if self.leap_clip is not None:
            lm = self.leap_clip.motion
            self._leap_contacts = np.ascontiguousarray(
                foot_contacts(lm.foot_positions(), lm.fps), dtype=bool)
        self._cache: dict = {}
        self._stance: dict = {}
        self._packed: dict = {}
        self._clips = {g: self.db.by_gait(g) for g in self.db.gaits}
        self.gait: str | None = None
        self.clip = None
        self.phase = 0.0            # generic time in the current clip (cycles, unwrapped)
        self.mode = "steady"        # steady, transition, leap
        self.time = 0.0
        self.yaw = 0.0
        self.position = None        # world root position (3,)
        self._local_prev = None     # previous local root sample of the current mode
        self._tr = None
        self._leap_pending = False
        self._leap_cmd = None
        self._tau = 0.0
        # world placement (heading, slope, body lead, planted feet)
        self.omega = 0.0            # turn rate (rad/s)
        self._turn_warned = False
        self._yaw_prev = 0.0
        self._yaw_lead = 0.0
        self.stand_w = 0.0          # 0 moving .. 1 standing square
        self._stand_goal_last = 0.0
        self.ground = Ground()
        self._slope = 0.0
        self.lead = BodyLead(character)
        self.planter = FootPlanter()
        skel = character.skeleton
        self._feet = np.array([leg.foot for leg in character.legs], dtype=np.int64)
        pair = (np.array([leg.chain[leg.ik_start] for leg in character.legs], dtype=np.int64),
                np.array([leg.chain[leg.ik_start + 1] for leg in character.legs], dtype=np.int64))
        rest = skel.rest_positions
        tops = rest[pair[0], 2] - rest[0, 2]
        self._girdles = (float(tops[2:].mean()), float(tops[:2].mean()))
        self._centre = 0.5 * sum(self._girdles)
        self._rest_height = float(rest[0, 1] - rest[self._feet, 1].mean())
        # the compiled placement's constants and state (quadsim.horse.place_kernel)
        J = skel.n_joints
        self._rig = PlaceRig(np.ascontiguousarray(skel.parents, dtype=np.int64),
                             np.ascontiguousarray(skel.offsets, dtype=float),
                             self.lead.chain, self.lead.share, self.lead.tau, self._feet,
                             pair[0], pair[1], float(self._centre), float(self._girdles[0]),
                             float(self._girdles[1]))
        self._tuning = PlaceTuning(
            look_distance=LOOK_DISTANCE, pitch_tau=PITCH_TAU, sag_tau=SAG_TAU, reach=REACH,
            shift_speed=SHIFT_SPEED, root_band=ROOT_BAND, ground_band=GROUND_BAND,
            swing_fade=SWING_FADE, swing_low=SWING_LOW, swing_high=SWING_HIGH,
            max_yaw_lead=MAX_YAW_LEAD, max_pitch_lead=MAX_PITCH_LEAD)
        self._place = PlaceState(np.zeros(3), np.zeros(1), np.zeros(1), self.lead.state,
                                 self.planter.state)
        self._place_row = FixedTypeCall(place_row)
        self._scratch = np.empty((J + 16, 3, 3))
        self._rest_q = np.zeros((J, 4))
        self._rest_q[:, 0] = 1.0
        self.max_turn_rate = math.radians(float(
            character.locomotion.get("max_turn_rate_deg_s", math.degrees(MAX_TURN_RATE))))

    # ------------------------------------------------------------ state
    @property
    def pitch(self) -> float:
        """Body pitch (rad), nose up: follows the ground between the hips and the shoulders."""
        return float(self._place.pitch[0])

    @property
    def sag(self) -> float:
        """How far the body is lowered for its planted legs (m)."""
        return float(self._place.sag[0])

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
        if self.mode == "transition":
            tr = self._tr
            done = self._tau * tr["fps"] / max(tr["f_end"] - tr["f0"], 1e-9)
            v += (float(tr["clip2"].speed) - v) * _smooth(done)
        elif self.mode == "leap":
            v = float(self.leap_clip.speed)
        return v * (1.0 - _smooth(self.stand_w))

    # ------------------------------------------------------------ helpers
    def _gait_for(self, speed: float) -> str:
        b = self.bounds
        k = bisect.bisect_left(b, speed)
        if self.gait in self.auto:
            cur = self.auto.index(self.gait)
            lo = b[cur - 1] * (1 - HYSTERESIS) if cur > 0 else -math.inf
            hi = b[cur] * (1 + HYSTERESIS) if cur < len(b) else math.inf
            if lo <= speed <= hi:
                return self.gait
        return self.auto[k]

    def expanded(self, gait: str, speed: float):
        """The gait's nearest clip expanded to ``speed`` (quantised, cached)."""
        clips = self._clips.get(gait)
        if not clips:
            raise InputError(f"the clip database has no {gait!r} clip; "
                             f"it has: {', '.join(self.db.gaits)}")
        speed = min(max(float(speed), clips[0].speed * SPEED_REACH[0]),
                    clips[-1].speed * SPEED_REACH[1])
        q = round(math.log(speed) / math.log1p(SPEED_STEP))
        key = (gait, q)
        if key not in self._cache:
            v = math.exp(q * math.log1p(SPEED_STEP))
            base = self.db.nearest(gait, v)
            anchor = "clip" if gait in CLIP_ANCHORED or gait not in HOYT else "law"
            self._cache[key] = expand(base, self.character, v, anchor=anchor)
        return self._cache[key]

    def _stance_time(self, clip) -> float:
        """Mean contact time of a clip's feet (s)."""
        tc = self._stance.get(clip)
        if tc is None:
            d = np.concatenate([(s[:, 1] - s[:, 0]) % 1.0 for s in clip_stance_cycles(clip)])
            tc = self._stance[clip] = float(max(d.mean(), 1e-3) * clip.period)
        return tc

    def _pack(self, clip) -> _Packed:
        pk = self._packed.get(clip)
        if pk is None:
            pk = self._packed[clip] = _Packed(clip, clip_stance_cycles(clip))
        return pk

    def _steady_local(self, clip, phase: float):
        """Local root (3,) (travel unwrapped) and rotations (J, 4) at ``phase``."""
        pk = self._pack(clip)
        f = (phase % 1.0) * clip.frames
        fl = math.floor(f)
        root = np.empty(3)
        q = np.empty(self._rest_q.shape)
        sample_row(pk.root, pk.rot, int(fl) % clip.frames, int(fl) % clip.frames + 1, f - fl,
                   root, q)
        root[2] += math.floor(phase) * clip.speed * clip.period
        return root, q

    def _sample(self, motion: Motion, f: float):
        """Root (3,) and rotations (J, 4) of ``motion`` at fractional frame ``f``."""
        f = min(max(f, 0.0), len(motion) - 1.0)
        i0 = int(math.floor(f))
        root = np.empty(3)
        q = np.empty(self._rest_q.shape)
        sample_row(motion.root_positions, motion.rotations, i0, min(i0 + 1, len(motion) - 1),
                   f - i0, root, q)
        return root, q

    def _target(self, command: Command) -> tuple[str, float]:
        if self._leap_pending and self.leap_clip is not None:
            return self.leap_clip.start_gait, self.leap_clip.speed
        speed = command.speed
        if command.gait is not None:
            gait = command.gait
            if gait == "transverse_gallop":
                gait = "gallop"
            if not self.db.by_gait(gait) or gait == "leap":
                raise InputError(f"gait {command.gait!r} has no clips in the database; "
                                 f"allowed: {', '.join(g for g in self.db.gaits if g != 'leap')}")
            if speed <= 0:
                return STAND, 0.0
            return gait, speed
        if speed <= 0:
            return STAND, 0.0
        return self._gait_for(speed), speed

    def _steer(self, command: Command, dt: float) -> None:
        """Turn rate and heading: towards ``command.heading`` or at ``command.turn_rate``.

        The rate is limited to the character's ``max_turn_rate_deg_s`` and to
        :data:`LATERAL_ACCEL` / speed, and changes by at most :data:`TURN_ACCEL`.
        A horse standing square does not turn (its planted legs would twist).
        """
        v = self.clip.speed * (1.0 - _smooth(self.stand_w)) if self.clip is not None \
            else command.speed
        wmax = min(self.max_turn_rate, LATERAL_ACCEL / max(v, 1e-6))
        if self.clip is not None:
            tc = self._stance_time(self.clip)
            if self.mode == "transition":
                tc = max(tc, self._stance_time(self._tr["clip2"]))
            wmax = min(wmax, TURN_PER_STANCE / tc)
        wmax *= 1.0 - _smooth(self.stand_w)         # no turning while standing square
        lead = 0.0
        if command.heading is not None:
            err = (command.heading - self.yaw + math.pi) % (2 * math.pi) - math.pi
            want = STEER_GAIN * err
            lead = err
        elif command.turn_rate is not None:
            want = command.turn_rate
            if abs(want) > wmax + 1e-9 and self.stand_w == 0.0 and not self._turn_warned:
                self._turn_warned = True
                warnings.warn(
                    f"turn rate {math.degrees(abs(want)):.1f} deg/s is beyond the horse's "
                    f"maximum at {v:.2f} m/s ({math.degrees(wmax):.1f} deg/s, from "
                    "max_turn_rate_deg_s, sideways acceleration and the contact time); "
                    "clamped", QuadsimClampWarning, stacklevel=4)
        else:
            want = 0.0
        want = min(max(want, -wmax), wmax)
        self.omega += min(max(want - self.omega, -TURN_ACCEL * dt), TURN_ACCEL * dt)
        if command.heading is not None and abs(self.omega * dt) > abs(lead) \
                and self.omega * lead >= 0:
            self.omega = lead / dt
        self.yaw += self.omega * dt
        self._yaw_lead = lead + self.omega * LOOK_AHEAD

    def _slope_command(self, command: Command) -> None:
        """Start a ramp ahead of the fore feet when the commanded slope changes."""
        if command.slope != self._slope:
            fwd = np.array([math.sin(self.yaw), math.cos(self.yaw)])
            base = np.zeros(2) if self.position is None else self.position[[0, 2]]
            self.ground.add_ramp(base + fwd * (self._girdles[1] + RAMP_AHEAD), self.yaw,
                                 command.slope)
            self._slope = command.slope

    # ------------------------------------------------------------ stepping
    def step(self, command: Command, dt: float | None = None) -> dict:
        """Advance one frame; returns the pose and labels.

        Parameters
        ----------
        command : Command
            ``speed`` (m/s; 0 stands still), ``turn_rate`` (rad/s) or
            ``heading`` (rad), ``gait``, ``leap`` (one leap per command object),
            ``slope`` (rad, climbing positive: a ramp starts just ahead of the
            fore feet when it changes).
        dt : float, optional
            Time step (s), default the controller's.

        Returns
        -------
        dict with ``local_rotations`` (J, 3, 3), ``rotations`` (J, 4)
        quaternions, ``root`` (3,), ``positions`` (J, 3) world joint
        positions (m), ``gait`` (label; ``"stand"`` standing still),
        ``contacts`` (4,) bool (the clip's contacts the feet are held to),
        ``heading`` and ``pitch`` (rad), ``ground`` (4,) ground height under
        each foot (m), ``mode``.
        """
        dt = self.dt if dt is None else float(dt)
        if not dt > 0:
            raise InputError(f"dt must be > 0 s, got {dt!r}")
        self._last_dt = dt
        self._slope_command(command)
        self._steer(command, dt)
        # leap request (once per command object)
        if (command.leap and command is not self._leap_cmd and self.leap_clip is not None
                and self.mode != "leap"):
            self._leap_cmd = command
            self._leap_pending = True
        gait, speed = self._target(command)
        first = self.clip is None
        stand_goal = 0.0
        if gait == STAND:
            ready = (self.mode == "steady" and self.gait == "walk"
                     and self.clip.speed <= STOP_SPEED * (1 + 2 * SPEED_STEP))
            if first or self.stand_w > 0 or ready:
                stand_goal = 1.0
                gait, speed = ("walk", STOP_SPEED) if first else (self.gait, self.clip.speed)
            else:
                gait, speed = "walk", STOP_SPEED
        self._stand_goal_last = stand_goal
        if first:
            self.gait = gait
            self.clip = self.expanded(gait, speed)
            self.phase = 0.0
            self.stand_w = stand_goal
            self._local_prev, _ = self._steady_local(self.clip, 0.0)
            return self._emit(*self._steady_pose(), first=True)
        if (self.stand_w > 0 or stand_goal > 0) and self.mode == "steady":
            if stand_goal == 0.0 and self.stand_w >= 1.0 and (
                    gait != self.gait or self.expanded(gait, speed) is not self.clip):
                # standing square: set off straight into the wanted gait
                new = self.expanded(gait, speed)
                self.gait, self.clip = gait, new
                self.phase = 0.0
                self._local_prev, _ = self._steady_local(new, 0.0)
            gait, speed = self.gait, self.clip.speed
            step = min(max(stand_goal - self.stand_w, -dt / STAND_TIME), dt / STAND_TIME)
            self.stand_w = min(max(self.stand_w + step, 0.0), 1.0)
        if self.mode == "steady":
            if gait != self.gait:
                self._start_transition(gait, speed)
            else:
                new = self.expanded(gait, speed)
                if new is not self.clip:
                    # same gait: swap the clip at the same phase
                    old_local, _ = self._steady_local(self.clip, self.phase)
                    self.clip = new
                    self._local_prev = self._steady_local(new, self.phase)[0] - \
                        (old_local - self._local_prev)
        if self.mode == "steady":
            prev = self.phase
            self.phase += (1.0 - _smooth(self.stand_w)) * dt / self.clip.period
            if (self._leap_pending and self.stand_w == 0.0
                    and self.gait == self.leap_clip.start_gait
                    and abs(self.clip.speed / self.leap_clip.speed - 1) < 0.05):
                x = self.clip.touchdown[REFERENCE] / self.clip.frames
                if math.floor(self.phase - x) > math.floor(prev - x):
                    self._start_leap()
                    return self._emit(*self._leap_pose())
            return self._emit(*self._steady_pose())
        if self.mode == "transition":
            self._tau += dt
            tr = self._tr
            f = tr["f0"] + self._tau * tr["fps"]
            if f >= tr["f_end"]:
                self.mode = "steady"
                self.gait = tr["gait"]
                self.clip = tr["clip2"]
                self.phase = tr["end"] + (f - tr["f_end"]) / self.clip.frames
                end_local = tr["motion"].root_positions[tr["f_end"]]
                self._local_prev = self._local_prev + (
                    self._steady_local(self.clip, tr["end"])[0] - end_local)
                return self._emit(*self._steady_pose())
            return self._emit(*self._transition_pose(f))
        # leap
        self._tau += dt
        f = self._tau * self.leap_clip.motion.fps
        n = len(self.leap_clip.motion)
        if f >= n - 1:
            g = self.expanded(self.leap_clip.start_gait, self.leap_clip.speed)
            end_local = self.leap_clip.motion.root_positions[n - 1]
            # continue the start gait from the leap's last landing: the foot that landed
            # last in the leap is where it is in the gait at its own touchdown
            j = int(np.argmax(self.leap_clip.touchdown))
            td = self.leap_clip.touchdown[j]
            self.mode = "steady"
            self.gait = g.gait
            self.clip = g
            ph0 = (g.touchdown[j] + (n - 1 - td)) / g.frames
            self.phase = ph0 + (f - (n - 1)) / g.frames
            self._local_prev = self._steady_local(g, ph0)[0] - (end_local - self._local_prev)
            self._leap_pending = False
            return self._emit(*self._steady_pose())
        return self._emit(*self._leap_pose())

    def _steady_pose(self):
        local, q = self._steady_local(self.clip, self.phase)
        st = self._steady_stance(self.clip, self.phase)
        label = self.gait
        if self.stand_w > 0:
            s = _smooth(self.stand_w)
            slerp_into(q, self._rest_q, s, q)
            local[1] = local[1] * (1 - s) + self._rest_height * s
            if self.stand_w >= 1.0:
                st = np.ones(4, dtype=bool)
                label = STAND
            else:
                label = (f"{self.gait}->{STAND}" if self._stand_goal_last
                         else f"{STAND}->{self.gait}")
        return local, q, st, label

    def _steady_stance(self, clip, phase: float) -> np.ndarray:
        """The feet (4,) bool the clip holds still at ``phase``.

        A contact's measured ends fall between frames, but the pose between
        two frames is interpolated: a foot there is still only when it is on
        the ground on both frames. Played between the frames at either end of
        a contact, the foot is already lifting (or still landing) and is left
        to the clip -- held on its plant there, it would be pulled back up to
        a fifth of a metre for a frame and the leg would snap.
        """
        pk = self._pack(clip)
        st = np.empty(4, dtype=bool)
        stance_row(pk.on_off, pk.count, clip.frames, phase, st)
        return st

    def _start_transition(self, gait: str, speed: float) -> None:
        clip1, clip2 = self.clip, self.expanded(gait, speed)
        ph = self.phase % 1.0
        # one cycle of M1 before, so the transition starts one frame after frame f0
        m = transition_motion(self.character, clip1, clip2, t_start=ph, before=1.0, after=1.0)
        n0 = round((1.0 + ph) * clip1.frames)
        f0 = n0 - 1
        lt = leg_times(clip1, clip2, (n0 - 1) / clip1.frames)
        cur_local, _ = self._steady_local(clip1, self.phase)
        # continue from the current root: re-base the precomputed motion's root
        self._local_prev = m.root_positions[f0] - (cur_local - self._local_prev)
        # on the ground: the foot phase, or the transition's foot at the ground; a lift of a
        # frame or two between two contacts (a leg switching clips) is no step
        held = m.foot_positions()[..., 1] <= GROUND_BAND
        stance = np.ascontiguousarray(_fill_gaps((m.extras["foot_phase"] != FLIGHT) | held,
                                                 max(1, round(MIN_AIR * m.fps))))
        # played through one cycle of M2 after the blend (root and feet settle)
        self._tr = {"motion": m, "f0": f0, "f_end": len(m) - 1, "fps": m.fps,
                    "end": lt["end"] + (len(m) - 1 - f0 - lt["B"]) / clip2.frames,
                    "clip2": clip2, "gait": gait, "stance": stance,
                    "label": f"{self.gait}->{gait}"}
        self._tau = 0.0
        self.mode = "transition"

    def _transition_pose(self, f: float):
        tr = self._tr
        root, rot = self._sample(tr["motion"], f)
        st = tr["stance"][min(int(round(f)), len(tr["stance"]) - 1)]
        return root, rot, st, tr["label"]

    def _start_leap(self) -> None:
        cur_local, _ = self._steady_local(self.clip, self.phase)
        lm = self.leap_clip.motion
        self._local_prev = lm.root_positions[0] - (cur_local - self._local_prev)
        self._tau = 0.0
        self.mode = "leap"

    def _leap_pose(self):
        lm = self.leap_clip.motion
        f = self._tau * lm.fps
        root, rot = self._sample(lm, f)
        st = self._leap_contacts[min(int(round(f)), len(lm) - 1)]
        return root, rot, st, "leap"

    def _emit(self, local, q, contacts, label, first=False) -> dict:
        """Place the clip-local pose in the world: heading, slope, body lead, planted feet, IK
        (compiled: :func:`~quadsim.horse.place_kernel.place_row`)."""
        dt = 0.0 if first else self._last_dt
        yaw, yaw0 = self.yaw, self._yaw_prev
        self._yaw_prev = yaw
        # every argument of the same types each frame (see FixedTypeCall)
        local = np.ascontiguousarray(local, dtype=float)
        frame = PlaceFrame(local, local if first else np.ascontiguousarray(self._local_prev,
                                                                           dtype=float),
                           np.ascontiguousarray(q, dtype=float),
                           np.ascontiguousarray(contacts, dtype=np.bool_), bool(first),
                           float(dt), float(yaw), float(yaw0), float(self._yaw_lead))
        J = len(q)
        out = PlacedPose(np.empty((J, 3, 3)), np.empty((J, 4)), np.empty((J, 3)), np.empty(3),
                         np.empty(4, dtype=np.bool_), np.empty(4), self._scratch)
        self._place_row(frame, self._rig, self._tuning, self._place,
                        np.ascontiguousarray(self.ground.table, dtype=float), out)
        self.position = self._place.position
        rot, L, P, root, planted, ground = (out.rotations, out.local_rotations, out.positions,
                                            out.root, out.contacts, out.ground)
        self._local_prev = local
        self.time += dt
        return {"rotations": rot, "local_rotations": L, "root": root, "positions": P,
                "gait": label, "contacts": planted, "heading": yaw, "pitch": self.pitch,
                "ground": ground, "mode": self.mode}


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
        ``"ground"`` (T, 4) the ground height under each foot (m).
    """
    if isinstance(script, Command):
        script = Script.constant(script)
    if not (duration > 0 and fps > 0):
        raise InputError(f"duration and fps must be > 0, got {duration!r}, {fps!r}")
    n = int(round(duration * fps))
    ctl = HorseDataController(character, database, dt=1.0 / fps)
    roots, rots, cons, gaits, heads, pitch, ground = [], [], [], [], [], [], []
    for i in range(n):
        out = ctl.step(script.command_at(i / fps))
        roots.append(out["root"])
        rots.append(out["rotations"])
        cons.append(out["contacts"])
        gaits.append(out["gait"])
        heads.append(out["heading"])
        pitch.append(out["pitch"])
        ground.append(out["ground"])
    return Motion(character.skeleton, fps, np.array(roots), np.array(rots),
                  contacts=np.array(cons), gaits=np.array(gaits, dtype=object),
                  foot_joints=character.foot_joints,
                  extras={"heading": np.array(heads), "pitch": np.array(pitch),
                          "ground": np.array(ground)})


__all__ = ["AUTO_GAITS", "HYSTERESIS", "STAND", "HorseDataController", "simulate"]
