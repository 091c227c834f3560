"""The named bundles of arrays the compiled plan reads and updates.

Every stage kernel of the plan (:mod:`quadsim.locomotion.plan_kernels`)
takes its inputs and state as these :class:`typing.NamedTuple` s of arrays
(numba compiles and caches functions of them), so a kernel names what it
reads -- ``state.cpg.theta``, ``gaits.speed_hi`` -- instead of a column
number. Arrays carry the row axis N first (one row per character; a lone
controller is one row), then the leg axis (LF, RF, LH, RH) where there is
one. Units are SI (m, s, rad); booleans are bool arrays.

Per-kind tables (:class:`GaitTables`) carry a kind axis K instead, indexed
by :attr:`BodyConstants.kind`, and a gait axis G: the gait ids of the gait
table data (:func:`quadsim.locomotion.gaits.gait_ids`), the standing state
last.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


__all__ = ["BodyConstants", "BodyState", "CommandRows", "CpgState", "FeetState", "GaitRows",
           "GaitTables", "MotionState", "PlanOutputs", "PlanState", "ReachTables",
           "ScheduleState", "StepConstants", "StepScratch", "new_gait_rows", "plan_outputs",
           "step_scratch", "take_rows"]


class CommandRows(NamedTuple):
    """The commands of one step, shape (N,) each."""

    speed: np.ndarray        #: commanded forward speed (m/s), >= 0
    turn_rate: np.ndarray    #: commanded turn rate (rad/s), positive left
    heading: np.ndarray      #: heading to steer to (rad); NaN: use the turn rate
    gait: np.ndarray         #: requested gait id (int64); -1 chooses by speed


class BodyConstants(NamedTuple):
    """A character's constants, one entry a row, shape (N,) each."""

    kind: np.ndarray             #: row's kind of character (int64), indexes GaitTables
    hip_height: np.ndarray       #: m
    pelvis_height: np.ndarray    #: rest height of the root (m)
    hind_z: np.ndarray           #: hind key point ahead of the pelvis (m)
    body_length: np.ndarray      #: hind to fore key point (m)
    stand_speed: np.ndarray      #: below this speed a halted character stands (m/s)
    max_speed: np.ndarray        #: top of the fastest gait (m/s)
    max_turn_rate: np.ndarray    #: rad/s
    spine_flexed: np.ndarray     #: concave target of the bounding spine (rad)
    spine_extended: np.ndarray   #: convex target (rad)
    min_turn_radius: np.ndarray  #: m
    spine_slow_scale: np.ndarray  #: scale of the slow gaits' spine motion
    start_speed: np.ndarray      #: speed reached when setting off from standing (m/s)
    n_tail: np.ndarray           #: tail joints, at least 1 (float)
    hysteresis: np.ndarray       #: relative half-width of the gait bands


class GaitTables(NamedTuple):
    """Each kind's gaits, shape (K, G) unless said (NaN where a kind lacks a gait)."""

    speed_lo: np.ndarray             #: m/s
    speed_hi: np.ndarray             #: m/s
    duty_lo: np.ndarray              #: duty factor at speed_lo
    duty_hi: np.ndarray              #: duty factor at speed_hi
    phases: np.ndarray               #: (K, G, 4) touchdown phases after LH's
    stride_coefficient: np.ndarray   #: lambda / h = coefficient * Fr^0.3
    swing_height: np.ndarray         #: m
    drop: np.ndarray                 #: fraction of the pelvis height
    bound: np.ndarray                #: 1 for a bounding spine, 0 for a flexing one
    spine_amplitude: np.ndarray      #: rad
    auto: np.ndarray                 #: (K, A) automatic gait ids by speed (int64, -1 padded)
    bounds: np.ndarray               #: (K, A) speed boundaries between them (m/s, inf padded)
    auto_pos: np.ndarray             #: (K, G) a gait's place in ``auto``, -1 if none (int64)
    n_auto: np.ndarray               #: (K,) number of automatic gaits (int64)


class ReachTables(NamedTuple):
    """What each leg reaches, per body drop."""

    drops: np.ndarray        #: (D,) body drops, fractions of the pelvis height
    half_sweep: np.ndarray   #: (N, D, 4) half stance sweep each leg reaches (m)
    sweep_min: np.ndarray    #: (N, D) the worst leg's
    sweep_cols: np.ndarray   #: (N, 4, D) half_sweep, leg-major
    foot_offset: np.ndarray  #: (N, 4, 3) mid-stance foot offsets from the key points (m)
    top_height: np.ndarray   #: (N, 4) each leg's top joint's height at rest (m)
    top_ahead: np.ndarray    #: (N, 4) ... and how far ahead of its key point (m)
    radius: np.ndarray       #: (N, 4) how far each leg's foot reaches from its top joint (m)
    flex_lift: np.ndarray    #: (N, 4) each top joint's rise per rad of spine flexion (m/rad)
    toe: np.ndarray          #: (N, 4, 2) each toe tip from its foot joint, level (forward, up) (m)
    roll: np.ndarray         #: (N, 4) how far each foot rolls over its toe tip by lift-off (rad)


