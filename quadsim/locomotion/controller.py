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
in one compiled pass at the end.

Speed: one character's state is a few numbers per leg, so a step keeps it
in plain Python floats and lists -- numpy's per-call overhead on arrays of
four numbers costs more than the arithmetic -- and runs the heavy stages as
compiled kernels over rows, the very ones
:class:`~quadsim.locomotion.batch.BatchController` runs for N characters:
the CPG step (:func:`~quadsim.locomotion.cpg.cpg_step_rows`), the feet
(:func:`~quadsim.locomotion.plan_kernels.feet_rows`) and the posing, leg IK
and forward kinematics (:mod:`quadsim.locomotion.pose_kernel`), for a single
frame and a whole clip alike. Tests hold the batch to the same motion to
1e-9.

Bad commands: a negative or non-finite speed or turn rate raises
``ValueError`` (:class:`~quadsim.locomotion.commands.Command` checks it); an
unknown gait raises :class:`~quadsim.errors.InputError`; a speed above the
character's fastest gait, or a turn rate above its maximum, is clamped with
a ``QuadsimClampWarning`` that names the value and the limit.
"""

from __future__ import annotations

import math
import warnings
import weakref
from itertools import chain
from dataclasses import dataclass, field, replace

import numpy as np

from quadsim.frames import Y
from quadsim.kinematics.ik import solve_leg
from quadsim.kinematics.rotations import quaternions_from_matrices
from quadsim.locomotion.commands import Command, Script
from quadsim.locomotion.cpg import CPGParams, cpg_step_rows
from quadsim.locomotion.gaits import (
    Gait,
    auto_gaits,
    gait_table,
    max_speed,
    resolve_gait_name,
)
from quadsim.locomotion.plan_kernels import MIN_SWING, feet_rows
from quadsim.locomotion.posing import Poser
from quadsim.locomotion.scalar import TWO_PI, interp
from quadsim.locomotion.transition import GaitScheduler
from quadsim.locomotion.turning import turn_rate_towards
from quadsim.skeleton.character import Character
from quadsim.skeleton.motion import Motion


#: The standing state: every foot planted (duty factor 1), entered when the
#: commanded speed is zero and left when it is not.
STAND = "stand"



#: Measured stance sweeps per character (see ProceduralController._measure_sweeps).
_SWEEPS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _standing(slowest: Gait) -> Gait:
    """A gait with duty factor 1 on the slowest gait's clock: once its
    transition ends no foot lifts, so the character stands."""
    return replace(slowest, name=STAND, duty_range=(1.0, 1.0), spine_amplitude=0.0,
                   drop=0.0)


def initial_oscillators(gait: Gait, seed: int):
    """Seeded starting state of the oscillators for a start in ``gait``.

    The left hind foot starts in mid-stance, every phase and amplitude with a
    small seeded perturbation. Returns ``theta`` (4,), ``r`` (4,) and the
    spine phase ``theta_s`` (0-d array).
    """
    rng = np.random.default_rng(seed)
    beta = float(gait.duty(gait.speed_range[0]))
    theta = TWO_PI * (0.5 * beta - gait.phases) + rng.normal(0.0, 0.05, 4)
    r = np.full(4, 1.0) + rng.normal(0.0, 0.02, 4)
    theta_s = np.asarray(theta[2] + rng.normal(0.0, 0.05))
    return theta, r, theta_s


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
        sweep = _SWEEPS.get(ch)
        if sweep is None:
            # a property of the (immutable) character alone: measured once
            sweep = np.maximum.accumulate(self._measure_sweeps(self.drops), axis=0)
            sweep.setflags(write=False)
            _SWEEPS[ch] = sweep
        self.half_sweep = sweep
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
        # plain-float copies for the per-step maths (quadsim.locomotion.scalar)
        self._drops_f = self.drops.tolist()
        self._sweep_cols_f = tuple(c.tolist() for c in self._sweep_cols)
        self._sweep_min_f = self._sweep_min.tolist()
        self._offset_f = tuple(tuple(o) for o in self.foot_offset.tolist())
        self._offset_1 = np.ascontiguousarray(self.foot_offset[None], dtype=float)

    def _init_state(self, seed: int) -> None:
        # per-leg state as lists of plain floats (legs LF, RF, LH, RH), points
        # as 3-tuples: numpy on four numbers costs more in calls than in sums
        theta, r, theta_s = initial_oscillators(self.gaits[self.scheduler.current], seed)
        self.theta = theta.tolist()
        self.r = r.tolist()
        self.theta_s = float(theta_s)
        self.r_s = 1.0
        self.time = 0.0
        self.speed = 0.0
        self.yaw_rate = 0.0
        self.heading = 0.0
        self.root_xz = (0.0, 0.0, 0.0)
        self.bend = 0.0
        self.spine_angle = 0.0
        self.spine_smooth = 0.0
        self.height = self.pelvis_height
        self.drops_now = [0.0, 0.0]
        self.tail = self.tail_rest.tolist()
        self.stance = [True] * 4
        feet = self.character.rest_foot_positions().copy()
        feet[:, Y] = 0.0
        self.planted = [tuple(f) for f in feet.tolist()]
        self.feet = list(self.planted)
        # the feet's state as the compiled stage 5 updates it in place (one row;
        # stance and planted are mirrored in the lists above)
        self._feet_state = {
            "stance": np.ones((1, 4), dtype=bool), "swing_s": np.zeros((1, 4)),
            "theta_lo": np.array([self.theta]), "theta_td": np.array([self.theta]),
            "planted": feet[None].copy(), "liftoff": feet[None].copy()}
        self.params = self.scheduler.params(0.0)
        self.freq = 1.0

    # ------------------------------------------------------------ helpers
    def _warn(self, key: str, msg: str) -> None:
        if key not in self._warned:
            self._warned.add(key)
            warnings.warn(msg, QuadsimClampWarning, stacklevel=3)

    def _key_points(self, root_xz, heading, bend):
        """Hind and fore key points (two 3-tuples) and their headings (two floats)."""
        # rotate_y of (0, 0, z) about +Y, in scalar form: (z sin h, 0, z cos h)
        hz, bl = self.hind_z, self.body_length
        fh = heading + 0.5 * bend
        x, y, z = root_xz
        hx, hy, hzz = x + math.sin(heading) * hz, y + 0.0, z + math.cos(heading) * hz
        keys = ((hx, hy, hzz), (hx + math.sin(fh) * bl, hy + 0.0, hzz + math.cos(fh) * bl))
        return keys, (heading, heading + bend)

    def _girdle_frame(self, keys, key_heading):
        """Each foot's mid-stance point and its girdle's forward vector (lists
        of four 3-tuples)."""
        mids, fwds = [], []
        for g in (0, 1):
            kh = key_heading[g]
            c, sn = math.cos(kh), math.sin(kh)
            kx, ky, kz = keys[g]
            for ox, oy, oz in self._offset_f[2 - 2 * g:4 - 2 * g]:
                mids.append((c * ox + sn * oz + kx, oy + ky, -sn * ox + c * oz + kz))
                fwds.append((sn, 0.0, c))
        # legs in order LF, RF (fore girdle), LH, RH (hind)
        return mids[2:] + mids[:2], fwds[2:] + fwds[:2]

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
        drops = self._drops_f
        half = min(interp(drop, drops, col) for col in self._sweep_cols_f)
        margin = self.settings.reach_margin - 0.05 * bound
        return 2.0 * margin * half / max(duty, 1e-3)

    def _trailing_room(self, girdles=None) -> list[float]:
        """How far (m) each foot may still fall behind its girdle before it is out
        of reach, four floats; the body may vault by the planned allowance.
        ``girdles``: this state's :meth:`_girdle_frame`, if already known."""
        p = self.params
        if girdles is None:
            keys, kh = self._key_points(self.root_xz, self.heading, self.bend)
            girdles = self._girdle_frame(keys, kh)
        mid, fwd = girdles
        d0, d1 = self.drops_now
        drop = max(p.drop + self.settings.vault, max(d0, d1))
        base = interp(drop, self._drops_f, self._sweep_min_f)
        return [base + ((a[0] - m[0]) * f[0] + (a[1] - m[1]) * f[1] + (a[2] - m[2]) * f[2])
                for a, m, f in zip(self.planted, mid, fwd)]

    def _reach_governor(self, dt: float) -> float:
        """Fastest speed (m/s) at which no planted foot falls out of reach before
        it lifts off.

        In steady locomotion the stride limit already guarantees this and the
        cap is far above the speed; it acts when feet stay planted longer than
        a stride planned for (a skipped step as the character starts or stops).
        """
        duty = self.params.duty
        room = self._trailing_room()
        out = math.inf
        for th, down, rm in zip(self.theta, self.stance, room):
            if not down:
                continue
            u = (th / TWO_PI) % 1.0
            lifts = u < duty and 1.0 - MIN_SWING >= duty
            t_lo = (duty - u if lifts else 1.0 - u + min(duty, 1.0 - MIN_SWING)) / self.freq
            den = max(t_lo, dt)
            num = max(rm, 0.0)
            if den == 0.0:  # as numpy: x / 0 is inf, 0 / 0 is nan (and nan wins)
                if num == 0.0:
                    return math.nan
                continue
            out = min(out, num / den)
        return out

    def needed_drop(self, leg: int, offset: float) -> float:
        """Body drop (fraction of pelvis height) at which a planted foot ``offset``
        metres fore or aft of its mid-stance point is within the leg's reach margin."""
        x = abs(offset) / self.settings.reach_margin
        return interp(x, self._sweep_cols_f[leg], self._drops_f)

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
        raw = self._advance(command, dt)
        n_tail = len(raw["tail"])
        frame = {k: np.array(v) for k, v in raw.items()}
        frame["tail"] = frame["tail"].reshape(n_tail, 2)
        frame["gait"] = raw["gait"]
        if pose:
            local, P, err = self.poser.pose_one(raw)
            frame["local_rotations"] = local
            frame["positions"] = P
            frame["ik_error"] = err
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
        c = s.cpg  # the compiled network step, one row (as the batch's N)
        th, rr, ts, rs = cpg_step_rows(
            np.array([self.theta]), np.array([self.r]), np.array([self.theta_s]),
            np.array([self.r_s]), np.array([omega]), np.array([p.phases], dtype=float), dt,
            c.mu, c.gain, c.coupling, c.spine_coupling, c.substeps)
        theta, self.r = th[0].tolist(), rr[0].tolist()
        self.theta_s, self.r_s = float(ts[0]), float(rs[0])
        # never let a phase run backwards (strong coupling at a start-up)
        theta = self.theta = [max(a, b) for a, b in zip(theta, theta_prev)]

        # 4. body on its path -------------------------------------------------
        # trapezoidal in speed and heading: exact for constant acceleration
        self.heading = self.heading + self.yaw_rate * dt
        k = 0.5 * (v_before + v) * dt  # heading_vector in scalar form
        mid_heading = self.heading - 0.5 * self.yaw_rate * dt
        x, y, z = self.root_xz
        self.root_xz = (x + k * math.sin(mid_heading), y + k * 0.0, z + k * math.cos(mid_heading))
        bend_target = min(max(self.yaw_rate * self.body_length / max(v, 0.3 * self.h),
                              -s.max_bend), s.max_bend)
        self.bend += (bend_target - self.bend) * (1.0 - math.exp(-dt / 0.2))
        keys, key_heading = self._key_points(self.root_xz, self.heading, self.bend)

        # 5. feet: the compiled stage the batch runs (plan_kernels.feet_rows), one row
        u = [(t / TWO_PI) % 1.0 for t in theta]
        duty = p.duty
        # a foot landing now stays down until the duty factor it will end with:
        # during a transition towards a longer stance, plan for the longer one
        final = self.scheduler.target(self.scheduler.current, v)
        reach = v * dt
        girdles = self._girdle_frame(keys, key_heading)
        trailing = [room < reach for room in self._trailing_room(girdles)]  # out of reach soon
        # land half a stance ahead of the girdle, but never beyond the leg's reach
        half = interp(p.drop + s.vault, self._drops_f, self._sweep_min_f)
        fs = self._feet_state
        feet_a = np.empty((1, 4, 3))
        fold_a = np.empty((1, 4))
        feet_rows(np.array([theta]), np.array([theta_prev]), np.array([duty]),
                  np.array([final.duty]), np.array([self.freq]), np.array([v]),
                  np.array([self.yaw_rate]), np.array([keys]), np.array([key_heading]),
                  self._offset_1, np.array([trailing]), np.array([p.swing_height]),
                  np.array([half]), s.reach_margin, fs["stance"], fs["swing_s"], fs["theta_lo"],
                  fs["theta_td"], fs["planted"], fs["liftoff"], feet_a, fold_a)
        stance = self.stance = fs["stance"][0].tolist()
        self.planted = [tuple(f) for f in fs["planted"][0].tolist()]
        feet = self.feet = [tuple(f) for f in feet_a[0].tolist()]
        fold = fold_a[0].tolist()

        # 6. spine, height, tail --------------------------------------------------
        # the concave/convex machine: flexed while no hind foot is down
        # (double flight, front stance), extended otherwise (spine_state)
        tgt = self.extended if (stance[2] or stance[3]) else self.flexed
        rate = 5.0 * abs(self.flexed - self.extended) * self.freq
        self.spine_angle += min(max(tgt - self.spine_angle, -rate * dt), rate * dt)
        slow_angle = self.slow_scale * p.spine_amplitude * math.sin(self.theta_s)
        raw = p.bound * self.spine_angle + (1.0 - p.bound) * slow_angle
        self.spine_smooth += (raw - self.spine_smooth) * (1.0 - math.exp(-dt / 0.03))
        sdut = max(duty, 1e-3)
        support = [math.sin(math.pi * min(max(ui / sdut, 0), 1)) if down else 0.0
                   for ui, down in zip(u, stance)]
        bob = 0.6 * p.drop * self.h * (0.5 - sum(support) / 4)
        # vaulting: each girdle drops as far as its planted feet need
        mid, fwd = girdles
        need = [0.0] * 4
        for i in range(4):
            if stance[i]:
                f, m, w = feet[i], mid[i], fwd[i]
                along = (f[0] - m[0]) * w[0] + (f[1] - m[1]) * w[1] + (f[2] - m[2]) * w[2]
                need[i] = self.needed_drop(i, along)
        drop_g = (max(p.drop, max(need[2], need[3])), max(p.drop, max(need[0], need[1])))
        a = 1.0 - math.exp(-dt / 0.04)
        d0, d1 = self.drops_now
        d0, d1 = d0 + (drop_g[0] - d0) * a, d1 + (drop_g[1] - d1) * a
        self.drops_now = [d0, d1]
        target_h = self.pelvis_height * (1.0 - d0) + bob
        self.height += (target_h - self.height) * a
        pitch = math.atan2((d1 - d0) * self.pelvis_height, self.body_length)
        # girdle sway from where the left and right feet are (seed figure 5)
        local = []
        for i in range(4):
            g = 1 if i < 2 else 0
            kx, ky, kz = keys[g]
            c, sn = math.cos(-key_heading[g]), math.sin(-key_heading[g])
            fx, fz = feet[i][0] - kx, feet[i][2] - kz
            local.append((c * fx + sn * fz, -sn * fx + c * fz))
        sway = []
        for left, right in ((2, 3), (0, 1)):  # hind, fore
            width = max(abs(local[left][0] - local[right][0]), 1e-3)
            sway.append(min(max(0.1 * math.atan2(local[left][1] - local[right][1], width),
                                -s.max_sway), s.max_sway))
        # tail: each joint follows the one before with a lag
        n_tail = len(self.tail)
        if n_tail:
            prev = [(0.6 * self.spine_smooth - 0.02 * v) / n_tail,
                    (-0.8 * self.bend - 0.5 * sway[0]) / n_tail]
            a = 1.0 - math.exp(-dt / s.tail_lag)
            tail = []
            for t in self.tail:
                tail.append([t[0] + a * (prev[0] - t[0]), t[1] + a * (prev[1] - t[1])])
                prev = t
            self.tail = tail

        self.time += dt
        # the plan in plain floats and lists (step() makes arrays of it)
        return {
            "root": [self.root_xz[0], self.height, self.root_xz[2]],
            "heading": self.heading,
            "pitch": pitch,
            "sway": sway,
            "bend_yaw": self.bend,
            "bend_pitch": self.spine_smooth,
            "feet": feet,
            "fold": fold,
            "toe": [0.5 * f for f in fold],
            "tail": self.tail,
            "look": 0.5 * self.bend,
            "contacts": list(stance),
            "gait": self.scheduler.label,
            "phase": u,
            "speed": v,
            "duty": duty,
            "spine": self.spine_smooth,
            "heading_rate": self.yaw_rate,
            "amplitude": self.r + [self.r_s],
        }

    def pose(self, plans: dict[str, np.ndarray]):
        """Local rotations (T, J, 3, 3), root positions (T, 3) and IK errors (T, 4)."""
        return self.poser.pose(plans)


