"""The data-driven horse controller: clips played by generic time, any speed, any moment.

:class:`HorseDataController` steps once per frame on a
:class:`~quadsim.locomotion.commands.Command`:

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
* **Heading.** ``turn_rate`` is integrated (or the heading steered towards
  ``command.heading`` at up to :data:`MAX_STEER_RATE`), and the whole body is
  yawed about +Y: the root's orientation and its travel turn together (a
  simple body yaw; the seed's head-to-root turning is not done).
* **Leap.** ``command.leap`` (once per command) moves to the leap clip's start
  gait at the leap clip's speed, starts the leap clip when the reference hind
  foot lands, plays it once and returns to the gait the command asks for.
* Slopes (``command.slope``) are ignored.
"""

from __future__ import annotations

import math

import numpy as np

from ..analysis.metrics import foot_contacts
from ..errors import InputError
from ..kinematics.rotations import matrices_from_quaternions, quaternion_multiply
from ..locomotion.commands import Command, Script
from ..skeleton.character import Character
from ..skeleton.motion import Motion
from .database import ClipDatabase, load_default_database, sample_motion
from .root import FLIGHT, clip_stance_cycles, in_stance
from .speed import HOYT, expand
from .timewarp import REFERENCE, leg_times, sample_cycle, transition_motion

#: Gaits chosen by speed, slowest first (amble and rack only on request).
AUTO_GAITS = ("walk", "trot", "canter", "gallop")
#: Relative hysteresis about each gait boundary.
HYSTERESIS = 0.06
#: Relative speed quantum of the expansion cache.
SPEED_STEP = 0.02
#: Gaits expanded relative to their clip (the absolute law is out of the leg's reach).
CLIP_ANCHORED = ("amble", "gallop")
#: Fastest steering towards a commanded heading (rad/s).
MAX_STEER_RATE = math.radians(90.0)
#: Lowest and highest speed played, as multiples of the gait's slowest / fastest clip.
SPEED_REACH = (0.6, 1.4)


def _yaw_quat(yaw: float) -> np.ndarray:
    return np.array([math.cos(yaw / 2), 0.0, math.sin(yaw / 2), 0.0])


def _rotate(yaw: float, v: np.ndarray) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * v[0] + s * v[2], v[1], -s * v[0] + c * v[2]])


