"""The procedural locomotion controller: commands in, poses out.

One :class:`ProceduralController` drives one character and implements
:class:`quadsim.controller.Controller`. Each call of
:meth:`ProceduralController.step` advances it by ``dt`` under a
:class:`~quadsim.commands.Command` and returns a :class:`quadsim.controller.Frame`:

1. speed and turn rate move towards the command (bounded acceleration);
2. the gait scheduler picks the gait (hysteresis) and blends transitions;
3. the CPG advances every leg's phase; a leg lifts off when its stride
   fraction passes the duty factor and touches down when it wraps;
4. stance feet stay where they landed; swing feet follow Catmull-Rom paths
   to touchdown points planned about the key points' predicted positions;
5. the spine bends (compress/stretch or the concave/convex machine) and
   into the turn; the tail lags behind;
6. IK poses the legs (:mod:`quadsim.locomotion.posing`).

The whole per-frame plan (1-5) is the compiled stage kernels of
:mod:`quadsim.locomotion.plan_kernels` over rows of characters, the very
ones :class:`~quadsim.locomotion.batch.BatchController` runs for N
characters: a lone controller keeps its state as one row of the kernels'
bundles (read back through properties such as
:attr:`ProceduralController.speed`). The posing is the compiled kernel of
:mod:`quadsim.locomotion.pose_kernel`. :func:`~quadsim.locomotion.offline.simulate`
runs a script and poses all frames in one pass at the end.

Bad commands: a negative or non-finite speed or turn rate raises
``ValueError`` (:class:`~quadsim.commands.Command` checks it); an
unknown gait raises :class:`~quadsim.errors.InputError`; a speed above the
character's fastest gait, or a turn rate above its maximum, is clamped with
a :class:`~quadsim.errors.QuadsimClampWarning` that names the value and the
limit -- once for each distinct request.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from quadsim.commands import Command
from quadsim.controller import Frame
from quadsim.errors import QuadsimClampWarning
from quadsim.locomotion.blocks import FixedEntry
from quadsim.locomotion.bundles import CommandRows, PlanOutputs, plan_outputs, step_scratch
from quadsim.locomotion.cpg import CPGParams
from quadsim.locomotion.gaits import STAND, resolve_gait_name
from quadsim.locomotion.plan_kernels import (
    GAIT_HOLD_FACTOR,
    LOOK_PER_BEND,
    MIN_TURN_SPEED,
    plan_rows,
    step_constants,
)
from quadsim.locomotion.pose_kernel import plan_columns
from quadsim.locomotion.precompile import while_plan_compiles
from quadsim.locomotion.rowmath import interp1
from quadsim.locomotion.tables import character_plan
from quadsim.locomotion.transition import GaitParams
from quadsim.skeleton.character import Character

#: Most gaits a controller offers to hold by number (the preview's keys 1-9).
MAX_HELD_GAITS = 9


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


class ScheduleView:
    """The gait scheduler's state of one controller, by gait name (read-only)."""

    def __init__(self, schedule, ids: tuple[str, ...]):
        self._s, self._ids = schedule, ids

    current = property(lambda self: self._ids[self._s.current[0]],
                       doc="The gait run, or entered by the transition.")
    source_name = property(lambda self: self._ids[self._s.source_name[0]],
                           doc="The gait the last transition left.")
    in_transition = property(lambda self: bool(self._s.in_transition[0]))

    @property
    def label(self) -> str:
        """``"old->new"`` during a transition, else the gait."""
        return f"{self.source_name}->{self.current}" if self.in_transition else self.current


