"""Many characters stepped together as one vectorised computation.

:class:`BatchController` steps ``N`` characters -- any mix of the shipped
characters, each with its own speed, heading or turn rate and gait -- with
arrays that carry a leading character axis ``N`` through every stage of the
procedural controller: speed and turning, gait choice with hysteresis and
transitions, the CPG, foot lift-off and touchdown, swing paths, the spine,
body height and sway, the tail, leg IK and forward kinematics. The
per-character logic is compiled, never a Python loop over characters: the
whole plan is one numba kernel looping over the rows
(:func:`~quadsim.locomotion.plan_kernels.plan_rows`, the one a lone
controller steps with as one row), the posing the kernels of
:mod:`quadsim.locomotion.pose_kernel`. The only Python loop is over the
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
from quadsim.frames import Y
from quadsim.commands import Command
from quadsim.locomotion.controller import (
    GAIT_IDS,
    ControllerSettings,
    ProceduralController,
    QuadsimClampWarning,
    initial_oscillators,
)
from quadsim.locomotion.gaits import GAIT_NAMES, resolve_gait_name
from quadsim.locomotion import plan_kernels as _pk
from quadsim.locomotion.plan_kernels import run_plan, step_scalars
from quadsim.locomotion.pose_kernel import PARALLEL_ROWS, pack_plan, plan_columns
from quadsim.skeleton.character import Character

_STAND = len(GAIT_NAMES)
_G = len(GAIT_IDS)


def _rows(values, n: int, dtype) -> np.ndarray:
    """``values`` (a scalar or N of them) as a new writable (N,) array."""
    out = np.empty(n, dtype=dtype)
    out[...] = np.asarray(values, dtype=dtype)
    return out


class _Rows:
    """A bag of arrays (the compiled plan's constants), as attributes."""

    def __init__(self, **arrays):
        self.__dict__.update(arrays)


class _Kind:
    """Per-character constants, taken from a lone controller's set-up."""

    def __init__(self, character: Character, dt: float, settings: ControllerSettings):
        ctl = ProceduralController(character, dt=dt, settings=settings)
        self.character = character
        self.template = ctl
        self.poser = ctl.poser
        self.n_tail = len(character.tail)
        # the compiled plan's constants (ProceduralController._tables)
        self.table, self.law, self.has = ctl.gait_table, ctl.gait_law, ctl.gait_has
        self.auto = list(ctl.auto_ids)
        self.bounds = np.asarray(ctl.scheduler.bounds, dtype=float)
        self.consts = ctl.plan_consts
        self.max_speed = ctl.max_speed
        self.pelvis_height = ctl.pelvis_height


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
        t0 = kd[0].template
        half_sweep = np.stack([x.template.half_sweep for x in kd])[k]  # (N, D, 4)
        A = max(len(x.auto) for x in kd)
        auto = np.full((len(kd), A), -1, dtype=np.int64)
        bounds = np.full((len(kd), A), np.inf)
        pos = np.full((len(kd), _G), -1, dtype=np.int64)
        for i, x in enumerate(kd):
            auto[i, :len(x.auto)] = x.auto
            bounds[i, :len(x.bounds)] = x.bounds
            pos[i, x.auto] = np.arange(len(x.auto))
        self._max_speed = np.array([x.max_speed for x in kd])[k]
        self._pelvis_height = np.array([x.pelvis_height for x in kd])[k]
        self._law = np.stack([x.law for x in kd])
        self._has = np.stack([x.has for x in kd])
        self._n_tail_max = max(x.n_tail for x in kd)
        self._k = _Rows(
            kind=np.ascontiguousarray(k, dtype=np.int64),
            consts=np.ascontiguousarray(np.stack([x.consts for x in kd])[k].T),
            table=np.ascontiguousarray(np.stack([x.table for x in kd])),
            law=np.ascontiguousarray(self._law), auto=np.ascontiguousarray(auto[k]),
            bounds=np.ascontiguousarray(bounds[k]), auto_pos=pos,
            drops=np.ascontiguousarray(t0.drops, dtype=float),
            half_sweep=np.ascontiguousarray(half_sweep, dtype=float),
            sweep_min=np.ascontiguousarray(half_sweep.min(axis=2)),
            sweep_cols=np.ascontiguousarray(np.swapaxes(half_sweep, 1, 2)),
            foot_offset=np.ascontiguousarray(
                np.stack([x.template.foot_offset for x in kd])[k], dtype=float))
        # read-only, as a lone controller's sweeps are: the same argument types, so
        # the batch runs the plan kernel a lone controller has compiled
        self._k.half_sweep.setflags(write=False)
        self._sc: dict[float, np.ndarray] = {}

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
        self.source = np.zeros((n, _pk.NP_))
        self.in_transition = np.zeros(n, dtype=bool)
        self.elapsed = np.zeros(n)
        self.duration = np.zeros(n)
        self.params = np.stack([self.kinds[self.kind[i]].template._target_row(start[i], 0.0)
                                for i in range(n)])

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

    @property
    def labels(self) -> list[str]:
        """Gait label of each row, as :attr:`GaitScheduler.label`."""
        return [f"{GAIT_IDS[s]}->{GAIT_IDS[c]}" if t else GAIT_IDS[c]
                for s, c, t in zip(self.source_name, self.current, self.in_transition)]

    def _warn(self, key: str, hit: bool, mask, msg: str) -> None:
        if hit and key not in self._warned:
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
        # the commands as fresh writable (N,) arrays, the kernel's one signature
        speed = _rows(speed, n, float)
        if not (speed.min() >= 0.0 and speed.max() < math.inf):  # NaN fails both
            raise ValueError("`speed` must be finite and >= 0 m/s for every character")
        if turn_rate is None:
            turn = np.zeros(n)
        else:
            turn = _rows(turn_rate, n, float)
            if not np.all(np.isfinite(turn)):
                raise ValueError("`turn_rate` must be finite")
        if heading is None:
            head = np.full(n, np.nan)
        else:  # the turn rate is not used where a heading is steered to
            head = _rows(heading, n, float)
            turn[np.isfinite(head)] = 0.0
        if gait is None:
            gait = np.full(n, -1, dtype=np.int64)
        else:
            gait = _rows(gait, n, np.int64)
            asked = gait >= 0
            if np.any(asked & ~self._has[self.kind, np.where(asked, gait, 0)]):
                raise InputError("a requested gait id is not among its character's gaits")
        # with pose, the plan kernel also packs the plans for the posing kernel
        packed = np.empty((n, plan_columns(self._n_tail_max))) if pose else None
        frame = self._advance(speed, turn, head, gait, self.dt if dt is None else float(dt),
                              packed)
        if pose:
            frame.update(self._pose_packed(packed))
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
        return self._pose_packed(pack_plan(plan, self._n_tail_max))

    def _pose_packed(self, packed: np.ndarray) -> dict:
        """:meth:`pose` of the plans packed (:func:`pack_plan` with the longest
        tail: each kind reads its own)."""
        out = {"local_rotations": [], "positions": [], "ik_error": []}
        for kd, (_, rows) in zip(self.kinds, self.groups):
            local, P, err = kd.poser.pose_packed(packed if len(self.kinds) == 1
                                                 else packed[rows])
            out["local_rotations"].append(local)
            out["positions"].append(P)
            out["ik_error"].append(err)
        return out

    def _advance(self, v_cmd, turn, head, gait, dt, packed=None) -> dict:
        sc = self._sc.get(dt)
        if sc is None:
            sc = self._sc[dt] = step_scalars(self.settings, dt)
        # the whole plan, compiled: the kernel a lone controller steps with
        # (plan_kernels.plan_rows), here over N rows; the state is updated in place.
        # From PARALLEL_ROWS rows on, one block of rows per thread
        # (plan_rows_parallel): the same result whatever the number of threads.
        # It also gives the stride fractions and, if asked, the packed plans
        phase = np.empty((self.n, 4))
        feet, fold, pitch, sway, flags, aux = run_plan(
            self._k, self, v_cmd, turn, head, gait, sc, self.settings.cpg.substeps,
            parallel=self.n >= PARALLEL_ROWS, phase=phase, packed=packed)
        if len(self._warned) < 3:  # each warning is given once
            hit = flags.any(axis=0)
            self._warn("gait_speed", hit[0], flags[:, 0],
                       "speed above what the requested gait reaches")
            self._warn("speed", hit[1], flags[:, 1], "speed above the character's fastest gait")
            self._warn("turn", hit[2], flags[:, 2], "turn rate beyond the character's maximum")
        self.feet = feet
        self.time += dt
        root = np.stack([self.root_xz[:, 0], self.height, self.root_xz[:, 2]], axis=1)
        spine = self.spine_smooth.copy()
        bend = self.bend.copy()
        # the frame holds copies: the state arrays change in place at the next step
        return {
            "root": root, "heading": self.heading.copy(), "pitch": pitch, "sway": sway,
            "bend_yaw": bend, "bend_pitch": spine, "feet": feet,
            "fold": fold, "toe": 0.5 * fold, "tail": self.tail.copy(), "look": 0.5 * bend,
            "contacts": self.stance.copy(), "gait": self.current.copy(),
            "phase": phase, "speed": self.speed.copy(),
            "duty": self.params[:, _pk.P_DUTY].copy(), "spine": spine,
            "heading_rate": self.yaw_rate.copy(),
            "amplitude": np.concatenate([self.r, self.r_s[:, None]], axis=1),
        }


__all__ = ["GAIT_IDS", "BatchController"]