_ARRAY_KEYS = ("root", "heading", "pitch", "sway", "bend_yaw", "bend_pitch", "feet", "fold",
               "toe", "tail", "look", "contacts", "phase", "speed", "duty", "spine",
               "heading_rate", "amplitude")


def stack_plans(plans: list[dict]) -> dict[str, np.ndarray]:
    """Stack per-frame plans (arrays, or the plain lists of a raw plan) into
    arrays with a leading frame axis."""
    T = len(plans)
    out = {}
    for k in _ARRAY_KEYS:
        first = plans[0][k] if T else 0.0
        shape = np.shape(first)
        dtype = bool if k == "contacts" else float
        if isinstance(first, np.ndarray) or not shape:
            out[k] = np.array([pl[k] for pl in plans], dtype=dtype).reshape((T,) + shape)
            continue
        # nested lists: flatten level by level and read them in one pass
        flat = (pl[k] for pl in plans)
        for _ in shape:
            flat = chain.from_iterable(flat)
        out[k] = np.fromiter(flat, dtype=dtype, count=T * math.prod(shape)).reshape(
            (T,) + shape)
    n_tail = len(plans[0]["tail"]) if plans else 0
    out["tail"] = out["tail"].reshape(T, n_tail, 2)
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
    # (the plain-float plans of _advance, stacked once: no per-frame arrays)
    plans = [ctl._advance(first, 0.0)]
    plans += [ctl._advance(script.command_at((k - 1) * dt), dt) for k in range(1, n)]
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
