"""Many characters stepped together as one vectorised computation.

:class:`BatchController` steps ``N`` characters -- any mix of the shipped
characters, each with its own speed, heading or turn rate and gait -- with
arrays that carry a leading character axis ``N`` through every stage of the
procedural controller: speed and turning, gait choice with hysteresis and
transitions, the CPG, foot lift-off and touchdown, swing paths, the spine,
body height and sway, the tail, leg IK and forward kinematics. The
per-character logic runs two ways, never as a Python loop over characters:
speed, turning and the gait scheduler (hysteresis, transitions, the standing
start) as numpy with boolean masks; the CPG step
(:func:`~quadsim.locomotion.cpg.cpg_step_rows`), the feet (lift-off,
touchdown, targets on the turning arc, swing paths: :func:`~quadsim.locomotion.plan_kernels.feet_rows`), the
body (spine, drops, height, pitch, sway, tail: :func:`~quadsim.locomotion.plan_kernels.body_rows`) and the
posing (:mod:`quadsim.locomotion.pose_kernel`) as compiled numba kernels
that loop over the rows. The CPG, feet and posing kernels are the very ones
a lone controller steps with (one row). The only Python loop is over the
kinds of character present (each kind has its own skeleton, posed as one
group).

Units are SI (m, s, rad); arrays carry the character axis N first, then the
leg axis (LF, RF, LH, RH) where there is one.

Each character follows exactly the path a lone
:class:`~quadsim.locomotion.controller.ProceduralController` with the same
seed, starting gait and commands would (tests assert agreement to 1e-9).

Gaits are numbered in the order of :data:`quadsim.locomotion.gaits.GAIT_NAMES`,
with the standing state last (:data:`GAIT_IDS`); ``-1`` asks for the
automatic choice by speed.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import numpy as np

from quadsim.errors import InputError
from quadsim.frames import FORE, GRAVITY, Y
from quadsim.locomotion.commands import Command
from quadsim.locomotion.controller import (
    MIN_SWING,
    STAND,
    ControllerSettings,
    ProceduralController,
    QuadsimClampWarning,
    initial_oscillators,
)
from quadsim.locomotion.cpg import TWO_PI, cpg_step_rows
from quadsim.locomotion.gaits import GAIT_NAMES, resolve_gait_name
from quadsim.locomotion.plan_kernels import body_rows, feet_rows
from quadsim.locomotion.pose_kernel import pack_plan
from quadsim.locomotion.turning import turn_rate_towards
from quadsim.skeleton.character import Character

#: Gait identifiers by number: the eight gaits, then the standing state.
GAIT_IDS: tuple[str, ...] = GAIT_NAMES + (STAND,)
_STAND = len(GAIT_NAMES)
_G = len(GAIT_IDS)
_GIRDLE = np.where(FORE, 1, 0)

# columns of a parameter row (the blendable GaitParams of every character)
_DUTY, _PH, _COEF, _MINV, _SWING, _DROP, _BOUND, _SPAMP = 0, slice(1, 5), 5, 6, 7, 8, 9, 10
_NP = 11
_LERP = np.array([0, 5, 6, 7, 8, 9, 10])  # the columns blended linearly

class _Kind:
    """Per-character constants, taken from a lone controller's set-up."""

    def __init__(self, character: Character, dt: float, settings: ControllerSettings):
        ctl = ProceduralController(character, dt=dt, settings=settings)
        self.character = character
        self.template = ctl
        self.poser = ctl.poser
        self.n_tail = len(character.tail)
        # gait table: one row of parameters per gait id, plus the duty law
        table = np.full((_G, _NP), np.nan)
        law = np.full((_G, 4), np.nan)  # speed lo, hi, duty lo, hi
        has = np.zeros(_G, dtype=bool)
        for g, name in enumerate(GAIT_IDS):
            gait = ctl.gaits.get(name)
            if gait is None:
                continue
            has[g] = True
            table[g, _PH] = gait.phases
            table[g, _COEF] = gait.stride_coefficient
            table[g, _MINV] = gait.speed_range[0]
            table[g, _SWING] = gait.swing_height
            table[g, _DROP] = gait.drop
            table[g, _BOUND] = 1.0 if gait.spine == "bound" else 0.0
            table[g, _SPAMP] = gait.spine_amplitude
            law[g] = (*gait.speed_range, *gait.duty_range)
        self.table, self.law, self.has = table, law, has
        self.auto = [GAIT_IDS.index(n) for n in ctl.auto]
        self.bounds = np.asarray(ctl.scheduler.bounds, dtype=float)
        self.hysteresis = ctl.scheduler.hysteresis
        self.scalars = {
            "h": ctl.h, "pelvis_height": ctl.pelvis_height, "hind_z": ctl.hind_z,
            "body_length": ctl.body_length, "stand_speed": ctl.stand_speed,
            "max_speed": ctl.max_speed, "max_turn_rate": ctl.max_turn_rate,
            "flexed": ctl.flexed, "extended": ctl.extended,
            "r_min": ctl.min_turn_radius * ctl.body_length, "slow_scale": ctl.slow_scale,
            "walk_top": ctl.gaits[ctl.auto[0]].speed_range[1],
            "n_tail": max(self.n_tail, 1),
        }


