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

Gaits are numbered by :func:`quadsim.locomotion.gaits.gait_ids` (the gait
table's order, the standing state last); ``-1`` asks for the automatic
choice by speed.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import numpy as np

from quadsim.commands import Command
from quadsim.errors import InputError, QuadsimClampWarning
from quadsim.locomotion.blocks import FixedEntry
from quadsim.locomotion.bundles import (
    BodyConstants,
    CommandRows,
    ReachTables,
    plan_outputs,
    step_scratch,
)
from quadsim.locomotion.controller import ControllerSettings
from quadsim.locomotion.gaits import STAND, gait_ids, resolve_gait_name
from quadsim.locomotion.plan_kernels import (
    LOOK_PER_BEND,
    plan_rows,
    run_plan,
    step_constants,
)
from quadsim.locomotion.pose_kernel import PARALLEL_ROWS, pack_plan, plan_columns, pose_scratch
from quadsim.locomotion.tables import character_plan, stack_states
from quadsim.locomotion.transition import gait_tables
from quadsim.skeleton.character import Character


def _rows(values, n: int, dtype) -> np.ndarray:
    """``values`` (a scalar or N of them) as a new writable (N,) array."""
    out = np.empty(n, dtype=dtype)
    out[...] = np.asarray(values, dtype=dtype)
    return out


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
        Gait id (:attr:`ids`) being run or transitioned to.
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
        self.kinds = []  # each kind's CharacterPlan
        kind_of = np.empty(n, dtype=np.int64)
        for i, ch in enumerate(chars):
            k = kinds.get(id(ch))
            if k is None:
                k = kinds[id(ch)] = len(self.kinds)
                self.kinds.append(character_plan(ch))
            kind_of[i] = k
        self.kind = kind_of
        self.groups = tuple((kd.character, np.flatnonzero(kind_of == k))
                            for k, kd in enumerate(self.kinds))
        self.ids = gait_ids()
        self._constants()
        seeds = np.broadcast_to(np.asarray(seeds, dtype=np.int64), (n,))
        gaits = [None] * n if gaits is None else list(gaits)
        if len(gaits) != n:
            raise ValueError(f"`gaits` has {len(gaits)} entries, expected {n} (one a character)")
        self._init_state(chars, seeds, gaits)
        self._warned: set[tuple] = set()

    # ------------------------------------------------------------ set-up
    def _constants(self) -> None:
        kd, k = self.kinds, self.kind
        self._tables = gait_tables([(x.gaits, x.auto) for x in kd], self.ids)
        self._has = np.isfinite(self._tables.speed_lo)
        body = BodyConstants(*(np.ascontiguousarray(np.concatenate(f)[k])
                               for f in zip(*(x.body for x in kd))))
        self._body = body._replace(kind=np.ascontiguousarray(k, dtype=np.int64))
        reach = [x.reach_rows() for x in kd]
        self._reach = ReachTables(reach[0].drops, *(
            np.ascontiguousarray(np.concatenate(f)[k]) for f in list(zip(*reach))[1:]))
        self._n_tail_max = max(len(x.character.tail) for x in kd)
        self._sc: dict[float, object] = {}
        self._runner = FixedEntry(plan_rows)  # the bundles' types never change
        self._scratch = step_scratch(self.n)  # the stages' working rows, reused
        self._views: dict = {}  # each block of rows' views of body, reach, state, scratch
        # the default commands, copied each step (the kernel's fresh (N,) arrays)
        self._no_heading = np.full(self.n, np.nan)
        self._auto_gait = np.full(self.n, -1, dtype=np.int64)

    def _init_state(self, chars, seeds, gaits) -> None:
        rows = []
        for i in range(self.n):  # set-up only: the seeded generators are sequential
            g = gaits[i]
            start = resolve_gait_name(g, chars[i]) if g else STAND
            rows.append(self.kinds[self.kind[i]].initial_state(int(seeds[i]), start))
        self.state = stack_states(rows, self._n_tail_max)
        self.time = 0.0
        self.feet = self.state.feet.planted.copy()

    # the state, read from the plan's bundles
    speed = property(lambda self: self.state.motion.speed)
    heading = property(lambda self: self.state.motion.heading)
    yaw_rate = property(lambda self: self.state.motion.yaw_rate)
    root_xz = property(lambda self: self.state.motion.root_xz)
    stance = property(lambda self: self.state.feet.stance)
    current = property(lambda self: self.state.schedule.current)

    @property
    def max_speed(self) -> np.ndarray:
        """Top speed of each row's character (m/s), shape (N,)."""
        return self._body.max_speed

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
                out[i] = self.ids.index(resolve_gait_name(g, ch))
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
        sch, ids = self.state.schedule, self.ids
        return [f"{ids[s]}->{ids[c]}" if t else ids[c]
                for s, c, t in zip(sch.source_name, sch.current, sch.in_transition)]

    def _warn(self, what: str, mask, values, msg: str) -> None:
        """Warn once for each distinct clamp: the rows clamped and what they asked."""
        rows = np.flatnonzero(mask)
        key = (what, tuple(rows.tolist()), tuple(np.asarray(values)[rows].tolist()))
        if key not in self._warned:
            self._warned.add(key)
            warnings.warn(f"{msg} for {len(rows)} of {self.n} characters; clamped",
                          QuadsimClampWarning, stacklevel=4)

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
        gait : str or array-like, shape (N,), optional
            Requested gaits: names (``None`` chooses by speed) or gait ids
            (:attr:`ids`, see :meth:`gait_ids`; -1 chooses by speed); one for
            every row or one per row (default: by speed).
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
            ``toe``, ``load`` and ``phase`` (N, 4), ``contacts`` (N, 4) bool, ``tail``
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
            head = self._no_heading.copy()
        else:  # the turn rate is not used where a heading is steered to
            head = _rows(heading, n, float)
            turn[np.isfinite(head)] = 0.0
        if gait is None:
            gait = self._auto_gait.copy()
        else:
            given = gait
            try:
                if isinstance(gait, str):  # one name for every row
                    gait = [gait] * n
                if not isinstance(gait, np.ndarray) and any(
                        g is None or isinstance(g, str) for g in np.ravel(np.asarray(gait, object))):
                    gait = self.gait_ids(list(np.broadcast_to(np.asarray(gait, object), (n,))))
                gait = _rows(gait, n, np.int64)
            except InputError:  # an unknown name: gait_ids names the character's gaits
                raise
            except (TypeError, ValueError):
                raise InputError("`gait` must be gait names (None: by speed) or gait ids "
                                 f"(-1: by speed), one or {n} of them, got {given!r}") from None
            if np.any((gait < -1) | (gait >= len(self.ids))):
                raise InputError(f"`gait` ids must lie in -1 ... {len(self.ids) - 1} "
                                 f"(see gait_ids), got {given!r}")
            asked = gait >= 0
            if np.any(asked & ~self._has[self.kind, np.where(asked, gait, 0)]):
                raise InputError("a requested gait id is not among its character's gaits")
        # with pose, the plan kernel also packs the plans for the posing kernel
        dt = self.dt if dt is None else float(dt)
        columns = plan_columns(self._n_tail_max) if pose else 0
        if pose and len(self.kinds) == 1:
            # one kind: each block of rows is posed right after its plan, on its thread
            poser = self.kinds[0].poser
            J = poser.character.skeleton.n_joints
            local, P, err = np.empty((n, J, 3, 3)), np.empty((n, J, 3)), np.empty((n, 4))
            out = plan_outputs(n, columns)
            packed, entry, rig = out.packed, poser.entry, poser.rig

            def pose_block(a, e):
                entry(packed[a:e], rig, local[a:e], P[a:e], err[a:e], pose_scratch(rig, e - a))

            frame, _ = self._advance(speed, turn, head, gait, dt, columns, out=out,
                                     then=pose_block)
            frame.update(local_rotations=[local], positions=[P], ik_error=[err])
            return frame
        frame, packed = self._advance(speed, turn, head, gait, dt, columns)
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

    def _advance(self, v_cmd, turn, head, gait, dt, packed_columns=0, out=None, then=None):
        sc = self._sc.get(dt)
        if sc is None:
            sc = self._sc[dt] = step_constants(self.settings, dt)
        # the whole plan, compiled: the stage kernels a lone controller steps
        # with (plan_kernels.plan_rows), here over N rows; the state is updated
        # in place. From PARALLEL_ROWS rows on, one block of rows per thread
        # (blocks.run_blocks): the same result whatever the number of threads.
        cmd = CommandRows(v_cmd, turn, head, gait)
        out = run_plan(cmd, self._body, self._tables, self._reach, sc, self.state,
                       parallel=self.n >= PARALLEL_ROWS, packed_columns=packed_columns,
                       runner=self._runner, scratch=self._scratch,
                       views=self._views, out=out, then=then)
        if out.gait_speed_clamped.any():
            self._warn("gait_speed", out.gait_speed_clamped, v_cmd,
                       "speed above what the requested gait reaches")
        if out.speed_clamped.any():
            self._warn("speed", out.speed_clamped, v_cmd,
                       "speed above the character's fastest gait")
        if out.turn_clamped.any():
            self._warn("turn", out.turn_clamped, turn, "turn rate beyond the character's maximum")
        st = self.state
        mo, bs = st.motion, st.body
        self.feet = out.feet
        self.time += dt
        root = mo.root_xz.copy()  # x and z; y is the pelvis height
        root[:, 1] = bs.height
        spine = bs.spine_smooth.copy()
        bend = mo.bend.copy()
        # the frame holds copies: the state arrays change in place at the next step
        return {
            "root": root, "heading": mo.heading.copy(), "pitch": out.pitch, "sway": out.sway,
            "bend_yaw": bend, "bend_pitch": spine, "feet": out.feet,
            "fold": out.fold, "toe": out.toe.copy(), "load": out.load.copy(),
            "tail": bs.tail.copy(),
            "look": LOOK_PER_BEND * bend, "foot_yaw": st.feet.yaw.copy(),
            "contacts": st.feet.stance.copy(),
            "gait": st.schedule.current.copy(), "phase": out.phase, "speed": mo.speed.copy(),
            "duty": st.schedule.params.duty.copy(), "spine": spine,
            "heading_rate": mo.yaw_rate.copy(),
            "amplitude": np.concatenate([st.cpg.r, st.cpg.r_s[:, None]], axis=1),
        }, out.packed


__all__ = ["BatchController"]
