"""The procedural locomotion controller: commands in, poses out.

One :class:`ProceduralController` drives one character. Each call of
:meth:`ProceduralController.step` advances it by ``dt`` under a
:class:`~quadsim.locomotion.commands.Command`:

1. speed and turn rate move towards the command (bounded acceleration);
2. the gait scheduler picks the gait (hysteresis) and blends transitions;
3. the CPG advances every leg's phase; a leg lifts off when its stride
   fraction passes the duty factor and touches down when it wraps;
4. stance feet stay where they landed; swing feet follow Catmull-Rom paths
   to touchdown points planned about the key points' predicted positions;
5. the spine bends (compress/stretch or the concave/convex machine) and
   into the turn; the tail lags behind;
6. IK poses the legs (:mod:`quadsim.locomotion.posing`).

:func:`simulate` runs a scripted sequence and returns a
:class:`~quadsim.skeleton.motion.Motion`; the posing of all frames is done
in one vectorised pass at the end.

Bad commands: a negative or non-finite speed or turn rate raises
``ValueError`` (:class:`~quadsim.locomotion.commands.Command` checks it); an
unknown gait raises :class:`~quadsim.errors.InputError`; a speed above the
character's fastest gait, or a turn rate above its maximum, is clamped with
a ``QuadsimClampWarning`` that names the value and the limit.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from quadsim.frames import FORE, Y
from quadsim.kinematics.ik import solve_leg
from quadsim.kinematics.rotations import quaternions_from_matrices
from quadsim.locomotion.commands import Command, Script
from quadsim.locomotion.cpg import TWO_PI, CPGParams, cpg_step
from quadsim.locomotion.footpath import swing_position
from quadsim.locomotion.gaits import (
    Gait,
    auto_gaits,
    gait_table,
    max_speed,
    resolve_gait_name,
)
from quadsim.locomotion.posing import Poser
from quadsim.locomotion.spine import flex_angle, rate_limited, spine_state, spine_target
from quadsim.locomotion.transition import GaitScheduler
from quadsim.locomotion.turning import arc_advance, rotate_y, turn_rate_towards
from quadsim.skeleton.character import Character
from quadsim.skeleton.fk import forward_kinematics
from quadsim.skeleton.motion import Motion

#: Shortest swing, as a fraction of the stride, worth lifting a foot for.
MIN_SWING = 0.12

#: The standing state: every foot planted (duty factor 1), entered when the
#: commanded speed is zero and left when it is not.
STAND = "stand"

#: Girdle of each leg in leg order (0 hind, 1 fore), indexing the key points.
_GIRDLE = np.where(FORE, 1, 0)


def _standing(slowest: Gait) -> Gait:
    """A gait with duty factor 1 on the slowest gait's clock: once its
    transition ends no foot lifts, so the character stands."""
    return replace(slowest, name=STAND, duty_range=(1.0, 1.0), spine_amplitude=0.0,
                   drop=0.0)


class QuadsimClampWarning(UserWarning):
    """A command value was outside what the character can do and was clamped."""


@dataclass(frozen=True)
class ControllerSettings:
    """Tunable constants of the procedural controller.

    Attributes
    ----------
    acceleration : float
        Largest change of forward speed (m/s^2).
    turn_response : float
        Time constant of the yaw rate following its command (s).
    reach_margin : float
        Fraction of a leg's measured stance sweep a stride may use (room for
        the body's bob, sway and flexion).
    vault : float
        Extra drop of a girdle (fraction of the pelvis height) a stride may
        use at the ends of stance: the body vaults over its planted legs.
    max_bend : float
        Largest spine yaw bend (rad).
    max_sway : float
        Largest yaw of a girdle following its feet (rad).
    tail_lag : float
        Time constant of each tail joint following the one before (s).
    cpg : CPGParams
    """

    acceleration: float = 3.0
    turn_response: float = 0.25
    reach_margin: float = 0.85
    vault: float = 0.04
    max_bend: float = math.radians(35.0)
    max_sway: float = math.radians(6.0)
    tail_lag: float = 0.08
    cpg: CPGParams = field(default_factory=CPGParams)


class ProceduralController:
    """Interactive procedural locomotion for one character.

    Parameters
    ----------
    character : Character
    dt : float
        Fixed step (s).
    seed : int
        Seeds the small random start offsets of the oscillators.
    gait : str, optional
        Starting gait (default: the slowest automatic gait).
    settings : ControllerSettings, optional
    """

    def __init__(self, character: Character, dt: float = 1.0 / 60.0, seed: int = 0,
                 gait: str | None = None, settings: ControllerSettings | None = None):
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
        self.character = character
        self.dt = float(dt)
        self.settings = settings or ControllerSettings()
        self.gaits = dict(gait_table(character))
        self.auto = auto_gaits(character)
        self.gaits[STAND] = _standing(self.gaits[self.auto[0]])
        self.stand_speed = 0.3 * self.gaits[self.auto[0]].speed_range[0]
        start = resolve_gait_name(gait, character) if gait else STAND
        self.scheduler = GaitScheduler(self.gaits, self.auto, start)
        self.poser = Poser.for_character(character)
        self.max_speed = max_speed(character)
        self.max_turn_rate = math.radians(float(
            character.locomotion.get("max_turn_rate_deg_s", 90.0)))
        self.flexed = math.radians(float(character.locomotion.get("spine_flex_deg", 15.0)))
        self.extended = math.radians(float(character.locomotion.get("spine_extend_deg", -10.0)))
        self.min_turn_radius = float(character.locomotion.get(
            "min_turn_radius_body_lengths", 1.0))
        self.slow_scale = float(character.locomotion.get("spine_slow_scale", 1.0))
        self._warned: set[str] = set()
        self._geometry()
        self._init_state(seed)

    # ------------------------------------------------------------ set-up
    def _geometry(self) -> None:
        ch = self.character
        P = ch.skeleton.rest_positions
        self.h = ch.hip_height
        self.pelvis_height = float(P[0, Y])
        pair_top = np.array([leg.chain[leg.ik_start] for leg in ch.legs])
        self.pair_height = P[pair_top, Y]
        self.drops = np.linspace(0.0, 0.3, 13)
        self.half_sweep = np.maximum.accumulate(self._measure_sweeps(self.drops), axis=0)
        # per-step constants: each leg's sweep column and the worst leg's
        self._sweep_cols = tuple(np.ascontiguousarray(self.half_sweep[:, i]) for i in range(4))
        self._sweep_min = self.half_sweep.min(axis=1)
        # key points: girdle centres on the ground, relative to the pelvis
        self.hind_z = float(np.mean(P[pair_top[2:], 2]) - P[0, 2])
        self.body_length = float(np.mean(P[pair_top[:2], 2]) - np.mean(P[pair_top[2:], 2]))
        feet = ch.rest_foot_positions()
        self.foot_offset = feet - P[pair_top]  # foot relative to its pair top, per leg
        self.foot_offset[:, Y] = 0.0
        self.foot_offset[:, 0] = feet[:, 0]  # lateral offset from the mid-line
        self.tail_rest = np.zeros((len(ch.tail), 2))

    def _init_state(self, seed: int) -> None:
        rng = np.random.default_rng(seed)
        gait = self.gaits[self.scheduler.current]
        beta = float(gait.duty(gait.speed_range[0]))
        # start with the left hind in mid-stance, small seeded perturbation
        self.theta = TWO_PI * (0.5 * beta - gait.phases) + rng.normal(0.0, 0.05, 4)
        self.r = np.full(4, 1.0) + rng.normal(0.0, 0.02, 4)
        self.theta_s = np.asarray(self.theta[2] + rng.normal(0.0, 0.05))
        self.r_s = np.asarray(1.0)
        self.time = 0.0
        self.speed = 0.0
        self.yaw_rate = 0.0
        self.heading = 0.0
        self.root_xz = np.array([0.0, 0.0, 0.0])
        self.bend = 0.0
        self.spine_angle = 0.0
        self.spine_smooth = 0.0
        self.height = self.pelvis_height
        self.drops_now = np.zeros(2)
        self.tail = self.tail_rest.copy()
        self.stance = np.ones(4, dtype=bool)
        feet = self.character.rest_foot_positions().copy()
        feet[:, Y] = 0.0
        self.planted = feet
        self.liftoff = feet.copy()
        self.theta_lo = self.theta.copy()
        self.theta_td = self.theta.copy()
        self.swing_s = np.zeros(4)
        self.feet = feet.copy()
        self.params = self.scheduler.params(0.0)
        self.freq = 1.0

    # ------------------------------------------------------------ helpers
    def _warn(self, key: str, msg: str) -> None:
        if key not in self._warned:
            self._warned.add(key)
            warnings.warn(msg, QuadsimClampWarning, stacklevel=3)

    def _key_points(self, root_xz, heading, bend):
        """Hind and fore key points (2, 3) and their headings (2,)."""
        # rotate_y of (0, 0, z) about +Y, in scalar form: (z sin h, 0, z cos h)
        hz, bl = self.hind_z, self.body_length
        fh = heading + 0.5 * bend
        x, y, z = float(root_xz[0]), float(root_xz[1]), float(root_xz[2])
        hx, hy, hzz = x + math.sin(heading) * hz, y + 0.0, z + math.cos(heading) * hz
        keys = np.array([[hx, hy, hzz],
                         [hx + math.sin(fh) * bl, hy + 0.0, hzz + math.cos(fh) * bl]])
        return keys, np.array([heading, heading + bend])

    def _girdle_frame(self, keys, key_heading):
        """Each foot's mid-stance point (4, 3) and its girdle's forward vector (4, 3)."""
        kh = key_heading[_GIRDLE]
        c, sn = np.cos(kh), np.sin(kh)
        off = self.foot_offset
        mid = np.empty((4, 3))
        mid[:, 0] = c * off[:, 0] + sn * off[:, 2]
        mid[:, 1] = off[:, 1]
        mid[:, 2] = -sn * off[:, 0] + c * off[:, 2]
        mid += keys[_GIRDLE]
        fwd = np.zeros((4, 3))
        fwd[:, 0] = sn
        fwd[:, 2] = c
        return mid, fwd

    def _measure_sweeps(self, drops: np.ndarray) -> np.ndarray:
        """Half stance sweep each leg reaches exactly, per body drop, shape (D, 4) (m).

        For each drop (fraction of the pelvis height the body is lowered by),
        ground targets fore and aft of the rest foot position are tried with
        the leg IK itself; the result is the largest distance for which every
        nearer target is reached on both sides.
        """
        ch = self.character
        P = ch.skeleton.rest_positions
        xs = np.linspace(0.0, 1.5 * self.h, 301)
        out = np.zeros((len(drops), 4))
        eye = np.eye(3)
        for i, geom in enumerate(self.poser.legs):
            foot = P[ch.legs[i].foot]
            for d, drop in enumerate(drops):
                parent = P[geom.parent] - np.array([0.0, drop * self.pelvis_height, 0.0])
                ok = np.ones(len(xs), dtype=bool)
                for sign in (-1.0, 1.0):
                    tgt = np.tile(foot, (len(xs), 1))
                    tgt[:, 2] += sign * xs
                    tgt[:, Y] = 0.0
                    _, err = solve_leg(geom, eye, parent, tgt)
                    ok &= err < 1e-9
                bad = np.flatnonzero(~ok)
                out[d, i] = xs[bad[0] - 1] if len(bad) and bad[0] > 0 else (
                    0.0 if len(bad) else xs[-1])
        return out

    def max_turn_rate_at(self, speed: float) -> float:
        """Largest turn rate (rad/s) at ``speed``: the character's maximum, and no
        tighter than its minimum turn radius (``min_turn_radius_body_lengths``
        body lengths, default 1) -- the key points must fit on the arc."""
        r_min = self.min_turn_radius * self.body_length
        return min(self.max_turn_rate, max(speed, 0.1 * self.h) / r_min)

    def gait_speed_cap(self, gait: str) -> float:
        """Fastest speed (m/s) a requested gait is held at: 15 % above its range."""
        return 1.15 * self.gaits[gait].speed_range[1]

    def stride_limit(self, duty: float, drop: float, bound: float = 0.0) -> float:
        """Longest stride (m) whose stance sweep every leg reaches at this duty and drop.

        The bounding gaits keep a further 5 % in hand for the spine's flexion,
        which moves the girdles against the feet.
        """
        drops = self.drops
        half = min(float(np.interp(drop, drops, col)) for col in self._sweep_cols)
        margin = self.settings.reach_margin - 0.05 * bound
        return 2.0 * margin * half / max(duty, 1e-3)

    def _trailing_room(self) -> np.ndarray:
        """How far (m) each foot may still fall behind its girdle before it is out
        of reach, shape (4,); the body may vault by the planned allowance."""
        p = self.params
        keys, kh = self._key_points(self.root_xz, self.heading, self.bend)
        mid, fwd = self._girdle_frame(keys, kh)
        along = np.einsum("ij,ij->i", self.planted - mid, fwd)
        d0, d1 = self.drops_now
        drop = max(p.drop + self.settings.vault, float(max(d0, d1)))
        return np.interp(drop, self.drops, self._sweep_min) + along

    def _reach_governor(self, dt: float) -> float:
        """Fastest speed (m/s) at which no planted foot falls out of reach before
        it lifts off.

        In steady locomotion the stride limit already guarantees this and the
        cap is far above the speed; it acts when feet stay planted longer than
        a stride planned for (a skipped step as the character starts or stops).
        """
        p = self.params
        u = np.mod(self.theta / TWO_PI, 1.0)
        lifts = (u < p.duty) & (1.0 - MIN_SWING >= p.duty)
        t_lo = np.where(lifts, p.duty - u, 1.0 - u + min(p.duty, 1.0 - MIN_SWING)) / self.freq
        room = self._trailing_room()
        caps = np.maximum(room, 0.0) / np.maximum(t_lo, dt)
        return float(np.min(np.where(self.stance, caps, np.inf)))

    def needed_drop(self, leg: int, offset: float) -> float:
        """Body drop (fraction of pelvis height) at which a planted foot ``offset``
        metres fore or aft of its mid-stance point is within the leg's reach margin."""
        x = abs(offset) / self.settings.reach_margin
        return float(np.interp(x, self._sweep_cols[leg], self.drops))

    # ------------------------------------------------------------ stepping
    def step(self, command: Command, dt: float | None = None, *, pose: bool = True) -> dict:
        """Advance one step of ``dt`` seconds under ``command``.

        Returns
        -------
        frame : dict
            This frame's plan (arrays, see
            :data:`quadsim.locomotion.posing.PLAN_FIELDS`, plus ``contacts``
            (4,), ``gait`` (label), ``phase`` (4,) CPG stride fractions,
            ``speed``, ``duty``, ``spine``) and, with ``pose=True``, the posed
            skeleton: ``local_rotations`` (J, 3, 3), ``positions`` (J, 3)
            joint world positions (m) and ``ik_error`` (4,) (m).
            :func:`simulate` steps with ``pose=False`` and poses all frames
            at once at the end.
        """
        frame = self._advance(command, dt)
        if pose:
            plan = {k: np.asarray(frame[k])[None] for k in _POSE_KEYS}
            local, root, err = self.poser.pose(plan)
            _, P = forward_kinematics(self.character.skeleton, local, root)
            frame["local_rotations"] = local[0]
            frame["positions"] = P[0]
            frame["ik_error"] = err[0]
        return frame

    def _advance(self, command: Command, dt: float | None) -> dict:
        dt = self.dt if dt is None else float(dt)
        s = self.settings
        # 1. speed and turning -------------------------------------------
        v_cmd = float(command.speed)
        halt = v_cmd <= 1e-9
        if command.gait:
            cap = self.gait_speed_cap(resolve_gait_name(command.gait, self.character))
            if v_cmd > cap:
                self._warn("gait_speed", f"speed {v_cmd:.2f} m/s is above what the "
                           f"{command.gait} of {self.character.id} reaches ({cap:.2f} m/s); "
                           f"clamped to {cap:.2f} m/s")
                v_cmd = cap
        if v_cmd > self.max_speed:
            self._warn("speed", f"speed {v_cmd:.2f} m/s is above {self.character.id}'s fastest "
                       f"gait ({self.max_speed:.2f} m/s); clamped to {self.max_speed:.2f} m/s")
            v_cmd = self.max_speed
        sch = self.scheduler
        if sch.current == STAND or (sch.in_transition and sch.source_name == STAND):
            # feet planted: set off only as fast as the legs start to step
            progress = min(sch.elapsed / sch.duration, 1.0) if sch.in_transition else 0.0
            v_cmd = min(v_cmd, max(progress, 0.0) ** 2 * self.gaits[self.auto[0]].speed_range[1])
        v_cmd = min(v_cmd, self._reach_governor(dt))
        dv = min(max(v_cmd - self.speed, -s.acceleration * dt), s.acceleration * dt)
        v_before = self.speed
        self.speed = max(self.speed + float(dv), 0.0)
        v = self.speed
        max_rate = self.max_turn_rate_at(max(v, v_cmd))
        if command.heading is not None:
            rate = float(turn_rate_towards(self.heading, command.heading, max_rate))
        else:
            rate = float(command.turn_rate or 0.0)
            if abs(rate) > max_rate:
                self._warn("turn", f"turn rate {math.degrees(rate):.1f} deg/s is beyond "
                           f"{self.character.id}'s maximum at {max(v, v_cmd):.2f} m/s "
                           f"({math.degrees(max_rate):.1f} deg/s); clamped")
                rate = math.copysign(max_rate, rate)
        self.yaw_rate += (rate - self.yaw_rate) * (1.0 - math.exp(-dt / s.turn_response))

        # 2. gait -----------------------------------------------------------
        if command.gait:
            wanted = resolve_gait_name(command.gait, self.character)
            # a slow gait cannot carry a fast body: slow down in the automatic
            # gaits first, then change (a fast gait may start at any speed)
            if v > self.gait_speed_cap(wanted):
                wanted = self.scheduler.auto_choice(v)
        elif halt and v <= self.stand_speed:
            wanted = STAND
        else:
            wanted = self.scheduler.auto_choice(v)
        # setting off from a stand is quick: the first steps come at once
        quick = 0.6 if self.scheduler.current == STAND else None
        p = self.scheduler.update(wanted, v, dt, 1.0 / max(self.freq, 1e-3), quick)
        self.params = p
        limit = self.stride_limit(p.duty, p.drop + s.vault, p.bound)
        lam = min(p.stride_length(v, self.h), limit)
        lam_min_speed = min(p.stride_length(p.min_speed, self.h), limit)
        self.freq = max(v / lam, p.min_speed / lam_min_speed) if v > 1e-6 else \
            p.min_speed / lam_min_speed
        omega = TWO_PI * self.freq

        # 3. CPG ------------------------------------------------------------
        theta_prev = self.theta
        self.theta, self.r, self.theta_s, self.r_s = cpg_step(
            self.theta, self.r, self.theta_s, self.r_s, np.asarray(omega), p.phases, dt, s.cpg)
        # never let a phase run backwards (strong coupling at a start-up)
        self.theta = np.maximum(self.theta, theta_prev)

        # 4. body on its path -------------------------------------------------
        # trapezoidal in speed and heading: exact for constant acceleration
        self.heading = self.heading + self.yaw_rate * dt
        k = 0.5 * (v_before + v) * dt  # heading_vector in scalar form
        mid_heading = self.heading - 0.5 * self.yaw_rate * dt
        self.root_xz = self.root_xz + np.array([k * math.sin(mid_heading), k * 0.0,
                                                k * math.cos(mid_heading)])
        bend_target = min(max(self.yaw_rate * self.body_length / max(v, 0.3 * self.h),
                              -s.max_bend), s.max_bend)
        self.bend += (bend_target - self.bend) * (1.0 - math.exp(-dt / 0.2))
        keys, key_heading = self._key_points(self.root_xz, self.heading, self.bend)

        # 5. feet ---------------------------------------------------------------
        u = np.mod(self.theta / TWO_PI, 1.0)
        # a foot landing now stays down until the duty factor it will end with:
        # during a transition towards a longer stance, plan for the longer one
        final = self.scheduler.target(self.scheduler.current, v)
        stance_time = max(p.duty, min(final.duty, 1.0 - MIN_SWING)) / self.freq
        trailing = self._trailing_room() < v * dt  # out of reach by the next frame
        for i in range(4):
            if self.stance[i]:
                # lift off when the stride fraction passes the duty factor, unless
                # too little of the stride is left for a real step (then the foot
                # stays down for this stride: a duty factor near 1 is standing);
                # a foot about to trail out of reach lifts at once (a reflex that
                # only acts in transitions and starts)
                due = p.duty <= u[i] <= 1.0 - MIN_SWING
                if ((due or trailing[i]) and self.theta[i] - self.theta_td[i] > 1e-9):
                    self.stance[i] = False
                    self.liftoff[i] = self.planted[i]
                    # lift-off at the moment the stride fraction crossed the duty
                    # factor during this step (or now, if the duty factor fell)
                    cross = TWO_PI * (math.floor(self.theta[i] / TWO_PI) + p.duty)
                    self.theta_lo[i] = cross if due and cross > theta_prev[i] else self.theta[i]
                    td = TWO_PI * (math.floor(self.theta[i] / TWO_PI) + 1.0)
                    if td - self.theta[i] < TWO_PI * MIN_SWING:
                        td += TWO_PI  # too little left of this stride: land on the next
                    self.theta_td[i] = td
                    self.swing_s[i] = 0.0
            if not self.stance[i]:
                span = self.theta_td[i] - self.theta_lo[i]
                sp = min(max(float((self.theta[i] - self.theta_lo[i]) / span), 0.0), 1.0)
                self.swing_s[i] = max(self.swing_s[i], sp)
        g = _GIRDLE
        remaining = np.maximum(self.theta_td - self.theta, 0.0) / omega
        # land half a stance ahead of the girdle, but never beyond the leg's reach
        half = np.interp(p.drop + s.vault, self.drops, self._sweep_min)
        lead = min(0.5 * stance_time, self.settings.reach_margin * half / max(v, 1e-6))
        tau = remaining + lead
        kp, kh = arc_advance(keys[g], key_heading[g], v, self.yaw_rate, tau)
        target = kp + rotate_y(self.foot_offset, kh)
        target[:, Y] = 0.0
        swinging = ~self.stance
        step_len = np.linalg.norm(target - self.liftoff, axis=-1)
        height = np.minimum(p.swing_height, 0.35 * step_len + 0.3 * p.swing_height)
        pos = swing_position(self.liftoff, target, height, self.swing_s)
        feet = np.where(swinging[:, None], pos, self.planted)
        touch = swinging & (self.swing_s >= 1.0 - 1e-12)
        if np.any(touch):
            self.planted[touch] = target[touch]
            feet[touch] = target[touch]
            self.stance[touch] = True
        self.feet = feet
        fold_amount = np.where(self.stance, 0.0, np.sin(np.pi * self.swing_s) ** 2)

        # 6. spine, height, tail --------------------------------------------------
        fore_down = bool(self.stance[0] or self.stance[1])
        hind_down = bool(self.stance[2] or self.stance[3])
        state = spine_state(fore_down, hind_down)
        tgt = float(spine_target(state, self.flexed, self.extended))
        rate = 5.0 * abs(self.flexed - self.extended) * self.freq
        self.spine_angle = float(rate_limited(self.spine_angle, tgt, rate, dt))
        bound_angle = self.spine_angle
        slow_angle = float(flex_angle(self.theta_s, self.slow_scale * p.spine_amplitude))
        raw = p.bound * bound_angle + (1.0 - p.bound) * slow_angle
        self.spine_smooth += (raw - self.spine_smooth) * (1.0 - math.exp(-dt / 0.03))
        support = np.where(self.stance, np.sin(np.pi * np.minimum(np.maximum(u / max(p.duty, 1e-3), 0), 1)), 0)
        bob = 0.6 * p.drop * self.h * (0.5 - float(np.mean(support)))
        # vaulting: each girdle drops as far as its planted feet need
        mid, fwd = self._girdle_frame(keys, key_heading)
        along = np.einsum("ij,ij->i", self.feet - mid, fwd)
        need = np.array([self.needed_drop(i, along[i]) if self.stance[i] else 0.0
                         for i in range(4)])
        drop_g = np.maximum(p.drop, [need[2:].max(), need[:2].max()])  # hind, fore
        self.drops_now += (drop_g - self.drops_now) * (1.0 - math.exp(-dt / 0.04))
        target_h = self.pelvis_height * (1.0 - self.drops_now[0]) + bob
        self.height += (target_h - self.height) * (1.0 - math.exp(-dt / 0.04))
        pitch = math.atan2((self.drops_now[1] - self.drops_now[0]) * self.pelvis_height,
                           self.body_length)
        # girdle sway from where the left and right feet are (seed figure 5)
        local = rotate_y(self.feet - keys[g], -key_heading[g])
        width = np.maximum(np.abs(local[[0, 2], 0] - local[[1, 3], 0]), 1e-3)
        sway = np.minimum(np.maximum(0.1 * np.arctan2(local[[0, 2], 2] - local[[1, 3], 2],
                                                      width), -s.max_sway), s.max_sway)[::-1]
        # tail: each joint follows the one before with a lag
        n_tail = len(self.tail)
        if n_tail:
            drive = np.array([0.6 * self.spine_smooth - 0.02 * v,
                              -0.8 * self.bend - 0.5 * sway[0]]) / n_tail
            a = 1.0 - math.exp(-dt / s.tail_lag)
            prev = np.vstack([drive, self.tail[:-1]])
            self.tail = self.tail + a * (prev - self.tail)

        self.time += dt
        root = np.array([self.root_xz[0], self.height, self.root_xz[2]])
        return {
            "root": root,
            "heading": np.asarray(self.heading),
            "pitch": np.asarray(pitch),
            "sway": sway,
            "bend_yaw": np.asarray(self.bend),
            "bend_pitch": np.asarray(self.spine_smooth),
            "feet": self.feet.copy(),
            "fold": fold_amount,
            "toe": 0.5 * fold_amount,
            "tail": self.tail.copy(),
            "look": np.asarray(0.5 * self.bend),
            "contacts": self.stance.copy(),
            "gait": self.scheduler.label,
            "phase": np.mod(self.theta / TWO_PI, 1.0),
            "speed": np.asarray(v),
            "duty": np.asarray(p.duty),
            "spine": np.asarray(self.spine_smooth),
            "heading_rate": np.asarray(self.yaw_rate),
            "amplitude": np.append(self.r, self.r_s),
        }

    def pose(self, plans: dict[str, np.ndarray]):
        """Local rotations (T, J, 3, 3), root positions (T, 3) and IK errors (T, 4)."""
        return self.poser.pose(plans)


