"""The procedural locomotion controller: commands in, poses out.

One :class:`ProceduralController` drives one character. Each call of
:meth:`ProceduralController.step` advances it by ``dt`` under a
:class:`~quadsim.commands.Command`:

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

Speed: the whole per-frame plan (stages 1-6 but the posing) is one compiled
kernel over rows of characters,
:func:`~quadsim.locomotion.plan_kernels.plan_rows`, the very one
:class:`~quadsim.locomotion.batch.BatchController` runs for N characters: a
lone controller keeps its state as one row of the kernel's arrays (read
back through properties such as :attr:`ProceduralController.speed`) and
steps it with one call; the posing, leg IK and forward kinematics are the
compiled kernels of :mod:`quadsim.locomotion.pose_kernel`, for a single frame
and a whole clip alike. The kernel reports its clamps as flags and the
warnings are raised here. Tests hold the batch to the same motion to 1e-9.

Bad commands: a negative or non-finite speed or turn rate raises
``ValueError`` (:class:`~quadsim.commands.Command` checks it); an
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
from quadsim.commands import Command, Script
from quadsim.errors import QuadsimClampWarning
from quadsim.locomotion.cpg import TWO_PI, CPGParams
from quadsim.locomotion.gaits import (
    GAIT_NAMES,
    Gait,
    auto_gaits,
    gait_table,
    max_speed,
    resolve_gait_name,
)
from quadsim.locomotion import plan_kernels as _pk
from quadsim.locomotion.plan_kernels import run_plan, step_scalars
from quadsim.locomotion.posing import Poser
from quadsim.locomotion.transition import GaitParams, GaitScheduler
from quadsim.skeleton.character import Character
from quadsim.skeleton.motion import Motion


#: The standing state: every foot planted (duty factor 1), entered when the
#: commanded speed is zero and left when it is not.
STAND = "stand"

#: Gait identifiers by number: the eight gaits, then the standing state.
GAIT_IDS: tuple[str, ...] = GAIT_NAMES + (STAND,)



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


class _Rows:
    """A bag of arrays (the compiled plan's constants or state), as attributes."""

    def __init__(self, **arrays):
        self.__dict__.update(arrays)


def _params_of(row) -> GaitParams:
    """GaitParams of a parameter row (plan_kernels' columns)."""
    return GaitParams(float(row[_pk.P_DUTY]), np.array(row[_pk.P_PH0:_pk.P_PH0 + 4]),
                      float(row[_pk.P_COEF]), float(row[_pk.P_MINV]), float(row[_pk.P_SWING]),
                      float(row[_pk.P_DROP]), float(row[_pk.P_BOUND]), float(row[_pk.P_SPAMP]))


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
        self._offset_1 = np.ascontiguousarray(self.foot_offset[None], dtype=float)

    def _tables(self) -> None:
        """The compiled plan's constants for this character, one row
        (:func:`~quadsim.locomotion.plan_kernels.plan_rows`)."""
        G = len(GAIT_IDS)
        table = np.full((G, _pk.NP_), np.nan)
        law = np.full((G, 4), np.nan)  # speed lo, hi, duty lo, hi
        has = np.zeros(G, dtype=bool)
        for g, name in enumerate(GAIT_IDS):
            gait = self.gaits.get(name)
            if gait is None:
                continue
            has[g] = True
            table[g, _pk.P_PH0:_pk.P_PH0 + 4] = gait.phases
            table[g, _pk.P_COEF] = gait.stride_coefficient
            table[g, _pk.P_MINV] = gait.speed_range[0]
            table[g, _pk.P_SWING] = gait.swing_height
            table[g, _pk.P_DROP] = gait.drop
            table[g, _pk.P_BOUND] = 1.0 if gait.spine == "bound" else 0.0
            table[g, _pk.P_SPAMP] = gait.spine_amplitude
            law[g] = (*gait.speed_range, *gait.duty_range)
        self.gait_table, self.gait_law, self.gait_has = table, law, has
        self.auto_ids = np.array([GAIT_IDS.index(n) for n in self.auto], dtype=np.int64)
        consts = np.zeros(_pk.NC)
        consts[_pk.C_H] = self.h
        consts[_pk.C_PELVIS] = self.pelvis_height
        consts[_pk.C_HIND_Z] = self.hind_z
        consts[_pk.C_BODY] = self.body_length
        consts[_pk.C_STAND_V] = self.stand_speed
        consts[_pk.C_MAX_V] = self.max_speed
        consts[_pk.C_MAX_TURN] = self.max_turn_rate
        consts[_pk.C_FLEXED] = self.flexed
        consts[_pk.C_EXTENDED] = self.extended
        consts[_pk.C_RMIN] = self.min_turn_radius * self.body_length
        consts[_pk.C_SLOW] = self.slow_scale
        consts[_pk.C_WALK_TOP] = self.gaits[self.auto[0]].speed_range[1]
        consts[_pk.C_NTAIL] = max(len(self.character.tail), 1)
        consts[_pk.C_HYST] = self.scheduler.hysteresis
        consts[_pk.C_NAUTO] = len(self.auto)
        self.plan_consts = consts
        pos = np.full(G, -1, dtype=np.int64)
        pos[self.auto_ids] = np.arange(len(self.auto))
        bounds = np.full(len(self.auto), np.inf)
        bounds[:len(self.scheduler.bounds)] = self.scheduler.bounds
        self._k = _Rows(
            kind=np.zeros(1, dtype=np.int64), consts=np.ascontiguousarray(consts[:, None]),
            table=table[None].copy(), law=law[None].copy(), auto=self.auto_ids[None].copy(),
            bounds=bounds[None].copy(), auto_pos=pos[None].copy(),
            drops=np.ascontiguousarray(self.drops, dtype=float),
            half_sweep=np.ascontiguousarray(self.half_sweep[None], dtype=float),
            sweep_min=np.ascontiguousarray(self._sweep_min[None], dtype=float),
            sweep_cols=np.ascontiguousarray(np.swapaxes(self.half_sweep, 0, 1)[None],
                                            dtype=float),
            foot_offset=self._offset_1)

    def _target_row(self, gait_id: int, speed: float) -> np.ndarray:
        """Parameter row (NP,) of a gait at ``speed`` (GaitScheduler.target)."""
        out = self.gait_table[gait_id].copy()
        lo, hi, d0, d1 = self.gait_law[gait_id]
        s = min(max((speed - lo) / (hi - lo), 0.0), 1.0)
        out[_pk.P_DUTY] = d0 + s * (d1 - d0)
        return out

    def _init_state(self, seed: int) -> None:
        # the state as one row of the arrays the compiled plan updates in
        # place (plan_kernels.plan_rows), as the batch's N rows
        self._tables()
        theta, r, theta_s = initial_oscillators(self.gaits[self.scheduler.current], seed)
        feet = self.character.rest_foot_positions().copy()
        feet[:, Y] = 0.0
        start = GAIT_IDS.index(self.scheduler.current)
        self._s = _Rows(
            speed=np.zeros(1), yaw_rate=np.zeros(1), heading=np.zeros(1),
            root_xz=np.zeros((1, 3)), bend=np.zeros(1), theta=theta[None].astype(float),
            r=r[None].astype(float), theta_s=np.array([float(theta_s)]), r_s=np.ones(1),
            freq=np.ones(1), current=np.array([start], dtype=np.int64),
            source_name=np.array([start], dtype=np.int64), source=np.zeros((1, _pk.NP_)),
            in_transition=np.zeros(1, dtype=bool), elapsed=np.zeros(1),
            duration=np.zeros(1), params=self._target_row(start, 0.0)[None],
            stance=np.ones((1, 4), dtype=bool), swing_s=np.zeros((1, 4)),
            theta_lo=theta[None].astype(float), theta_td=theta[None].astype(float),
            planted=feet[None].copy(), liftoff=feet[None].copy(), spine_angle=np.zeros(1),
            spine_smooth=np.zeros(1), drops_now=np.zeros((1, 2)),
            height=np.array([self.pelvis_height]),
            tail=np.zeros((1, len(self.character.tail), 2)))
        self.time = 0.0
        self.feet = [tuple(f) for f in feet.tolist()]
        self._sc: dict[float, np.ndarray] = {}
        # the command as one row (speed, turn rate, heading, gait id), reused
        self._cmd = (np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1, dtype=np.int64))
        self._gait_ids: dict[str, tuple[str, int]] = {}

    # the state, read from the compiled plan's row
    speed = property(lambda self: float(self._s.speed[0]), doc="Forward speed (m/s).")
    heading = property(lambda self: float(self._s.heading[0]), doc="Heading about +Y (rad).")
    yaw_rate = property(lambda self: float(self._s.yaw_rate[0]), doc="Turn rate (rad/s).")
    bend = property(lambda self: float(self._s.bend[0]), doc="Spine yaw bend (rad).")
    freq = property(lambda self: float(self._s.freq[0]), doc="Stride frequency (Hz).")
    height = property(lambda self: float(self._s.height[0]), doc="Pelvis height (m).")
    spine_smooth = property(lambda self: float(self._s.spine_smooth[0]))
    spine_angle = property(lambda self: float(self._s.spine_angle[0]))
    theta_s = property(lambda self: float(self._s.theta_s[0]))
    r_s = property(lambda self: float(self._s.r_s[0]))
    theta = property(lambda self: self._s.theta[0].tolist(), doc="Leg phases (rad).")
    r = property(lambda self: self._s.r[0].tolist())
    stance = property(lambda self: self._s.stance[0].tolist(), doc="Planted feet (4 bools).")
    planted = property(lambda self: [tuple(f) for f in self._s.planted[0].tolist()])
    root_xz = property(lambda self: tuple(self._s.root_xz[0].tolist()))
    drops_now = property(lambda self: self._s.drops_now[0].tolist())
    tail = property(lambda self: self._s.tail[0].tolist())

    @property
    def params(self) -> GaitParams:
        """The blended gait parameters of the last step."""
        return _params_of(self._s.params[0])

    # ------------------------------------------------------------ helpers
    def _warn(self, key: str, msg: str) -> None:
        if key not in self._warned:
            self._warned.add(key)
            warnings.warn(msg, QuadsimClampWarning, stacklevel=3)

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
        half = min(float(np.interp(drop, self.drops, col)) for col in self._sweep_cols)
        margin = self.settings.reach_margin - 0.05 * bound
        return 2.0 * margin * half / max(duty, 1e-3)

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

    def _gait_id(self, name: str) -> tuple[str, int]:
        out = self._gait_ids.get(name)
        if out is None:
            resolved = resolve_gait_name(name, self.character)
            out = self._gait_ids[name] = (resolved, GAIT_IDS.index(resolved))
        return out

    def _sync_scheduler(self) -> None:
        """Mirror the compiled plan's gait state on :attr:`scheduler`."""
        st, sch = self._s, self.scheduler
        sch.current = GAIT_IDS[st.current[0]]
        sch.source_name = GAIT_IDS[st.source_name[0]]
        sch.elapsed = float(st.elapsed[0])
        sch.duration = float(st.duration[0])
        if not st.in_transition[0]:
            sch.source = None
        elif sch.source is None or st.elapsed[0] == 0.0:
            sch.source = _params_of(st.source[0])

    def _plan(self, command: Command, dt: float | None):
        """One step of the compiled plan (plan_kernels.plan_rows, one row),
        warnings raised for its clamps. Returns the kernel's feet (1, 4, 3),
        fold (1, 4), pitch (1,) and sway (1, 2); the rest is in the state."""
        dt = self.dt if dt is None else float(dt)
        sc = self._sc.get(dt)
        if sc is None:
            sc = self._sc[dt] = step_scalars(self.settings, dt)
        v_cmd = float(command.speed)
        gait_name, gid = self._gait_id(command.gait) if command.gait else (None, -1)
        head = math.nan if command.heading is None else float(command.heading)
        turn = float(command.turn_rate or 0.0) if command.heading is None else 0.0
        st = self._s
        cv, ct, ch, cg = self._cmd
        cv[0], ct[0], ch[0], cg[0] = v_cmd, turn, head, gid
        feet, fold, pitch, sway, flags, aux = run_plan(
            self._k, st, cv, ct, ch, cg, sc, self.settings.cpg.substeps)
        if flags.any():
            if flags[0, 0]:
                cap = self.gait_speed_cap(gait_name)
                self._warn("gait_speed", f"speed {v_cmd:.2f} m/s is above what the "
                           f"{command.gait} of {self.character.id} reaches ({cap:.2f} m/s); "
                           f"clamped to {cap:.2f} m/s")
                v_cmd = cap
            if flags[0, 1]:
                self._warn("speed", f"speed {v_cmd:.2f} m/s is above {self.character.id}'s "
                           f"fastest gait ({self.max_speed:.2f} m/s); clamped to "
                           f"{self.max_speed:.2f} m/s")
            if flags[0, 2]:
                fast, max_rate = float(aux[0, 0]), float(aux[0, 1])
                self._warn("turn", f"turn rate {math.degrees(turn):.1f} deg/s is beyond "
                           f"{self.character.id}'s maximum at {fast:.2f} m/s "
                           f"({math.degrees(max_rate):.1f} deg/s); clamped")
        self._sync_scheduler()
        self.time += dt
        return feet, fold, pitch, sway

    def _advance(self, command: Command, dt: float | None) -> dict:
        """One step; this frame's plan in plain floats and lists."""
        feet, fold, pitch, sway = self._plan(command, dt)
        st = self._s
        f = feet[0].tolist()
        self.feet = f
        fl = fold[0].tolist()
        theta = st.theta[0].tolist()
        bend = float(st.bend[0])
        spine = float(st.spine_smooth[0])
        # the plan of this frame (step() makes arrays of it, simulate stacks them)
        return {
            "root": [float(st.root_xz[0, 0]), float(st.height[0]), float(st.root_xz[0, 2])],
            "heading": float(st.heading[0]),
            "pitch": float(pitch[0]),
            "sway": sway[0].tolist(),
            "bend_yaw": bend,
            "bend_pitch": spine,
            "feet": f,
            "fold": fl,
            "toe": [0.5 * x for x in fl],
            "tail": st.tail[0].tolist(),
            "look": 0.5 * bend,
            "contacts": st.stance[0].tolist(),
            "gait": self.scheduler.label,
            "phase": [(t / TWO_PI) % 1.0 for t in theta],
            "speed": float(st.speed[0]),
            "duty": float(st.params[0, _pk.P_DUTY]),
            "spine": spine,
            "heading_rate": float(st.yaw_rate[0]),
            "amplitude": st.r[0].tolist() + [float(st.r_s[0])],
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
    # (the compiled plan's row copied into the clip's arrays: no per-frame dicts)
    st = ctl._s
    n_tail = len(character.tail)
    root, heading, pitch, sway = np.empty((n, 3)), np.empty(n), np.empty(n), np.empty((n, 2))
    bend, spine, feet, fold = np.empty(n), np.empty(n), np.empty((n, 4, 3)), np.empty((n, 4))
    tail, contacts, theta = np.empty((n, n_tail, 2)), np.empty((n, 4), dtype=bool), \
        np.empty((n, 4))
    speed, duty, rate, amp = np.empty(n), np.empty(n), np.empty(n), np.empty((n, 5))
    gaits = []
    for k in range(n):
        if k:
            f, fo, pi, sw = ctl._plan(script.command_at((k - 1) * dt), dt)
        else:
            f, fo, pi, sw = ctl._plan(first, 0.0)
        root[k, 0], root[k, 1], root[k, 2] = st.root_xz[0, 0], st.height[0], st.root_xz[0, 2]
        heading[k], pitch[k], sway[k] = st.heading[0], pi[0], sw[0]
        bend[k], spine[k], feet[k], fold[k] = st.bend[0], st.spine_smooth[0], f[0], fo[0]
        tail[k], contacts[k], theta[k] = st.tail[0], st.stance[0], st.theta[0]
        speed[k], duty[k], rate[k] = st.speed[0], st.params[0, 0], st.yaw_rate[0]
        amp[k, :4], amp[k, 4] = st.r[0], st.r_s[0]
        gaits.append(ctl.scheduler.label)
    plan = {"root": root, "heading": heading, "pitch": pitch, "sway": sway, "bend_yaw": bend,
            "bend_pitch": spine, "feet": feet, "fold": fold, "toe": 0.5 * fold, "tail": tail,
            "look": 0.5 * bend, "contacts": contacts, "phase": np.mod(theta / TWO_PI, 1.0),
            "speed": speed, "duty": duty, "spine": spine, "heading_rate": rate,
            "amplitude": amp, "gait": np.array(gaits, dtype=object)}
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