class ProceduralController:
    """Interactive procedural locomotion for one character
    (a :class:`quadsim.controller.Controller`).

    Parameters
    ----------
    character : Character
    dt : float
        Fixed step (s).
    seed : int
        Seeds the small random start offsets of the oscillators.
    gait : str, optional
        Starting gait (default: standing).
    settings : ControllerSettings, optional
    """

    mode = "procedural"
    ground = None

    def __init__(self, character: Character, dt: float = 1.0 / 60.0, seed: int = 0,
                 gait: str | None = None, settings: ControllerSettings | None = None):
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
        self.character = character
        self._skeleton = character.skeleton
        self.dt = float(dt)
        self.settings = settings or ControllerSettings()
        self.plan = plan = character_plan(character)
        self.poser = plan.poser
        self.gaits = plan.gaits
        self.auto = list(plan.auto)
        self.auto_gaits = list(plan.auto)
        held = character.locomotion.get("gaits", [g for g in plan.gaits if g != STAND])
        self.gait_order = list(held)[:MAX_HELD_GAITS]
        self.max_speed = plan.max_speed
        self.max_turn_rate = float(plan.body.max_turn_rate[0])
        self.min_turn_radius = float(plan.body.min_turn_radius[0])
        self.h = character.hip_height
        self.pelvis_height = float(plan.body.pelvis_height[0])
        self.body_length = float(plan.body.body_length[0])
        self.drops = plan.drops
        self.half_sweep = plan.half_sweep
        start = resolve_gait_name(gait, character) if gait else STAND
        self._s = plan.initial_state(seed, start)
        self._reach = plan.reach_rows()
        self._packed_columns = plan_columns(len(character.tail))
        self.time = 0.0
        self._sc: dict[float, object] = {}
        self._cmd = CommandRows(np.zeros(1), np.zeros(1), np.zeros(1),
                                np.zeros(1, dtype=np.int64))
        self._gait_ids: dict[str, tuple[str, int]] = {}
        self._warned: set[tuple] = set()
        # on an empty cache the CLI may compile the plan in a second process: the
        # first step then compiles the posing meanwhile, and loads the plan
        self._runner = FixedEntry(plan_rows, before_first=partial(
            while_plan_compiles, self.poser, self._packed_columns))
        # the outputs of a step, reused: every reader copies what it keeps
        self._outs = {False: plan_outputs(1), True: plan_outputs(1, self._packed_columns)}
        self._scratch = step_scratch(1)  # the stages' working row
        self._labels: dict[tuple, str] = {}
        self._label = self._current_label()

    # the state, read from the compiled plan's row
    speed = property(lambda self: float(self._s.motion.speed[0]), doc="Forward speed (m/s).")
    heading = property(lambda self: float(self._s.motion.heading[0]),
                       doc="Heading about +Y (rad).")
    yaw_rate = property(lambda self: float(self._s.motion.yaw_rate[0]), doc="Turn rate (rad/s).")
    bend = property(lambda self: float(self._s.motion.bend[0]), doc="Spine yaw bend (rad).")
    freq = property(lambda self: float(self._s.cpg.freq[0]), doc="Stride frequency (Hz).")
    height = property(lambda self: float(self._s.body.height[0]), doc="Pelvis height (m).")
    theta = property(lambda self: self._s.cpg.theta[0].tolist(), doc="Leg phases (rad).")
    stance = property(lambda self: self._s.feet.stance[0].tolist(),
                      doc="Planted feet (4 bools).")
    root_xz = property(lambda self: tuple(self._s.motion.root_xz[0].tolist()))
    state = property(lambda self: self._s, doc="The plan's state bundle (one row).")

    @property
    def gait(self) -> str:
        """The last frame's gait label (``"walk"``, ``"walk->trot"``, ``"stand"``)."""
        return self._label

    @property
    def params(self) -> GaitParams:
        """The blended gait parameters of the last step."""
        return GaitParams.from_rows(self._s.schedule.params, 0)

    @property
    def scheduler(self) -> ScheduleView:
        """The gait scheduler's state, by name (read-only)."""
        return ScheduleView(self._s.schedule, self.plan.ids)

    def _current_label(self) -> str:
        """The scheduler's label, remembered by (current, source, in transition)."""
        sch = self._s.schedule
        key = (int(sch.current[0]), int(sch.source_name[0]), bool(sch.in_transition[0]))
        label = self._labels.get(key)
        if label is None:
            label = self._labels[key] = ScheduleView(sch, self.plan.ids).label
        return label

    # ------------------------------------------------------------ limits
    def preferred_speed(self, gait: str) -> float:
        """The gait table's preferred speed of ``gait`` (m/s), the middle of its range."""
        return float(self.gaits[resolve_gait_name(gait, self.character)].preferred_speed)

    def gait_speed_cap(self, gait: str) -> float:
        """Fastest speed (m/s) a requested gait is held at: 15 % above its range,
        at most :attr:`max_speed`."""
        g = self.gaits[resolve_gait_name(gait, self.character)]
        return min(self.max_speed, GAIT_HOLD_FACTOR * g.speed_range[1])

    def max_turn_rate_at(self, speed: float) -> float:
        """Largest turn rate (rad/s) at ``speed``: the character's maximum, and no
        tighter than its minimum turn radius (``min_turn_radius_body_lengths``
        body lengths, default 1) -- the key points must fit on the arc."""
        return min(self.max_turn_rate, max(speed, MIN_TURN_SPEED * self.h) / self.min_turn_radius)

    def needed_drop(self, leg: int, offset: float) -> float:
        """Body drop (fraction of pelvis height) at which a planted foot ``offset``
        metres fore or aft of its mid-stance point is within the leg's reach margin."""
        x = abs(offset) / self.settings.reach_margin
        return float(interp1(x, np.ascontiguousarray(self.half_sweep[:, leg]), self.drops))

    # ------------------------------------------------------------ stepping
    def _gait_id(self, name: str) -> tuple[str, int]:
        out = self._gait_ids.get(name)
        if out is None:
            resolved = resolve_gait_name(name, self.character)
            out = self._gait_ids[name] = (resolved, self.plan.gait_id(resolved))
        return out

    def _warn(self, key: tuple, msg: str) -> None:
        """Warn once for each distinct clamp ``key``."""
        if key not in self._warned:
            self._warned.add(key)
            warnings.warn(msg, QuadsimClampWarning, stacklevel=4)

    def _plan(self, command: Command, dt: float | None, packed: bool = False) -> PlanOutputs:
        """One step of the compiled plan (one row), warnings raised for its
        clamps; the outputs, the plan packed for the posing if ``packed``."""
        dt = self.dt if dt is None else float(dt)
        sc = self._sc.get(dt)
        if sc is None:
            sc = self._sc[dt] = step_constants(self.settings, dt)
        v_cmd = float(command.speed)
        gait_name, gid = self._gait_id(command.gait) if command.gait else (None, -1)
        c = self._cmd
        c.speed[0] = v_cmd
        c.gait[0] = gid
        if command.heading is None:
            c.heading[0] = math.nan
            c.turn_rate[0] = float(command.turn_rate or 0.0)
        else:
            c.heading[0] = float(command.heading)
            c.turn_rate[0] = 0.0
        p = self.plan
        out = self._outs[packed]
        # run_plan's serial path, called directly (one row: no blocks on threads)
        self._runner(c, p.body, p.tables, self._reach, sc, self._s, self._scratch, out)
        if out.gait_speed_clamped[0] or out.speed_clamped[0] or out.turn_clamped[0]:
            self._clamp_warnings(command, gait_name, out)
        self._label = self._current_label()
        self.time += dt
        return out

    def _clamp_warnings(self, command: Command, gait_name, out: PlanOutputs) -> None:
        v_cmd, who = float(command.speed), self.character.id
        if out.gait_speed_clamped[0]:
            cap = GAIT_HOLD_FACTOR * self.gaits[gait_name].speed_range[1]
            self._warn(("gait_speed", gait_name, v_cmd),
                       f"speed {v_cmd:.2f} m/s is above what the {command.gait} of {who} "
                       f"reaches ({cap:.2f} m/s); clamped to {cap:.2f} m/s")
            v_cmd = cap
        if out.speed_clamped[0]:
            self._warn(("speed", v_cmd),
                       f"speed {v_cmd:.2f} m/s is above {who}'s fastest gait "
                       f"({self.max_speed:.2f} m/s); clamped to {self.max_speed:.2f} m/s")
        if out.turn_clamped[0]:
            turn = float(command.turn_rate or 0.0)
            fast, max_rate = float(out.clamp_speed[0]), float(out.clamp_rate[0])
            self._warn(("turn", turn),
                       f"turn rate {math.degrees(turn):.1f} deg/s is beyond {who}'s maximum "
                       f"at {fast:.2f} m/s ({math.degrees(max_rate):.1f} deg/s); clamped")

    def plan_step(self, command: Command, dt: float | None = None) -> dict:
        """Advance one step without posing: this frame's plan.

        Returns
        -------
        dict
            Arrays: ``root`` (3,) (m), ``heading``, ``pitch``, ``bend_yaw``,
            ``bend_pitch``, ``look``, ``spine`` (rad), ``sway`` (2,), ``feet``
            (4, 3) (m), ``fold``, ``toe``, ``load``, ``phase`` (4,), ``contacts`` (4,)
            bool, ``tail`` (n_tail, 2), ``speed`` (m/s), ``duty``,
            ``heading_rate`` (rad/s), ``amplitude`` (5,); and ``gait`` (label).
        """
        return self._plan_dict(self._plan(command, dt))

    def _plan_dict(self, out: PlanOutputs) -> dict:
        st = self._s
        mo, bs = st.motion, st.body
        fold = out.fold[0].copy()
        bend = mo.bend.item(0)
        spine = bs.spine_smooth.item(0)
        x, _, z = mo.root_xz[0].tolist()
        return {
            "root": np.array((x, bs.height.item(0), z)),
            "heading": mo.heading.item(0), "pitch": out.pitch.item(0),
            "sway": out.sway[0].copy(), "bend_yaw": bend, "bend_pitch": spine,
            "feet": out.feet[0].copy(), "fold": fold, "toe": out.toe[0].copy(),
            "load": out.load[0].copy(),
            "tail": bs.tail[0].copy(), "look": LOOK_PER_BEND * bend,
            "foot_yaw": st.feet.yaw[0].copy(),
            "contacts": st.feet.stance[0].copy(), "gait": self._label,
            "phase": out.phase[0].copy(), "speed": mo.speed.item(0),
            "duty": st.schedule.params.duty.item(0), "spine": spine,
            "heading_rate": mo.yaw_rate.item(0),
            "amplitude": np.concatenate([st.cpg.r[0], st.cpg.r_s]),
        }

    def step(self, command: Command, dt: float | None = None, *, pose: bool = True) -> Frame:
        """Advance one step of ``dt`` seconds (default :attr:`dt`) under ``command``.

        Returns
        -------
        Frame
            The posed skeleton at the new :attr:`time`, with ``extras``:
            ``phase`` (4,) CPG stride fractions, ``spine`` (rad), ``duty``,
            ``speed`` (m/s), ``heading`` (rad), ``feet`` (4, 3) the foot
            targets (m), ``ik_error`` (4,) (m) and ``cpg_amplitude`` (5,).
            With ``pose=False`` (the plan alone, for timing it) the
            :meth:`plan_step` dict instead.
        """
        if not pose:
            return self.plan_step(command, dt)
        out = self._plan(command, dt, packed=True)
        local, positions, err = self.poser.pose_row(out.packed)
        st = self._s
        mo = st.motion
        # every array fresh, owning its data: the frame takes them (Frame.owned)
        return Frame.owned(
            self._skeleton, self.time, positions[0].copy(), local, positions,
            float(mo.heading[0]), self._label, st.feet.stance[0].copy(), float(mo.speed[0]),
            {"phase": out.phase[0].copy(), "spine": np.array(st.body.spine_smooth[0]),
             "duty": np.array(st.schedule.params.duty[0]), "speed": np.array(mo.speed[0]),
             "heading": np.array(mo.heading[0]), "feet": out.feet[0].copy(), "ik_error": err,
             "cpg_amplitude": np.concatenate([st.cpg.r[0], st.cpg.r_s])})

    def pose(self, plans: dict[str, np.ndarray]):
        """Local rotations (T, J, 3, 3), root positions (T, 3) and IK errors (T, 4)
        of plans with a leading frame axis (as :meth:`plan_step` gives, stacked)."""
        return self.poser.pose(plans)


__all__ = ["ControllerSettings", "ProceduralController", "QuadsimClampWarning"]
