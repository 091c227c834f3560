"""A character's constants for the compiled plan, and its starting state.

:func:`character_plan` works out, once per character, what the plan kernels
read: the gaits (with the standing state) as
:class:`~quadsim.locomotion.bundles.GaitTables`, the body as one row of
:class:`~quadsim.locomotion.bundles.BodyConstants`, and each leg's measured
reach (:func:`measure_sweeps`). :meth:`CharacterPlan.initial_state` gives a
row of :class:`~quadsim.locomotion.bundles.PlanState`; :func:`stack_states`
stacks rows for a batch.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, replace

import numpy as np

from quadsim.frames import Y
from quadsim.kinematics.ik import solve_leg
from quadsim.kinematics.rotations import matrices_yaw_pitch
from quadsim.locomotion.body import MAX_FOOTING
from quadsim.locomotion.bundles import (
    BodyConstants,
    BodyState,
    CpgState,
    FeetState,
    GaitRows,
    GaitTables,
    MotionState,
    PlanState,
    ReachTables,
    ScheduleState,
    new_gait_rows,
)
from quadsim.locomotion.cpg import TWO_PI
from quadsim.locomotion.gaits import STAND, Gait, auto_gaits, gait_ids, gait_table, max_speed
from quadsim.locomotion.posing import Poser
from quadsim.locomotion.transition import HYSTERESIS, gait_tables
from quadsim.skeleton.character import Character
from quadsim.skeleton.fk import forward_kinematics

#: Body drops (fractions of the pelvis height) at which each leg's reach is measured.
DROPS = np.linspace(0.0, 0.3, 13)
#: Stance sweeps are tried out to this many hip heights fore and aft, in this
#: many steps.
SWEEP_REACH = 1.5
SWEEP_SAMPLES = 301
#: A halted character stands once slower than this fraction of its slowest
#: gait's lowest speed.
STAND_SPEED_FRACTION = 0.3
#: Defaults of the character file's ``[locomotion]`` keys.
DEFAULT_MAX_TURN_RATE_DEG_S = 90.0
DEFAULT_SPINE_FLEX_DEG = 15.0
DEFAULT_SPINE_EXTEND_DEG = -10.0
DEFAULT_MIN_TURN_RADIUS_BODY_LENGTHS = 1.0
DEFAULT_SPINE_SLOW_SCALE = 1.0


def standing(slowest: Gait) -> Gait:
    """A gait with duty factor 1 on the slowest gait's clock: once its
    transition ends no foot lifts, so the character stands."""
    return replace(slowest, name=STAND, duty_range=(1.0, 1.0), spine_amplitude=0.0, drop=0.0)


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


def flexion_lift(character: Character, joints: np.ndarray, bend: float = 0.1) -> np.ndarray:
    """How far each of ``joints`` rises per rad of spine flexion (m/rad), the
    trunk posed as the posing kernel bends it (the pelvis tilted back by half
    the bend, the spine joints sharing it), by central difference over
    ``+-bend`` rad."""
    sk = character.skeleton
    spine = list(character.spine[1:])
    K = len(spine)
    heights = []
    for b in (bend, -bend):
        local = np.broadcast_to(np.eye(3), (sk.n_joints, 3, 3)).copy()
        local[0] = matrices_yaw_pitch(0.0, -0.5 * b)
        local[spine] = matrices_yaw_pitch(np.zeros(K), np.full(K, b / K))
        _, P = forward_kinematics(sk, local[None], sk.rest_positions[0][None])
        heights.append(P[0, joints, Y])
    return (heights[0] - heights[1]) / (2.0 * bend)


def measure_sweeps(character: Character, poser: Poser, drops: np.ndarray) -> np.ndarray:
    """Half stance sweep each leg reaches exactly, per body drop, shape (D, 4) (m).

    For each drop (fraction of the pelvis height the body is lowered by),
    ground targets fore and aft of the rest foot position are tried with
    the leg IK itself; the result is the largest distance for which every
    nearer target is reached on both sides.
    """
    P = character.skeleton.rest_positions
    pelvis_height = float(P[0, Y])
    xs = np.linspace(0.0, SWEEP_REACH * character.hip_height, SWEEP_SAMPLES)
    out = np.zeros((len(drops), 4))
    eye = np.eye(3)
    for i, geom in enumerate(poser.legs):
        foot = P[character.legs[i].foot]
        for d, drop in enumerate(drops):
            parent = P[geom.parent] - np.array([0.0, drop * pelvis_height, 0.0])
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


def toe_vectors(character: Character) -> np.ndarray:
    """Each foot's toe tip (its joint's end site) from the joint, in the frame of
    the foot standing level and facing forward: (forward, up) (m), shape (4, 2);
    zero for a foot without an end site. The rest pose stands level, so the end
    site's offset is that vector (its sideways part left out)."""
    sk = character.skeleton
    out = np.zeros((4, 2))
    for i, leg in enumerate(character.legs):
        end = sk.end_sites.get(sk.names[leg.chain[-1]])
        if end is not None:
            out[i] = end[2], end[1]
    return out