class HorseDataController:
    """Step the data-driven horse one frame at a time.

    Parameters
    ----------
    character : Character
        A character with a clip database (the horse).
    database : ClipDatabase, optional
        Defaults to the character's shipped database.
    dt : float
        Default time step (s).
    """

    def __init__(self, character: Character, database: ClipDatabase | None = None,
                 dt: float = 1 / 60):
        self.character = character
        self.db = database if database is not None else load_default_database(character)
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
            self._leap_contacts = foot_contacts(lm.foot_positions(), lm.fps)
        self._cache: dict = {}
        self._stance: dict = {}
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

    # ------------------------------------------------------------ helpers
    def _gait_for(self, speed: float) -> str:
        b = self.bounds
        k = int(np.searchsorted(b, speed))
        if self.gait in self.auto:
            cur = self.auto.index(self.gait)
            lo = b[cur - 1] * (1 - HYSTERESIS) if cur > 0 else -np.inf
            hi = b[cur] * (1 + HYSTERESIS) if cur < len(b) else np.inf
            if lo <= speed <= hi:
                return self.gait
        return self.auto[k]

    def expanded(self, gait: str, speed: float):
        """The gait's nearest clip expanded to ``speed`` (quantised, cached)."""
        clips = self.db.by_gait(gait)
        if not clips:
            raise InputError(f"the clip database has no {gait!r} clip; "
                             f"it has: {', '.join(self.db.gaits)}")
        speed = float(np.clip(speed, clips[0].speed * SPEED_REACH[0],
                              clips[-1].speed * SPEED_REACH[1]))
        q = round(math.log(speed) / math.log1p(SPEED_STEP))
        key = (gait, q)
        if key not in self._cache:
            v = math.exp(q * math.log1p(SPEED_STEP))
            base = self.db.nearest(gait, v)
            anchor = "clip" if gait in CLIP_ANCHORED or gait not in HOYT else "law"
            self._cache[key] = expand(base, self.character, v, anchor=anchor)
        return self._cache[key]

    def _stance_of(self, clip):
        if clip.name not in self._stance:
            self._stance[clip.name] = clip_stance_cycles(clip)
        return self._stance[clip.name]

    def _steady_local(self, clip, phase: float):
        """Local root (3,) (travel unwrapped) and rotations (J, 4) at ``phase``."""
        L = clip.frames
        m = clip.motion
        ext = np.concatenate([m.root_positions,
                              m.root_positions[:1] + [0.0, 0.0, clip.speed * clip.period]])
        f = (phase % 1.0) * L
        i0 = int(math.floor(f)) % L
        a = f - math.floor(f)
        root = ext[i0] * (1 - a) + ext[i0 + 1] * a
        root[2] += math.floor(phase) * clip.speed * clip.period
        q, _ = sample_cycle(clip, np.array([phase]))
        return root, q[0]

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
                cs = self.db.by_gait(gait)
                speed = float(np.exp(np.mean([np.log(c.speed) for c in cs])))
            return gait, speed
        speed = max(speed, 1e-3)
        return self._gait_for(speed), speed

    # ------------------------------------------------------------ stepping
    def step(self, command: Command, dt: float | None = None) -> dict:
        """Advance one frame; returns the pose and labels.

        Returns
        -------
        dict with ``local_rotations`` (J, 3, 3), ``rotations`` (J, 4)
        quaternions, ``root`` (3,), ``positions`` (J, 3) world joint
        positions, ``gait`` (label), ``contacts`` (4,) bool from the clip's
        measured contacts, ``heading`` (rad), ``mode``.
        """
        dt = self.dt if dt is None else float(dt)
        if not dt > 0:
            raise InputError(f"dt must be > 0 s, got {dt!r}")
        self._last_dt = dt
        # heading
        if command.heading is not None:
            err = (command.heading - self.yaw + math.pi) % (2 * math.pi) - math.pi
            self.yaw += float(np.clip(err, -MAX_STEER_RATE * dt, MAX_STEER_RATE * dt))
        elif command.turn_rate is not None:
            self.yaw += command.turn_rate * dt
        # leap request (once per command object)
        if (command.leap and command is not self._leap_cmd and self.leap_clip is not None
                and self.mode != "leap"):
            self._leap_cmd = command
            self._leap_pending = True
        gait, speed = self._target(command)
        first = self.clip is None
        if first:
            self.gait = gait
            self.clip = self.expanded(gait, speed)
            self.phase = 0.0
            local, _ = self._steady_local(self.clip, 0.0)
            self.position = np.array([0.0, local[1], 0.0])
            self._local_prev = local
            return self._emit(*self._steady_pose(), first=True)
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
            self.phase += dt / self.clip.period
            if (self._leap_pending and self.gait == self.leap_clip.start_gait
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
            td = self.leap_clip.touchdown[REFERENCE]
            self.mode = "steady"
            self.gait = g.gait
            self.clip = g
            ph0 = (g.touchdown[REFERENCE] + (n - 1 - td)) / g.frames
            self.phase = ph0 + (f - (n - 1)) / g.frames
            self._local_prev = self._steady_local(g, ph0)[0] - (end_local - self._local_prev)
            self._leap_pending = False
            return self._emit(*self._steady_pose())
        return self._emit(*self._leap_pose())

    def _steady_pose(self):
        local, q = self._steady_local(self.clip, self.phase)
        st = in_stance(self._stance_of(self.clip), np.full((1, 4), self.phase))[0]
        return local, q, st, self.gait

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
        stance = m.extras["foot_phase"] != FLIGHT
        # played through one cycle of M2 after the blend (root and feet settle)
        self._tr = {"motion": m, "f0": f0, "f_end": len(m) - 1, "fps": m.fps,
                    "end": lt["end"] + (len(m) - 1 - f0 - lt["B"]) / clip2.frames, "clip2": clip2, "gait": gait, "stance": stance,
                    "label": f"{self.gait}->{gait}"}
        self._tau = 0.0
        self.mode = "transition"

    def _transition_pose(self, f: float):
        tr = self._tr
        root, rot = sample_motion(tr["motion"], np.array([f]))
        st = tr["stance"][min(int(round(f)), len(tr["stance"]) - 1)]
        return root[0], rot[0], st, tr["label"]

    def _start_leap(self) -> None:
        cur_local, _ = self._steady_local(self.clip, self.phase)
        lm = self.leap_clip.motion
        self._local_prev = lm.root_positions[0] - (cur_local - self._local_prev)
        self._tau = 0.0
        self.mode = "leap"

    def _leap_pose(self):
        lm = self.leap_clip.motion
        f = self._tau * lm.fps
        root, rot = sample_motion(lm, np.array([f]))
        st = self._leap_contacts[min(int(round(f)), len(lm) - 1)]
        return root[0], rot[0], st, "leap"

    def _emit(self, local, q, contacts, label, first=False) -> dict:
        if not first:
            d = local - self._local_prev
            d[1] = 0.0
            self.position = self.position + _rotate(self.yaw, d)
            self.position[1] = local[1]
            self._local_prev = np.array(local, dtype=float)
        self.time += 0.0 if first else self._last_dt
        q = np.array(q, dtype=float)
        q[0] = quaternion_multiply(_yaw_quat(self.yaw), q[0])
        root = np.array(self.position, dtype=float)
        pose = Motion(self.character.skeleton, 60.0, root[None], q[None])
        return {"rotations": q, "local_rotations": matrices_from_quaternions(q),
                "root": root, "positions": pose.world_positions()[0],
                "gait": label, "contacts": np.array(contacts, dtype=bool),
                "heading": self.yaw, "mode": self.mode}


def simulate(character: Character, script: Script | Command, duration: float, fps: float, *,
             database: ClipDatabase | None = None) -> Motion:
    """Run a script with the data-driven horse; one step per frame.

    Returns a Motion of ``int(round(duration * fps))`` frames with contacts,
    gait labels, foot joints and ``extras["heading"]`` (rad).
    """
    if isinstance(script, Command):
        script = Script.constant(script)
    if not (duration > 0 and fps > 0):
        raise InputError(f"duration and fps must be > 0, got {duration!r}, {fps!r}")
    n = int(round(duration * fps))
    ctl = HorseDataController(character, database, dt=1.0 / fps)
    roots, rots, cons, gaits, heads = [], [], [], [], []
    for i in range(n):
        out = ctl.step(script.command_at(i / fps))
        roots.append(out["root"])
        rots.append(out["rotations"])
        cons.append(out["contacts"])
        gaits.append(out["gait"])
        heads.append(out["heading"])
    return Motion(character.skeleton, fps, np.array(roots), np.array(rots),
                  contacts=np.array(cons), gaits=np.array(gaits, dtype=object),
                  foot_joints=character.foot_joints,
                  extras={"heading": np.array(heads)})


__all__ = ["AUTO_GAITS", "HYSTERESIS", "HorseDataController", "simulate"]