class StepConstants(NamedTuple):
    """The step's scalars (settings and ``dt``)."""

    dt: float              #: s
    acceleration: float    #: m/s^2
    reach_margin: float    #: fraction of the measured sweep a stride may use
    vault: float           #: extra drop a stride may use (fraction of pelvis height)
    max_bend: float        #: rad
    max_sway: float        #: rad
    a_turn: float          #: smoothing factors 1 - exp(-dt / tau) of the turn rate,
    a_bend: float          #: the spine's yaw bend,
    a_smooth: float        #: the spine's pitch,
    a_drop: float          #: the girdles' drops and height,
    a_tail: float          #: and each tail joint
    mu: float              #: CPG squared amplitude
    gain: float            #: CPG amplitude gain (1/s)
    coupling: float        #: leg coupling (rad/s)
    spine_coupling: float  #: leg-to-spine coupling (rad/s)
    substeps: int          #: RK4 sub-steps


class GaitRows(NamedTuple):
    """Blendable gait parameters, one set a row, shape (N,) unless said."""

    duty: np.ndarray
    phases: np.ndarray               #: (N, 4)
    stride_coefficient: np.ndarray
    min_speed: np.ndarray            #: m/s
    swing_height: np.ndarray         #: m
    drop: np.ndarray
    bound: np.ndarray
    spine_amplitude: np.ndarray      #: rad


class MotionState(NamedTuple):
    """The body's path, shape (N,) unless said."""

    speed: np.ndarray     #: m/s
    yaw_rate: np.ndarray  #: rad/s
    heading: np.ndarray   #: rad
    root_xz: np.ndarray   #: (N, 3) pelvis on the ground (m)
    bend: np.ndarray      #: spine yaw bend (rad)


class CpgState(NamedTuple):
    """The oscillators, shape (N,) unless said."""

    theta: np.ndarray    #: (N, 4) unwrapped leg phases (rad)
    r: np.ndarray        #: (N, 4) leg amplitudes
    theta_s: np.ndarray  #: spine phase (rad)
    r_s: np.ndarray      #: spine amplitude
    freq: np.ndarray     #: stride frequency (Hz)


class ScheduleState(NamedTuple):
    """The gait scheduler, shape (N,) unless said."""

    current: np.ndarray        #: gait id run or entered (int64)
    source_name: np.ndarray    #: gait id a transition left (int64)
    in_transition: np.ndarray  #: bool
    elapsed: np.ndarray        #: s into the transition
    duration: np.ndarray       #: s
    source: GaitRows           #: parameters when the transition started
    params: GaitRows           #: parameters of this step


class FeetState(NamedTuple):
    """The feet, shape (N, 4) unless said."""

    stance: np.ndarray    #: bool, planted
    swing_s: np.ndarray   #: swing progress 0..1
    theta_lo: np.ndarray  #: phase at lift-off (rad)
    theta_td: np.ndarray  #: phase of the planned touchdown (rad)
    planted: np.ndarray   #: (N, 4, 3) where each planted foot is (m)
    liftoff: np.ndarray   #: (N, 4, 3) where each swing began (m)
    yaw: np.ndarray       #: world yaw each foot keeps (rad): its landing heading in stance
    yaw_lo: np.ndarray    #: ... and had at its lift-off
    toe_lo: np.ndarray    #: each foot's pitch, toes down, at its lift-off (rad)
    duty_td: np.ndarray   #: the duty factor of the gait each planted foot landed in


class BodyState(NamedTuple):
    """The spine, height and tail, shape (N,) unless said."""

    spine_angle: np.ndarray   #: the bounding spine's machine angle (rad)
    spine_smooth: np.ndarray  #: spine pitch after its filter (rad)
    drops_now: np.ndarray     #: (N, 2) hind and fore girdle drops
    height: np.ndarray        #: pelvis height (m): ``base_height`` plus the hind girdle's rise
    tail: np.ndarray          #: (N, T, 2) tail joints' (pitch, yaw) (rad)
    heave: np.ndarray         #: (N, 2) the trunk centre's rise (m) and rocking (rad)
    heave_rate: np.ndarray    #: (N, 2) their rates (m/s, rad/s)
    base_height: np.ndarray   #: pelvis height the drops set, after their filter (m)
    rise: np.ndarray          #: (N, 2) hind and fore girdles' rise over the drops (m)
    footing: np.ndarray       #: time since the last flight ended (s; 0 in flight)
    ceiling: np.ndarray       #: (N, 2) the girdles' ceilings a step ago (m; infinite with none)
    ceiling_feet: np.ndarray  #: (N, 2) ... and their planted feet then (left 1 + right 2)
    heave_rest: np.ndarray    #: (N,) the trunk centre's held level, the heave spring's rest (m)