@dataclass(frozen=True, eq=False)
class CharacterPlan:
    """What the compiled plan knows of one character (immutable, shared).

    Attributes
    ----------
    character : Character
    poser : Poser
    gaits : dict of str to Gait
        The character's gaits and the standing state :data:`~quadsim.locomotion.gaits.STAND`.
    auto : list of str
        The automatic gaits, slowest first.
    ids : tuple of str
        The gait ids (:func:`~quadsim.locomotion.gaits.gait_ids`).
    tables : GaitTables
        The gaits, one kind.
    body : BodyConstants
        One row.
    drops : ndarray, shape (D,)
    half_sweep : ndarray, shape (D, 4)
        Each leg's half stance sweep per drop (m), non-decreasing.
    foot_offset : ndarray, shape (4, 3)
        Mid-stance foot offsets from the key points (m).
    top_height, top_ahead, radius : ndarray, shape (4,)
        Each leg's top joint's rest height, how far ahead of its key point
        it stands, and how far its foot reaches from it (the nearer end of
        the stance sweep at the standing height) (m).
    flex_lift : ndarray, shape (4,)
        How far each leg's top joint rises per rad of spine flexion
        (:func:`flexion_lift`) (m/rad).
    toe : ndarray, shape (4, 2)
        Each toe tip from its foot joint in the level foot's frame, (forward,
        up) (m) (:func:`toe_vectors`).
    roll : ndarray, shape (4,)
        How far each foot rolls over its toe tip by lift-off, toes down (rad):
        ``[locomotion] toe_roll_deg`` (a character file that sets it gives every
        foot a toe tip ahead of its joint, :func:`~quadsim.skeleton.character.load_character`).
    """

    character: Character
    poser: Poser
    gaits: dict
    auto: list
    ids: tuple
    tables: GaitTables
    body: BodyConstants
    drops: np.ndarray
    half_sweep: np.ndarray
    foot_offset: np.ndarray
    top_height: np.ndarray
    top_ahead: np.ndarray
    radius: np.ndarray
    flex_lift: np.ndarray
    toe: np.ndarray
    roll: np.ndarray

    @property
    def max_speed(self) -> float:
        return float(self.body.max_speed[0])

    def reach_rows(self) -> ReachTables:
        """The reach tables as one row (fresh writable arrays: one compiled
        signature for every character and the batch)."""
        hs = np.array(self.half_sweep, dtype=float)
        return ReachTables(np.array(self.drops, dtype=float), hs[None].copy(),
                           np.ascontiguousarray(hs.min(axis=1)[None]),
                           np.ascontiguousarray(np.swapaxes(hs, 0, 1)[None]),
                           np.array(self.foot_offset[None], dtype=float),
                           np.array(self.top_height[None], dtype=float),
                           np.array(self.top_ahead[None], dtype=float),
                           np.array(self.radius[None], dtype=float),
                           np.array(self.flex_lift[None], dtype=float),
                           np.array(self.toe[None], dtype=float),
                           np.array(self.roll[None], dtype=float))

    def gait_id(self, name: str) -> int:
        return self.ids.index(name)

    def initial_state(self, seed: int, start: str) -> PlanState:
        """One row of the plan's state: standing (or in gait ``start``) at the
        origin facing +Z, the oscillators seeded."""
        ch = self.character
        theta, r, theta_s = initial_oscillators(self.gaits[start], seed)
        feet = ch.rest_foot_positions().copy()
        feet[:, Y] = 0.0
        g = self.ids.index(start)
        # the gait's parameters at speed 0: the duty factor at the slow end
        # (target_into's line at s = 0, exactly)
        t = self.tables
        params = GaitRows(t.duty_lo[0, g:g + 1].copy(), t.phases[0, g:g + 1].copy(),
                          *(np.array([f[0, g]]) for f in (t.stride_coefficient, t.speed_lo,
                                                          t.swing_height, t.drop, t.bound,
                                                          t.spine_amplitude)))
        theta = theta[None].astype(float)
        return PlanState(
            MotionState(np.zeros(1), np.zeros(1), np.zeros(1), np.zeros((1, 3)), np.zeros(1)),
            CpgState(theta, r[None].astype(float), np.array([float(theta_s)]), np.ones(1),
                     np.ones(1)),
            ScheduleState(np.array([g], dtype=np.int64), np.array([g], dtype=np.int64),
                          np.zeros(1, dtype=bool), np.zeros(1), np.zeros(1), new_gait_rows(1),
                          params),
            FeetState(np.ones((1, 4), dtype=bool), np.zeros((1, 4)), theta.copy(),
                      theta.copy(), feet[None].copy(), feet[None].copy(), np.zeros((1, 4)),
                      np.zeros((1, 4)), np.zeros((1, 4)), np.ones((1, 4))),
            BodyState(np.zeros(1), np.zeros(1), np.zeros((1, 2)),
                      np.array([float(self.body.pelvis_height[0])]),
                      np.zeros((1, len(ch.tail), 2)), np.zeros((1, 2)), np.zeros((1, 2)),
                      np.array([float(self.body.pelvis_height[0])]), np.zeros((1, 2)),
                      np.full(1, MAX_FOOTING), np.full((1, 2), np.inf),
                      np.zeros((1, 2)), np.zeros(1)))