#: the plan fields the posing reads
_POSE_KEYS = ("root", "heading", "pitch", "sway", "bend_yaw", "bend_pitch", "feet", "fold",
              "toe", "tail", "look")

_ARRAY_KEYS = ("root", "heading", "pitch", "sway", "bend_yaw", "bend_pitch", "feet", "fold",
               "toe", "tail", "look", "contacts", "phase", "speed", "duty", "spine",
               "heading_rate", "amplitude")


def stack_plans(plans: list[dict]) -> dict[str, np.ndarray]:
    """Stack per-frame plans into arrays with a leading frame axis."""
    out = {k: np.stack([np.asarray(pl[k]) for pl in plans]) for k in _ARRAY_KEYS}
    out["gait"] = np.array([pl["gait"] for pl in plans], dtype=object)
    return out


def simulate(character: Character, script: Script | Command, duration: float, fps: float,
             *, seed: int = 0, settings: ControllerSettings | None = None) -> Motion:
    """Run a scripted sequence of commands and return the motion.

    Parameters
    ----------
    character : Character
    script : Script or Command
        The commands over time (a single command is held throughout).
    duration : float
        Seconds to simulate (> 0).
    fps : float
        Frames per second; the controller steps once per frame.
    seed : int

    Returns
    -------
    Motion
        ``int(round(duration * fps))`` frames, frame ``k`` at ``t = k / fps``
        (the state after ``k`` steps), with planned contacts, gait labels
        and, in ``extras``, the CPG stride fractions ``phase`` (T, 4), the
        spine angle ``spine`` (T,), the duty factor ``duty`` (T,), the speed
        ``speed`` (T,) and the IK error ``ik_error`` (T, 4).
    """
    if isinstance(script, Command):
        script = Script.constant(script)
    if not (math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a positive number of seconds, got {duration!r}")
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive number, got {fps!r}")
    n = int(round(duration * fps))
    dt = 1.0 / fps
    first = script.commands[0]
    ctl = ProceduralController(character, dt=dt, seed=seed, gait=first.gait, settings=settings)
    # frame 0 is the starting state; frame k follows k steps of dt
    plans = [ctl.step(first, 0.0, pose=False)]
    plans += [ctl.step(script.command_at((k - 1) * dt), dt, pose=False) for k in range(1, n)]
    plan = stack_plans(plans)
    local, root, err = ctl.pose(plan)
    return Motion(
        character.skeleton, fps, root, quaternions_from_matrices(local),
        contacts=plan["contacts"], gaits=plan["gait"], foot_joints=character.foot_joints,
        extras={"phase": plan["phase"], "spine": plan["spine"], "duty": plan["duty"],
                "speed": plan["speed"], "ik_error": err, "heading": plan["heading"],
                "cpg_amplitude": plan["amplitude"]},
    )


__all__ = ["ControllerSettings", "ProceduralController", "QuadsimClampWarning", "simulate",
           "stack_plans"]