def _interp_shared(x, xp, fp):
    """``np.interp(x, xp, fp)`` for many ``x`` (N,) with one ``xp`` (D,) and a
    table ``fp`` of shape (N, D, ...) per row; returns shape (N, ...)."""
    D = len(xp)
    j = np.clip(np.searchsorted(xp, x, side="right") - 1, 0, D - 2)
    rows = np.arange(len(x))
    f0, f1 = fp[rows, j], fp[rows, j + 1]
    x0, x1 = xp[j], xp[j + 1]
    shape = (-1,) + (1,) * (f0.ndim - 1)
    slope = (f1 - f0) / (x1 - x0).reshape(shape)
    out = slope * (x - x0).reshape(shape) + f0
    out = np.where((x <= xp[0]).reshape(shape), fp[rows, 0], out)
    return np.where((x >= xp[-1]).reshape(shape), fp[rows, -1], out)


def _interp_rows(x, xp, fp):
    """``np.interp`` with a different non-decreasing ``xp`` per element.

    ``x`` has shape (...), ``xp`` shape (..., D), ``fp`` shape (D,).
    """
    D = xp.shape[-1]
    j = (xp <= x[..., None]).sum(axis=-1) - 1
    jc = np.clip(j, 0, D - 2)
    x0 = np.take_along_axis(xp, jc[..., None], -1)[..., 0]
    x1 = np.take_along_axis(xp, jc[..., None] + 1, -1)[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        out = (fp[jc + 1] - fp[jc]) / (x1 - x0) * (x - x0) + fp[jc]
    out = np.where(j < 0, fp[0], out)
    return np.where(j >= D - 1, fp[-1], out)


class BatchController:
    """Procedural locomotion for many characters at once.

    Parameters
    ----------
    characters : sequence of Character, length N
        The characters, in row order; the same object may (and, for speed,
        should) appear many times: rows sharing a :class:`Character` are
        posed together.
    dt : float
        Fixed step (s).
    seeds : int or sequence of int, optional
        Seed of each row's oscillator start offsets (default ``0`` for all,
        as :class:`ProceduralController`'s default).
    gaits : sequence of str or None, optional
        Starting gait of each row (default: standing).
    settings : ControllerSettings, optional
        Shared by every row.

    Attributes
    ----------
    n : int
        Number of characters N.
    groups : tuple of (Character, ndarray of int)
        Each kind of character and the rows that hold it.
    speed, heading, yaw_rate : ndarray, shape (N,)
        Forward speed (m/s), heading about +Y (rad), turn rate (rad/s).
    root_xz : ndarray, shape (N, 3)
        Pelvis position on the ground, ``(x, 0, z)`` (m).
    stance : ndarray of bool, shape (N, 4)
        Whether each foot is planted, legs LF, RF, LH, RH.
    current : ndarray of int, shape (N,)
        Gait id (:data:`GAIT_IDS`) being run or transitioned to.
    """

    def __init__(self, characters: Sequence[Character], dt: float = 1.0 / 60.0,
                 seeds: int | Sequence[int] = 0, gaits: Sequence[str | None] | None = None,
                 settings: ControllerSettings | None = None):
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
        chars = list(characters)
        if not chars:
            raise ValueError("`characters` is empty; give at least one Character")
        n = len(chars)
        self.n = n
        self.dt = float(dt)
        self.settings = settings or ControllerSettings()
        kinds: dict[int, int] = {}
        self.kinds: list[_Kind] = []
        kind_of = np.empty(n, dtype=np.int64)
        for i, ch in enumerate(chars):
            k = kinds.get(id(ch))
            if k is None:
                k = kinds[id(ch)] = len(self.kinds)
                self.kinds.append(_Kind(ch, self.dt, self.settings))
            kind_of[i] = k
        self.kind = kind_of
        self.groups = tuple((kd.character, np.flatnonzero(kind_of == k))
                            for k, kd in enumerate(self.kinds))
        self._constants()
        seeds = np.broadcast_to(np.asarray(seeds, dtype=np.int64), (n,))
        gaits = [None] * n if gaits is None else list(gaits)
        if len(gaits) != n:
            raise ValueError(f"`gaits` has {len(gaits)} entries, expected {n} (one a character)")
        self._init_state(chars, seeds, gaits)
        self._warned: set[str] = set()

    # ------------------------------------------------------------ set-up
    def _constants(self) -> None:
        kd, k = self.kinds, self.kind
        for name in kd[0].scalars:
            setattr(self, "_" + name, np.array([x.scalars[name] for x in kd])[k])
        t0 = kd[0].template
        self._drops = t0.drops
        self._half_sweep = np.stack([x.template.half_sweep for x in kd])[k]  # (N, D, 4)
        self._sweep_cols = np.swapaxes(self._half_sweep, 1, 2).copy()  # (N, 4, D)
        self._sweep_min = self._half_sweep.min(axis=2)  # (N, D)
        self._foot_offset = np.stack([x.template.foot_offset for x in kd])[k]  # (N, 4, 3)
        self._table = np.stack([x.table for x in kd])  # (K, G, P)
        self._law = np.stack([x.law for x in kd])
        self._has = np.stack([x.has for x in kd])
        A = max(len(x.auto) for x in kd)
        auto = np.full((len(kd), A), -1, dtype=np.int64)
        bounds = np.full((len(kd), A), np.inf)
        pos = np.full((len(kd), _G), -1, dtype=np.int64)
        for i, x in enumerate(kd):
            auto[i, :len(x.auto)] = x.auto
            bounds[i, :len(x.bounds)] = x.bounds
            pos[i, x.auto] = np.arange(len(x.auto))
        self._auto, self._bounds, self._auto_pos = auto[k], bounds[k], pos
        self._hyst = np.array([x.hysteresis for x in kd])[k]
        self._n_tail_max = max(x.n_tail for x in kd)
        self._rows = np.arange(self.n)

    def _init_state(self, chars, seeds, gaits) -> None:
        n = self.n
        start = np.full(n, _STAND, dtype=np.int64)
        for i, g in enumerate(gaits):
            if g:
                start[i] = GAIT_IDS.index(resolve_gait_name(g, chars[i]))
        self.theta = np.empty((n, 4))
        self.r = np.empty((n, 4))
        self.theta_s = np.empty(n)
        for i in range(n):  # set-up only: the seeded generators are sequential
            gait = self.kinds[self.kind[i]].template.gaits[GAIT_IDS[start[i]]]
            self.theta[i], self.r[i], self.theta_s[i] = initial_oscillators(gait, int(seeds[i]))
        self.r_s = np.ones(n)
        self.time = 0.0
        self.speed = np.zeros(n)
        self.yaw_rate = np.zeros(n)
        self.heading = np.zeros(n)
        self.root_xz = np.zeros((n, 3))
        self.bend = np.zeros(n)
        self.spine_angle = np.zeros(n)
        self.spine_smooth = np.zeros(n)
        self.height = self._pelvis_height.copy()
        self.drops_now = np.zeros((n, 2))
        self.tail = np.zeros((n, self._n_tail_max, 2))
        self.stance = np.ones((n, 4), dtype=bool)
        feet = np.stack([k.character.rest_foot_positions() for k in self.kinds])[self.kind]
        feet[..., Y] = 0.0
        self.planted = feet
        self.liftoff = feet.copy()
        self.theta_lo = self.theta.copy()
        self.theta_td = self.theta.copy()
        self.swing_s = np.zeros((n, 4))
        self.feet = feet.copy()
        self.freq = np.ones(n)
        # gait scheduler
        self.current = start
        self.source_name = start.copy()
        self.source = np.zeros((n, _NP))
        self.in_transition = np.zeros(n, dtype=bool)
        self.elapsed = np.zeros(n)
        self.duration = np.zeros(n)
        self.params = self._target(self.current, np.zeros(n))

    @property
    def max_speed(self) -> np.ndarray:
        """Top speed of each row's character (m/s), shape (N,)."""
        return self._max_speed

    # ------------------------------------------------------------ commands
    def gait_ids(self, names: Sequence[str | None]) -> np.ndarray:
        """Gait ids (N,) for gait names (``None``: automatic, -1); checks each
        name against its row's character (``InputError`` if unknown)."""
        out = np.full(self.n, -1, dtype=np.int64)
        if len(names) != self.n:
            raise ValueError(f"`names` has {len(names)} entries, expected {self.n}")
        for i, g in enumerate(names):
            if g:
                ch = self.kinds[self.kind[i]].character
                out[i] = GAIT_IDS.index(resolve_gait_name(g, ch))
        return out

    def step_commands(self, commands: Sequence[Command], dt: float | None = None, *,
                      pose: bool = True) -> dict:
        """:meth:`step` under one :class:`Command` per row (convenience; the
        conversion loops over the rows, the step does not)."""
        if len(commands) != self.n:
            raise ValueError(f"{len(commands)} commands for {self.n} characters")
        speed = np.array([c.speed for c in commands], dtype=float)
        turn = np.array([c.turn_rate or 0.0 for c in commands], dtype=float)
        head = np.array([np.nan if c.heading is None else c.heading for c in commands])
        gaits = self.gait_ids([c.gait for c in commands])
        return self.step(speed, turn, head, gaits, dt, pose=pose)

    # ------------------------------------------------------------ gait tables
    def _target(self, gait, speed):
        """Parameters (N, P) of gait ids ``gait`` (N,) at ``speed`` (N,):
        the vectorised :meth:`GaitScheduler.target`."""
        out = self._table[self.kind, gait]
        lo, hi, d0, d1 = np.moveaxis(self._law[self.kind, gait], -1, 0)
        s = np.clip((speed - lo) / (hi - lo), 0.0, 1.0)
        out[:, _DUTY] = d0 + s * (d1 - d0)
        return out

    def _blend(self, a, b, s):
        """``a`` moved a fraction ``s`` (N,) of the way to ``b`` (GaitParams.blend)."""
        out = np.empty_like(a)
        sc = s[:, None]
        out[:, _LERP] = a[:, _LERP] + sc * (b[:, _LERP] - a[:, _LERP])
        dpsi = np.mod(b[:, _PH] - a[:, _PH] + 0.5, 1.0) - 0.5
        out[:, _PH] = np.mod(a[:, _PH] + sc * dpsi, 1.0)
        return out

    def _scheduled(self, speed):
        """Blended parameters now (GaitScheduler.params)."""
        target = self._target(self.current, speed)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.minimum(self.elapsed / self.duration, 1.0) ** 2
        return np.where(self.in_transition[:, None],
                        self._blend(self.source, target, np.where(self.in_transition, s, 0.0)),
                        target)

    def _auto_choice(self, speed):
        """Automatic gait id per row, keeping the current one in its band."""
        k = self._auto_pos[self.kind, self.current]
        kc = np.maximum(k, 0)
        bounds, hyst = self._bounds, self._hyst
        lo = np.where(k > 0, bounds[self._rows, np.maximum(kc - 1, 0)] * (1 - hyst), -np.inf)
        hi = bounds[self._rows, kc] * (1 + hyst)
        keep = (k >= 0) & (lo <= speed) & (speed <= hi)
        idx = (bounds <= speed[:, None]).sum(axis=1)
        return np.where(keep, self.current, self._auto[self._rows, idx])

    def _update_gait(self, wanted, speed, dt, stride_period, quick):
        """GaitScheduler.update for every row."""
        self.elapsed = np.where(self.in_transition, self.elapsed + dt, self.elapsed)
        self.in_transition = self.in_transition & ~(self.elapsed >= self.duration)
        change = wanted != self.current
        if change.any():
            start = self._scheduled(speed)
            self.source = np.where(change[:, None], start, self.source)
            self.source_name = np.where(change, self.current, self.source_name)
            self.current = np.where(change, wanted, self.current)
            self.in_transition = self.in_transition | change
            self.elapsed = np.where(change, 0.0, self.elapsed)
            dur = np.where(quick, 0.6, np.clip(1.5 * stride_period, 0.5, 2.0))
            self.duration = np.where(change, dur, self.duration)
        return self._scheduled(speed)

    @property
    def labels(self) -> list[str]:
        """Gait label of each row, as :attr:`GaitScheduler.label`."""
        return [f"{GAIT_IDS[s]}->{GAIT_IDS[c]}" if t else GAIT_IDS[c]
                for s, c, t in zip(self.source_name, self.current, self.in_transition)]

    # ------------------------------------------------------------ geometry
    def _key_points(self):
        """Hind and fore key points (N, 2, 3) and their headings (N, 2)."""
        h, bend = self.heading, self.bend
        fh = h + 0.5 * bend
        keys = np.empty((self.n, 2, 3))
        keys[:, 0, 0] = self.root_xz[:, 0] + np.sin(h) * self._hind_z
        keys[:, 0, 1] = self.root_xz[:, 1] + 0.0
        keys[:, 0, 2] = self.root_xz[:, 2] + np.cos(h) * self._hind_z
        keys[:, 1, 0] = keys[:, 0, 0] + np.sin(fh) * self._body_length
        keys[:, 1, 1] = keys[:, 0, 1] + 0.0
        keys[:, 1, 2] = keys[:, 0, 2] + np.cos(fh) * self._body_length
        return keys, np.stack([h, h + bend], axis=1)

    def _girdle_frame(self, keys, key_heading):
        """Each foot's mid-stance point and its girdle's forward vector, (N, 4, 3)."""
        kh = key_heading[:, _GIRDLE]
        c, sn = np.cos(kh), np.sin(kh)
        off = self._foot_offset
        mid = np.empty((self.n, 4, 3))
        mid[..., 0] = c * off[..., 0] + sn * off[..., 2]
        mid[..., 1] = off[..., 1]
        mid[..., 2] = -sn * off[..., 0] + c * off[..., 2]
        mid += keys[:, _GIRDLE]
        fwd = np.zeros((self.n, 4, 3))
        fwd[..., 0] = sn
        fwd[..., 2] = c
        return mid, fwd

    def _trailing_room(self, params):
        """How far (m) each foot may still fall behind its girdle, (N, 4)."""
        keys, kh = self._key_points()
        mid, fwd = self._girdle_frame(keys, kh)
        along = np.einsum("nij,nij->ni", self.planted - mid, fwd)
        drop = np.maximum(params[:, _DROP] + self.settings.vault, self.drops_now.max(axis=1))
        return _interp_shared(drop, self._drops, self._sweep_min)[:, None] + along

    def _reach_governor(self, dt):
        p = self.params
        duty = p[:, _DUTY, None]
        u = np.mod(self.theta / TWO_PI, 1.0)
        lifts = (u < duty) & (1.0 - MIN_SWING >= duty)
        t_lo = np.where(lifts, duty - u, 1.0 - u + np.minimum(duty, 1.0 - MIN_SWING)) \
            / self.freq[:, None]
        room = self._trailing_room(p)
        with np.errstate(divide="ignore", invalid="ignore"):
            caps = np.maximum(room, 0.0) / np.maximum(t_lo, dt)
        return np.min(np.where(self.stance, caps, np.inf), axis=1)

    def _stride_length(self, p, speed):
        vc = np.maximum(np.maximum(speed, p[:, _MINV]), 1e-3)
        h = self._h
        lam = h * p[:, _COEF] * (vc * vc / (GRAVITY * h)) ** 0.3
        return np.where(speed < vc, lam * speed / vc, lam)

    def _warn(self, key: str, mask, msg: str) -> None:
        if key not in self._warned and np.any(mask):
            self._warned.add(key)
            warnings.warn(f"{msg} for {int(np.count_nonzero(mask))} of {self.n} characters; "
                          "clamped", QuadsimClampWarning, stacklevel=3)

    # ------------------------------------------------------------ stepping
    def step(self, speed, turn_rate=None, heading=None, gait=None, dt: float | None = None,
             *, pose: bool = True) -> dict:
        """Advance every character by ``dt`` seconds.

        Parameters
        ----------
        speed : array-like, shape (N,)
            Commanded forward speed (m/s), >= 0.
        turn_rate : array-like, shape (N,), optional
            Commanded turn rate (rad/s), positive left (default 0).
        heading : array-like, shape (N,), optional
            Heading to steer towards (rad); NaN where the turn rate is used.
        gait : array-like of int, shape (N,), optional
            Requested gait ids (:data:`GAIT_IDS`, see :meth:`gait_ids`); -1
            chooses by speed (default).
        dt : float, optional
            Step (s), default the controller's.
        pose : bool
            Also pose the skeletons (IK and forward kinematics).

        Returns
        -------
        frame : dict
            The plan of every row with a leading axis N: ``root`` (N, 3) (m),
            ``heading``, ``pitch``, ``bend_yaw``, ``bend_pitch``, ``look``,
            ``spine``, ``heading_rate`` (N,) (rad, rad/s), ``speed`` (N,) (m/s),
            ``duty`` (N,), ``sway`` (N, 2), ``feet`` (N, 4, 3) (m), ``fold``,
            ``toe`` and ``phase`` (N, 4), ``contacts`` (N, 4) bool, ``tail``
            (N, T_max, 2) (rad, zero-padded), ``amplitude`` (N, 5) and ``gait``
            (N,) gait ids. With ``pose=True`` also ``local_rotations``,
            ``positions`` and ``ik_error``: lists with one array per entry of
            :attr:`groups`, of shapes (n_g, J_g, 3, 3), (n_g, J_g, 3) (m) and
            (n_g, 4) (m).
        """
        n = self.n
        speed = np.broadcast_to(np.asarray(speed, dtype=float), (n,))
        if not np.all(np.isfinite(speed)) or np.any(speed < 0):
            raise ValueError("`speed` must be finite and >= 0 m/s for every character")
        turn = np.zeros(n) if turn_rate is None else np.broadcast_to(
            np.asarray(turn_rate, dtype=float), (n,))
        if not np.all(np.isfinite(turn)):
            raise ValueError("`turn_rate` must be finite")
        head = np.full(n, np.nan) if heading is None else np.broadcast_to(
            np.asarray(heading, dtype=float), (n,))
        gait = np.full(n, -1, dtype=np.int64) if gait is None else np.broadcast_to(
            np.asarray(gait, dtype=np.int64), (n,))
        asked = gait >= 0
        if np.any(asked & ~self._has[self.kind, np.where(asked, gait, 0)]):
            raise InputError("a requested gait id is not among its character's gaits")
        frame = self._advance(speed, turn, head, gait, asked,
                              self.dt if dt is None else float(dt))
        if pose:
            frame.update(self.pose(frame))
        return frame

    def pose(self, plan: dict) -> dict:
        """Pose a batch plan with the compiled posing kernel
        (:meth:`Poser.pose_packed <quadsim.locomotion.posing.Poser.pose_packed>`),
        once per kind of character.

        Returns
        -------
        dict
            ``local_rotations`` (n_g, J_g, 3, 3), ``positions`` (n_g, J_g, 3)
            (m) and ``ik_error`` (n_g, 4) (m): lists with one array per
            entry of :attr:`groups`.
        """
        out = {"local_rotations": [], "positions": [], "ik_error": []}
        packed = pack_plan(plan, self._n_tail_max)  # each kind reads its own tail
        for kd, (_, rows) in zip(self.kinds, self.groups):
            local, P, err = kd.poser.pose_packed(packed if len(self.kinds) == 1
                                                 else packed[rows])
            out["local_rotations"].append(local)
            out["positions"].append(P)
            out["ik_error"].append(err)
        return out

    def _advance(self, v_cmd, turn, head, gait, asked, dt) -> dict:
        s = self.settings
        # 1. speed and turning -------------------------------------------
        halt = v_cmd <= 1e-9
        cap = 1.15 * self._law[self.kind, np.where(asked, gait, 0), 1]
        over = asked & (v_cmd > cap)
        self._warn("gait_speed", over, "speed above what the requested gait reaches")
        v_cmd = np.where(over, cap, v_cmd)
        over = v_cmd > self._max_speed
        self._warn("speed", over, "speed above the character's fastest gait")
        v_cmd = np.where(over, self._max_speed, v_cmd)
        cur = self.current
        standing = (cur == _STAND) | (self.in_transition & (self.source_name == _STAND))
        with np.errstate(divide="ignore", invalid="ignore"):
            progress = np.where(self.in_transition,
                                np.minimum(self.elapsed / self.duration, 1.0), 0.0)
        v_cmd = np.where(standing, np.minimum(
            v_cmd, np.maximum(progress, 0.0) ** 2 * self._walk_top), v_cmd)
        v_cmd = np.minimum(v_cmd, self._reach_governor(dt))
        dv = np.minimum(np.maximum(v_cmd - self.speed, -s.acceleration * dt), s.acceleration * dt)
        v_before = self.speed
        v = self.speed = np.maximum(self.speed + dv, 0.0)
        fast = np.maximum(v, v_cmd)
        max_rate = np.minimum(self._max_turn_rate, np.maximum(fast, 0.1 * self._h) / self._r_min)
        steer = np.isfinite(head)
        over = ~steer & (np.abs(turn) > max_rate)
        self._warn("turn", over, "turn rate beyond the character's maximum")
        rate = np.where(steer, turn_rate_towards(self.heading, np.where(steer, head, 0.0),
                                                 max_rate),
                        np.where(over, np.copysign(max_rate, turn), turn))
        self.yaw_rate = self.yaw_rate + (rate - self.yaw_rate) * (
            1.0 - math.exp(-dt / s.turn_response))

        # 2. gait -----------------------------------------------------------
        auto = self._auto_choice(v)
        wanted_cap = 1.15 * self._law[self.kind, np.where(asked, gait, 0), 1]
        wanted = np.where(asked, np.where(v > wanted_cap, auto, gait),
                          np.where(halt & (v <= self._stand_speed), _STAND, auto))
        quick = self.current == _STAND
        p = self._update_gait(wanted, v, dt, 1.0 / np.maximum(self.freq, 1e-3), quick)
        self.params = p
        duty = p[:, _DUTY]
        # stride limit (ProceduralController.stride_limit), every leg's sweep
        half = _interp_shared(p[:, _DROP] + s.vault, self._drops, self._half_sweep).min(axis=1)
        margin = s.reach_margin - 0.05 * p[:, _BOUND]
        limit = 2.0 * margin * half / np.maximum(duty, 1e-3)
        lam = np.minimum(self._stride_length(p, v), limit)
        lam_min = np.minimum(self._stride_length(p, p[:, _MINV]), limit)
        with np.errstate(divide="ignore", invalid="ignore"):
            self.freq = np.where(v > 1e-6, np.maximum(v / lam, p[:, _MINV] / lam_min),
                                 p[:, _MINV] / lam_min)
        omega = TWO_PI * self.freq

        # 3. CPG ------------------------------------------------------------
        theta_prev = self.theta
        c = s.cpg  # the compiled network step, as a lone controller's
        theta, self.r, self.theta_s, self.r_s = cpg_step_rows(
            self.theta, self.r, self.theta_s, self.r_s, omega,
            np.ascontiguousarray(p[:, _PH]), float(dt), c.mu, c.gain, c.coupling,
            c.spine_coupling, c.substeps)
        theta = self.theta = np.maximum(theta, theta_prev)

        # 4. body on its path -------------------------------------------------
        self.heading = self.heading + self.yaw_rate * dt
        k = 0.5 * (v_before + v) * dt
        mid_heading = self.heading - 0.5 * self.yaw_rate * dt
        self.root_xz = self.root_xz + np.stack(
            [k * np.sin(mid_heading), k * 0.0, k * np.cos(mid_heading)], axis=1)
        bend_target = np.minimum(np.maximum(
            self.yaw_rate * self._body_length / np.maximum(v, 0.3 * self._h), -s.max_bend),
            s.max_bend)
        self.bend = self.bend + (bend_target - self.bend) * (1.0 - math.exp(-dt / 0.2))
        keys, key_heading = self._key_points()

        # 5. feet (compiled, row by row) ------------------------------------------
        final = self._target(self.current, v)[:, _DUTY]
        trailing = self._trailing_room(p) < (v * dt)[:, None]
        half_min = _interp_shared(p[:, _DROP] + s.vault, self._drops, self._sweep_min)
        feet = np.empty((self.n, 4, 3))
        fold = np.empty((self.n, 4))
        feet_rows(theta, theta_prev, np.ascontiguousarray(duty), np.ascontiguousarray(final),
                  self.freq, v,
                   self.yaw_rate, keys, key_heading, self._foot_offset, trailing,
                   np.ascontiguousarray(p[:, _SWING]), half_min, s.reach_margin, self.stance,
                   self.swing_s, self.theta_lo, self.theta_td, self.planted, self.liftoff,
                   feet, fold)
        self.feet = feet
        stance = self.stance
        u = np.mod(theta / TWO_PI, 1.0)

        # 6. spine, height, tail (compiled, row by row; new state arrays, since
        # the frames returned share them) ----------------------------------------
        self.spine_angle = self.spine_angle.copy()
        self.spine_smooth = self.spine_smooth.copy()
        self.drops_now = self.drops_now.copy()
        self.height = self.height.copy()
        self.tail = self.tail.copy()
        pitch = np.empty(self.n)
        sway = np.empty((self.n, 2))
        body_rows(stance, u, np.ascontiguousarray(duty), self.freq, v, self.bend,
                   self.theta_s, keys, key_heading, self._foot_offset, feet, self._sweep_cols,
                   self._drops, self._flexed, self._extended, self._slow_scale,
                   np.ascontiguousarray(p[:, _SPAMP]), np.ascontiguousarray(p[:, _BOUND]),
                   np.ascontiguousarray(p[:, _DROP]), self._h, self._pelvis_height,
                   self._body_length, self._n_tail, s.reach_margin, s.max_sway, float(dt),
                   1.0 - math.exp(-dt / 0.03), 1.0 - math.exp(-dt / 0.04),
                   1.0 - math.exp(-dt / s.tail_lag), self.spine_angle, self.spine_smooth,
                   self.drops_now, self.height, self.tail, pitch, sway)

        self.time += dt
        root = np.stack([self.root_xz[:, 0], self.height, self.root_xz[:, 2]], axis=1)
        return {
            "root": root, "heading": self.heading, "pitch": pitch, "sway": sway,
            "bend_yaw": self.bend, "bend_pitch": self.spine_smooth, "feet": feet,
            "fold": fold, "toe": 0.5 * fold, "tail": self.tail, "look": 0.5 * self.bend,
            "contacts": stance.copy(), "gait": self.current.copy(),
            "phase": np.mod(theta / TWO_PI, 1.0), "speed": v, "duty": duty,
            "spine": self.spine_smooth, "heading_rate": self.yaw_rate,
            "amplitude": np.concatenate([self.r, self.r_s[:, None]], axis=1),
        }


__all__ = ["GAIT_IDS", "BatchController"]