_PLANS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def character_plan(character: Character) -> CharacterPlan:
    """The :class:`CharacterPlan` of ``character`` (worked out once)."""
    hit = _PLANS.get(character)
    if hit is not None:
        return hit
    ch = character
    loc = ch.locomotion
    gaits = dict(gait_table(ch))
    auto = auto_gaits(ch)
    gaits[STAND] = standing(gaits[auto[0]])
    ids = gait_ids()
    poser = Poser.for_character(ch)
    P = ch.skeleton.rest_positions
    pair_top = np.array([leg.chain[leg.ik_start] for leg in ch.legs])
    hind_z = float(np.mean(P[pair_top[2:], 2]) - P[0, 2])
    body_length = float(np.mean(P[pair_top[:2], 2]) - np.mean(P[pair_top[2:], 2]))
    feet = ch.rest_foot_positions()
    foot_offset = feet - P[pair_top]  # foot relative to its pair top, per leg
    foot_offset[:, Y] = 0.0
    foot_offset[:, 0] = feet[:, 0]  # lateral offset from the mid-line
    sweep = np.maximum.accumulate(measure_sweeps(ch, poser, DROPS), axis=0)
    tops = np.array([leg.chain[0] for leg in ch.legs])
    top_height = P[tops, Y]
    # the key points' z: the hind and fore pair tops' mean
    key_z = np.array([np.mean(P[pair_top[:2], 2])] * 2 + [np.mean(P[pair_top[2:], 2])] * 2)
    top_ahead = P[tops, 2] - key_z
    # the foot at mid-stance on the ground, the sweep's ends fore and aft
    mid = key_z + foot_offset[:, 2]
    radius = np.minimum(np.hypot(mid + sweep[0] - P[tops, 2], top_height),
                        np.hypot(mid - sweep[0] - P[tops, 2], top_height))
    sweep.setflags(write=False)
    slowest = gaits[auto[0]]
    toe = toe_vectors(ch)
    roll = math.radians(float(loc.get("toe_roll_deg", 0.0)))

    def row(x, dtype=float):
        return np.array([x], dtype=dtype)

    body = BodyConstants(
        kind=row(0, np.int64), hip_height=row(ch.hip_height), pelvis_height=row(P[0, Y]),
        hind_z=row(hind_z), body_length=row(body_length),
        stand_speed=row(STAND_SPEED_FRACTION * slowest.speed_range[0]),
        max_speed=row(max_speed(ch)),
        max_turn_rate=row(math.radians(float(loc.get("max_turn_rate_deg_s",
                                                     DEFAULT_MAX_TURN_RATE_DEG_S)))),
        spine_flexed=row(math.radians(float(loc.get("spine_flex_deg",
                                                    DEFAULT_SPINE_FLEX_DEG)))),
        spine_extended=row(math.radians(float(loc.get("spine_extend_deg",
                                                      DEFAULT_SPINE_EXTEND_DEG)))),
        min_turn_radius=row(float(loc.get("min_turn_radius_body_lengths",
                                          DEFAULT_MIN_TURN_RADIUS_BODY_LENGTHS)) * body_length),
        spine_slow_scale=row(float(loc.get("spine_slow_scale", DEFAULT_SPINE_SLOW_SCALE))),
        start_speed=row(slowest.speed_range[1]), n_tail=row(max(len(ch.tail), 1)),
        hysteresis=row(HYSTERESIS))
    out = CharacterPlan(ch, poser, gaits, auto, ids, gait_tables([(gaits, auto)], ids), body,
                        np.ascontiguousarray(DROPS, dtype=float), sweep, foot_offset,
                        top_height, top_ahead, radius, flexion_lift(ch, tops), toe,
                        np.full(4, roll))
    _PLANS[ch] = out
    return out


def stack_states(rows: list[PlanState], n_tail: int) -> PlanState:
    """Rows of :class:`~quadsim.locomotion.bundles.PlanState` as one, the
    tails zero-padded to ``n_tail`` joints."""
    def stack(fields):
        first = fields[0]
        if isinstance(first, tuple):
            return type(first)(*(stack([f[k] for f in fields]) for k in range(len(first))))
        return np.ascontiguousarray(np.concatenate(fields))

    padded = []
    for s in rows:
        tail = np.zeros((1, n_tail, 2))
        tail[:, :s.body.tail.shape[1]] = s.body.tail
        padded.append(s._replace(body=s.body._replace(tail=tail)))
    return stack(padded)