class PlanState(NamedTuple):
    """Everything the plan updates in place."""

    motion: MotionState
    cpg: CpgState
    schedule: ScheduleState
    feet: FeetState
    body: BodyState


class StepScratch(NamedTuple):
    """What one stage of a step hands the next, and each stage's working
    rows (filled within the step; the caller's, so the step allocates nothing)."""

    v_before: np.ndarray     #: (N,) speed before this step (m/s)
    omega: np.ndarray        #: (N,) stride angular frequency (rad/s)
    psi: np.ndarray          #: (N, 4) target touchdown phases
    theta_prev: np.ndarray   #: (N, 4) leg phases before the CPG step (rad)
    keys: np.ndarray         #: (N, 2, 3) hind and fore key points (m)
    key_heading: np.ndarray  #: (N, 2) their headings (rad)
    key_cs: np.ndarray       #: (N, 2, 2) cosine and sine of each key heading
    final_duty: np.ndarray   #: (N,) duty factor of the gait being entered
    trailing: np.ndarray     #: (N, 4) bool: planted feet about to fall out of reach
    half_min: np.ndarray     #: (N,) the worst leg's half stance sweep (m)
    room: np.ndarray         #: (N, 4) each planted foot's trailing room (m)
    wanted: np.ndarray       #: (N,) gait id the schedule is asked for (int64)
    period: np.ndarray       #: (N,) stride period (s)
    need: np.ndarray         #: (N, 4) drop each planted foot needs (fraction of pelvis height)
    lx: np.ndarray           #: (N, 4) each foot across its girdle (m)
    lz: np.ndarray           #: (N, 4) ... and along it (m)
    td_tau: np.ndarray       #: (N, 4) each swinging foot's time to its touchdown (s; -1 planted)
    td_reach2: np.ndarray    #: (N, 4) ... and its touchdown point's squared ground distance
    #: from its leg's top joint where that will be then (m^2)


class PlanOutputs(NamedTuple):
    """What a step of the plan gives besides its state."""

    feet: np.ndarray             #: (N, 4, 3) foot targets (m)
    fold: np.ndarray             #: (N, 4) swing fold 0..1
    toe: np.ndarray              #: (N, 4) each foot's pitch, toes down (rad)
    load: np.ndarray             #: (N, 4) stance load over the body's weight (0 in swing)
    pitch: np.ndarray            #: (N,) whole-body pitch (rad)
    sway: np.ndarray             #: (N, 2) hind and fore girdle sway (rad)
    phase: np.ndarray            #: (N, 4) stride fractions
    packed: np.ndarray           #: (N, F) the plan packed for the posing; F = 0: not packed
    gait_speed_clamped: np.ndarray  #: (N,) bool: above what the requested gait reaches
    speed_clamped: np.ndarray    #: (N,) bool: above the character's top speed
    turn_clamped: np.ndarray     #: (N,) bool: turn rate above the maximum
    clamp_speed: np.ndarray      #: (N,) the speed the turn limit used (m/s)
    clamp_rate: np.ndarray       #: (N,) the turn limit (rad/s)


def new_gait_rows(n: int) -> GaitRows:
    """An empty :class:`GaitRows` of ``n`` rows."""
    return GaitRows(np.zeros(n), np.zeros((n, 4)), np.zeros(n), np.zeros(n), np.zeros(n),
                    np.zeros(n), np.zeros(n), np.zeros(n))


def step_scratch(n: int) -> StepScratch:
    """An empty :class:`StepScratch` of ``n`` rows."""
    return StepScratch(np.empty(n), np.empty(n), np.empty((n, 4)), np.empty((n, 4)),
                       np.empty((n, 2, 3)), np.empty((n, 2)), np.empty((n, 2, 2)), np.empty(n),
                       np.empty((n, 4), dtype=np.bool_), np.empty(n), np.empty((n, 4)),
                       np.empty(n, dtype=np.int64), np.empty(n), np.empty((n, 4)),
                       np.empty((n, 4)), np.empty((n, 4)), np.empty((n, 4)),
                       np.empty((n, 4)))


def plan_outputs(n: int, packed_columns: int = 0) -> PlanOutputs:
    """An empty :class:`PlanOutputs` of ``n`` rows (``packed_columns``: 0 packs nothing)."""
    return PlanOutputs(np.empty((n, 4, 3)), np.empty((n, 4)), np.empty((n, 4)),
                       np.zeros((n, 4)), np.empty(n),
                       np.empty((n, 2)),
                       np.empty((n, 4)), np.empty((n, packed_columns)),
                       np.zeros(n, dtype=np.bool_), np.zeros(n, dtype=np.bool_),
                       np.zeros(n, dtype=np.bool_), np.zeros(n), np.zeros(n))


def take_rows(bundle, rows):
    """``bundle`` (a NamedTuple of arrays, nested or not) with every array
    indexed by ``rows`` (in Python; a copy for an index array)."""
    return type(bundle)(*(take_rows(f, rows) if isinstance(f, tuple) else f[rows]
                          for f in bundle))
