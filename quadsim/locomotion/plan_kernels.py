"""The procedural controller's per-frame plan, compiled, as named stage kernels.

:func:`plan_rows` is one step of the whole plan for N rows (characters),
the stages in order:

1. :func:`speed_turn_rows` -- speed and turning: the clamps (reported in the
   outputs), the start from standing, the reach governor, bounded
   acceleration, the turn rate;
2. :func:`schedule_rows` -- the gait: the automatic choice with hysteresis,
   transitions along the duty-factor curve
   (:mod:`quadsim.locomotion.transition`);
3. :func:`stride_rows` -- stride limits and the stride frequency;
4. :func:`cpg_rows` -- the CPG (:func:`~quadsim.locomotion.cpg.cpg_step_rows`);
5. :func:`path_rows` -- the body on its path, the key points, what the feet
   need; then the feet (:func:`~quadsim.locomotion.feet.feet_rows`);
6. the body (:func:`~quadsim.locomotion.body.body_rows`);
7. :func:`pack_rows` -- each row's plan packed for the posing kernel, when
   asked.

With many rows, blocks of rows run on threads (:func:`run_plan`). Inputs
and state travel as the named bundles of
:mod:`quadsim.locomotion.bundles`. A lone
:class:`~quadsim.locomotion.controller.ProceduralController` runs the plan
on one row, :class:`~quadsim.locomotion.batch.BatchController` on N, so the
two agree by construction.

Units are SI (m, s, rad); legs in the order LF, RF, LH, RH.
"""

from __future__ import annotations

import math

from numba import get_num_threads, njit

from quadsim.locomotion.blocks import FixedEntry, run_blocks
from quadsim.locomotion.body import body_rows
from quadsim.locomotion.bundles import (
    PlanOutputs,
    ReachTables,
    StepConstants,
    StepScratch,
    plan_outputs,
    step_scratch,
    take_rows,
)
from quadsim.locomotion.cpg import TWO_PI, cpg_step_into
from quadsim.locomotion.feet import feet_rows, stance_duty
from quadsim.locomotion.pose_kernel import (
    BEND_PITCH,
    BEND_YAW,
    FEET,
    FOLD,
    FOOT_YAW,
    HEADING,
    LOAD,
    LOOK,
    PITCH,
    ROOT,
    SWAY,
    TAIL,
    TOE,
)
from quadsim.locomotion.rowmath import (
    MIN_SWING,
    frac,
    interp_col,
    interp_row,
    keys_row,
    plan_inner,
    room_row,
    stride_length,
)
from quadsim.locomotion.transition import advance_schedule, auto_choice, duty_at
from quadsim.locomotion.turning import HEADING_GAIN, steer_rate

#: A requested gait is held up to this factor above the top of its speed range.
GAIT_HOLD_FACTOR = 1.15
#: A commanded speed at or below this (m/s) is a halt.
HALT_SPEED = 1e-9
#: The turn limit of the minimum turn radius uses at least this fraction of
#: the hip height per second as the speed (turning on the spot stays possible).
MIN_TURN_SPEED = 0.1
#: The spine's yaw bend into a turn uses at least this fraction of the hip
#: height per second as the speed.
MIN_BEND_SPEED = 0.3
#: The bounding gaits keep this much more of the reach margin in hand for
#: the spine's flexion, which moves the girdles against the feet.
BOUND_REACH_KEEP = 0.05
#: Least stride frequency (Hz) a transition's length is taken from, least
#: duty factor a stride limit divides by, and the speed (m/s) above which
#: the stride law sets the frequency (below it the gait's least frequency).
MIN_FREQ = 1e-3
MIN_DUTY = 1e-3
MOVING_SPEED = 1e-6
#: Yaw of the head: this fraction of the spine's bend (the toes' curl in swing
#: is the feet stage's, :data:`~quadsim.locomotion.feet.TOE_PER_FOLD`).
LOOK_PER_BEND = 0.5
#: Time constants (s) of the spine's yaw bend, of its pitch and of the girdle
#: drops and body height following their targets.
BEND_TIME = 0.2
SPINE_SMOOTH_TIME = 0.03
DROP_TIME = 0.04


@plan_inner
def speed_turn_rows(cmd, body, gaits, reach, sc, state, scratch, out):
    """Stage 1: the speed and turn rate of this step, from the commands.

    The speed command is clamped to what a requested gait reaches
    (:data:`GAIT_HOLD_FACTOR`) and to the character's top speed; setting off
    from standing, to the square of the transition's progress times the
    slowest gait's top; by the reach governor, so that no planted foot falls
    out of reach before it lifts; then the speed moves towards it at
    bounded acceleration. The turn rate steers towards a commanded heading,
    or follows the commanded rate within the turn limit. The clamps are
    flagged in ``out``; ``scratch`` receives ``v_before``, ``keys`` and
    ``key_heading`` (the key points before moving) and ``room``.
    """
    st, mo, sch = state.feet, state.motion, state.schedule
    stand = gaits.speed_lo.shape[1] - 1
    # every array bound once, out of the loop
    keys, kh, v_before, room = scratch.keys, scratch.key_heading, scratch.v_before, scratch.room
    key_cs = scratch.key_cs
    c_speed, c_gait, c_turn, c_head = cmd.speed, cmd.gait, cmd.turn_rate, cmd.heading
    kind, speed_hi = body.kind, gaits.speed_hi
    max_speed, start_speed, max_turn = body.max_speed, body.start_speed, body.max_turn_rate
    hind_z, body_length, hip, r_min = (body.hind_z, body.body_length, body.hip_height,
                                       body.min_turn_radius)
    o_gait, o_speed, o_turn = out.gait_speed_clamped, out.speed_clamped, out.turn_clamped
    o_fast, o_rate = out.clamp_speed, out.clamp_rate
    current, in_transition, source_name = sch.current, sch.in_transition, sch.source_name
    elapsed, duration = sch.elapsed, sch.duration
    p_drop, p_duty = sch.params.drop, sch.params.duty
    drops_now, drops, sweep_min = state.body.drops_now, reach.drops, reach.sweep_min
    foot_offset, planted, stance = reach.foot_offset, st.planted, st.stance
    theta, freq = state.cpg.theta, state.cpg.freq
    speed, heading, bend, root_xz, yaw_rate = mo.speed, mo.heading, mo.bend, mo.root_xz, \
        mo.yaw_rate
    vault, dt, a_turn = sc.vault, sc.dt, sc.a_turn
    acc = sc.acceleration * sc.dt
    for n in range(speed.shape[0]):
        k = kind[n]
        vc = c_speed[n]
        g = c_gait[n]
        o_gait[n] = False
        o_speed[n] = False
        o_turn[n] = False
        if g >= 0:
            cap = GAIT_HOLD_FACTOR * speed_hi[k, g]
            if vc > cap:
                o_gait[n] = True
                vc = cap
        if vc > max_speed[n]:
            o_speed[n] = True
            vc = max_speed[n]
        cur = current[n]
        in_tr = in_transition[n]
        if cur == stand or (in_tr and source_name[n] == stand):
            progress = min(elapsed[n] / duration[n], 1.0) if in_tr else 0.0
            vc = min(vc, max(progress, 0.0) ** 2 * start_speed[n])
        # the reach governor: no planted foot out of reach before it lifts
        keys_row(root_xz, heading[n], bend[n], hind_z[n], body_length[n], keys, kh, key_cs, n)
        pd = p_drop[n] + vault
        dmax = max(drops_now[n, 0], drops_now[n, 1])
        base = interp_row(max(pd, dmax), drops, sweep_min, n)
        room_row(keys, key_cs, foot_offset, planted, base, room, n)
        duty = p_duty[n]
        gov = math.inf
        for i in range(4):
            if not stance[n, i]:
                continue
            u = frac(theta[n, i] / TWO_PI)
            d_own = stance_duty(duty, st.duty_td[n, i], cur == stand)  # (the feet stage's)
            lifts = u < d_own and 1.0 - MIN_SWING >= d_own
            t_lo = (d_own - u if lifts else 1.0 - u + min(d_own, 1.0 - MIN_SWING)) / freq[n]
            den = max(t_lo, dt)
            num = max(room[n, i], 0.0)
            if den == 0.0:
                if num == 0.0:
                    gov = math.nan
                    break
                continue
            gov = min(gov, num / den)
        if gov < vc:  # noqa: PLR1730 -- not min(): a NaN governor leaves vc as it is
            vc = gov
        dv = min(max(vc - speed[n], -acc), acc)
        v_before[n] = speed[n]
        v = max(speed[n] + dv, 0.0)
        speed[n] = v
        fast = max(v, vc)
        max_rate = min(max_turn[n], max(fast, MIN_TURN_SPEED * hip[n]) / r_min[n])
        o_fast[n] = fast
        o_rate[n] = max_rate
        if not math.isnan(c_head[n]):
            rate = steer_rate(heading[n], c_head[n], max_rate, HEADING_GAIN)
        else:
            rate = c_turn[n]
            if abs(rate) > max_rate:
                o_turn[n] = True
                rate = math.copysign(max_rate, rate)
        yaw_rate[n] += (rate - yaw_rate[n]) * a_turn


@plan_inner
def schedule_rows(cmd, body, gaits, sc, state, scratch):
    """Stage 2: the gait wanted and the blended gait parameters of this step.

    A halt (speed command 0) stands once the speed is below the stand
    speed, whatever gait is asked for; a requested gait is held up to
    :data:`GAIT_HOLD_FACTOR` above its speed range; otherwise the automatic
    choice by speed (with hysteresis) decides (``scratch.wanted``, and the
    stride period ``scratch.period``).
    """
    sch, mo = state.schedule, state.motion
    stand = gaits.speed_lo.shape[1] - 1
    speed, current, kind = mo.speed, sch.current, body.kind
    c_speed, c_gait, freq = cmd.speed, cmd.gait, state.cpg.freq
    hysteresis, stand_speed, speed_hi = body.hysteresis, body.stand_speed, gaits.speed_hi
    wanted, period = scratch.wanted, scratch.period
    for n in range(speed.shape[0]):
        k = kind[n]
        v = speed[n]
        g = c_gait[n]
        choice = auto_choice(gaits, k, current[n], v, hysteresis[n])
        if c_speed[n] <= HALT_SPEED and v <= stand_speed[n]:
            wanted[n] = stand
        elif g >= 0:
            wanted[n] = g
            if v > GAIT_HOLD_FACTOR * speed_hi[k, g]:
                wanted[n] = choice
        else:
            wanted[n] = choice
        period[n] = 1.0 / max(freq[n], MIN_FREQ)
    advance_schedule(gaits, kind, sch, wanted, speed, sc.dt, period, stand)


@plan_inner
def stride_rows(body, reach, sc, state, scratch):
    """Stage 3: the stride frequency (``cpg.freq``), the clock ``omega`` and
    the target phases ``psi`` (into ``scratch``): Alexander's stride law,
    no longer than every leg's stance sweep at this drop allows."""
    p, cpg = state.schedule.params, state.cpg
    for n in range(cpg.freq.shape[0]):
        h = body.hip_height[n]
        v = state.motion.speed[n]
        pd = p.drop[n] + sc.vault
        half = math.inf
        for i in range(4):
            half = min(half, interp_col(pd, reach.drops, reach.half_sweep, n, i))
        margin = sc.reach_margin - BOUND_REACH_KEEP * p.bound[n]
        limit = 2.0 * margin * half / max(p.duty[n], MIN_DUTY)
        minv, coef = p.min_speed[n], p.stride_coefficient[n]
        free = stride_length(minv, coef, v, h)
        lam = min(free, limit)
        lam_min = min(stride_length(minv, coef, minv, h), limit)
        if v > max(MOVING_SPEED, scratch.v_before[n]) and state.schedule.in_transition[n] \
                and v > lam * max(v / free, cpg.freq[n]):
            # through a gait change the stance may still be the old gait's, its
            # stride held short by the legs' sweep, while the speed runs up to
            # the new gait's: the body waits for the stride to open, the stride
            # frequency rising no higher than the stride law's or its own (the
            # legs spun up to 4.2 Hz from 1.8 and 2.7 in a walk -> trot, swings
            # squeezed to 5 frames of 11-14, wrists at 3,600 deg/s); slowing, it
            # slows no faster than asked (held, the horse's trot -> amble sagged
            # to 0.6 of the amble's speed)
            v = lam * max(v / free, cpg.freq[n])
            state.motion.speed[n] = v
        if v > MOVING_SPEED:
            cpg.freq[n] = max(v / lam, minv / lam_min)
        else:
            cpg.freq[n] = minv / lam_min
        scratch.omega[n] = TWO_PI * cpg.freq[n]
        for i in range(4):
            scratch.psi[n, i] = p.phases[n, i]


@plan_inner
def cpg_rows(sc, state, scratch):
    """Stage 4: the oscillators advance by ``sc.dt``; a leg's phase never
    runs backwards (``scratch.theta_prev`` keeps the phases before)."""
    c = state.cpg
    for n in range(c.theta.shape[0]):
        for i in range(4):
            scratch.theta_prev[n, i] = c.theta[n, i]
    cpg_step_into(c.theta, c.r, c.theta_s, c.r_s, scratch.omega, scratch.psi, sc.dt, sc.mu,
                  sc.gain, sc.coupling, sc.spine_coupling, sc.substeps)
    for n in range(c.theta.shape[0]):
        for i in range(4):
            c.theta[n, i] = max(c.theta[n, i], scratch.theta_prev[n, i])


@plan_inner
def path_rows(body, gaits, reach, sc, state, scratch):
    """Stage 5a: the body moves on its path (heading, pelvis, spine bend)
    and the feet stage's inputs follow: the key points, the duty factor of
    the gait entered, the planted feet about to trail out of reach and the
    worst leg's half sweep."""
    mo, p = state.motion, state.schedule.params
    room = scratch.room
    dt = sc.dt
    kind, current = body.kind, state.schedule.current
    for n in range(mo.speed.shape[0]):
        h = body.hip_height[n]
        v = mo.speed[n]
        mo.heading[n] = mo.heading[n] + mo.yaw_rate[n] * dt
        kk = 0.5 * (scratch.v_before[n] + v) * dt
        mh = mo.heading[n] - 0.5 * mo.yaw_rate[n] * dt
        mo.root_xz[n, 0] = mo.root_xz[n, 0] + kk * math.sin(mh)
        mo.root_xz[n, 1] = mo.root_xz[n, 1] + kk * 0.0
        mo.root_xz[n, 2] = mo.root_xz[n, 2] + kk * math.cos(mh)
        mb = sc.max_bend
        bt = min(max(mo.yaw_rate[n] * body.body_length[n] / max(v, MIN_BEND_SPEED * h), -mb),
                 mb)
        mo.bend[n] += (bt - mo.bend[n]) * sc.a_bend
        keys_row(mo.root_xz, mo.heading[n], mo.bend[n], body.hind_z[n], body.body_length[n],
                 scratch.keys, scratch.key_heading, scratch.key_cs, n)
        g = current[n]
        scratch.final_duty[n] = duty_at(gaits.speed_lo[kind[n], g], gaits.speed_hi[kind[n], g],
                                        gaits.duty_lo[kind[n], g], gaits.duty_hi[kind[n], g], v)
        pd = p.drop[n] + sc.vault
        dmax = max(state.body.drops_now[n, 0], state.body.drops_now[n, 1])
        base = interp_row(max(pd, dmax), reach.drops, reach.sweep_min, n)
        room_row(scratch.keys, scratch.key_cs, reach.foot_offset, state.feet.planted, base,
                 room, n)
        step = v * dt
        for i in range(4):
            scratch.trailing[n, i] = room[n, i] < step
        scratch.half_min[n] = interp_row(pd, reach.drops, reach.sweep_min, n)


@plan_inner
def pack_rows(state, out):
    """Stage 7: each row's plan packed for the posing
    (:func:`~quadsim.locomotion.pose_kernel.pack_plan`'s layout, with
    ``(F - TAIL) // 2`` tail joints, at most the state's), unless
    ``out.packed`` has no columns."""
    packed = out.packed
    if packed.shape[1] == 0:
        return
    mo, bs = state.motion, state.body
    tail = bs.tail
    n_tail = min((packed.shape[1] - TAIL) // 2, tail.shape[1])
    for n in range(packed.shape[0]):
        packed[n, ROOT] = mo.root_xz[n, 0]
        packed[n, ROOT + 1] = bs.height[n]
        packed[n, ROOT + 2] = mo.root_xz[n, 2]
        packed[n, HEADING] = mo.heading[n]
        packed[n, PITCH] = out.pitch[n]
        packed[n, SWAY] = out.sway[n, 0]
        packed[n, SWAY + 1] = out.sway[n, 1]
        packed[n, BEND_YAW] = mo.bend[n]
        packed[n, BEND_PITCH] = bs.spine_smooth[n]
        for i in range(4):
            for c in range(3):
                packed[n, FEET + 3 * i + c] = out.feet[n, i, c]
            packed[n, FOLD + i] = out.fold[n, i]
            packed[n, TOE + i] = out.toe[n, i]
        packed[n, LOOK] = LOOK_PER_BEND * mo.bend[n]
        for i in range(4):
            packed[n, FOOT_YAW + i] = state.feet.yaw[n, i]
            packed[n, LOAD + i] = out.load[n, i]
        for k in range(n_tail):
            packed[n, TAIL + 2 * k] = tail[n, k, 0]
            packed[n, TAIL + 2 * k + 1] = tail[n, k, 1]


@njit(cache=True, nogil=True, _nrt=False)
def plan_rows(cmd, body, gaits, reach, sc, state, scratch, out):
    """One step of the whole plan for N rows (characters), compiled.

    Compiled without numba's reference counting (like its stages,
    :data:`~quadsim.locomotion.rowmath.plan_inner`): the step borrows the
    caller's arrays and allocates nothing, so an array crosses in from
    Python without a reference-counted wrapper of its own.

    Parameters
    ----------
    cmd : CommandRows
    body : BodyConstants
    gaits : GaitTables
    reach : ReachTables
    sc : StepConstants
    state : PlanState
        Updated in place.
    scratch : StepScratch
        The stages' working rows (any values; overwritten).
    out : PlanOutputs
        Receives the feet, fold, pitch, sway, stride fractions, packed
        plans (if it has columns) and the clamp flags.
    """
    speed_turn_rows(cmd, body, gaits, reach, sc, state, scratch, out)
    schedule_rows(cmd, body, gaits, sc, state, scratch)
    stride_rows(body, reach, sc, state, scratch)
    cpg_rows(sc, state, scratch)
    path_rows(body, gaits, reach, sc, state, scratch)
    feet_rows(state, scratch, reach, sc, out)
    for n in range(out.phase.shape[0]):
        for i in range(4):
            out.phase[n, i] = frac(state.cpg.theta[n, i] / TWO_PI)
    body_rows(body, state, scratch, reach, sc, out)
    pack_rows(state, out)


def step_constants(settings, dt: float) -> StepConstants:
    """The step's scalars for ``settings`` (a
    :class:`~quadsim.locomotion.controller.ControllerSettings`) and ``dt``."""
    c = settings.cpg
    return StepConstants(
        dt=float(dt), acceleration=settings.acceleration, reach_margin=settings.reach_margin,
        vault=settings.vault, max_bend=settings.max_bend, max_sway=settings.max_sway,
        a_turn=1.0 - math.exp(-dt / settings.turn_response),
        a_bend=1.0 - math.exp(-dt / BEND_TIME),
        a_smooth=1.0 - math.exp(-dt / SPINE_SMOOTH_TIME),
        a_drop=1.0 - math.exp(-dt / DROP_TIME),
        a_tail=1.0 - math.exp(-dt / settings.tail_lag),
        mu=float(c.mu), gain=float(c.gain), coupling=float(c.coupling),
        spine_coupling=float(c.spine_coupling), substeps=int(c.substeps))


def run_plan(cmd, body, gaits, reach, sc, state, parallel: bool = False,
             packed_columns: int = 0, runner: FixedEntry | None = None,
             out: PlanOutputs | None = None, scratch: StepScratch | None = None,
             views: dict | None = None, then=None) -> PlanOutputs:
    """:func:`plan_rows`, or, if ``parallel`` (and numba has more than one
    thread), :func:`plan_rows` on blocks of rows on threads
    (:func:`~quadsim.locomotion.blocks.run_blocks`: the same result); returns
    the step's outputs, the plans packed for the posing if ``packed_columns``.

    ``runner``, a :class:`~quadsim.locomotion.blocks.FixedEntry` of
    :func:`plan_rows` for bundles whose types never change, skips numba's
    dispatch. ``out``, if given, receives the outputs (``packed_columns`` is
    then its ``packed`` width); ``scratch`` (a
    :func:`~quadsim.locomotion.bundles.step_scratch` of as many rows), if
    given, is the stages' working rows. ``views``, a dict the caller keeps
    for a ``body``, ``reach``, ``state`` and ``scratch`` that are the same
    arrays every call, keeps each block's views of them (cut once, not
    every step). ``then(a, e)``, if given, runs after the plan of rows ``a:e``
    in the same block (on the same thread): the posing of those rows, say,
    with no wait for the other blocks' plans in between."""
    n = state.motion.speed.shape[0]
    if out is None:
        out = plan_outputs(n, packed_columns)
    if scratch is None:
        scratch = step_scratch(n)
    if not parallel or get_num_threads() <= 1:
        (runner or plan_rows)(cmd, body, gaits, reach, sc, state, scratch, out)
        if then is not None:
            then(0, n)
        return out

    kernel = runner or plan_rows  # the blocks' slices have the whole arrays' types

    def block(a, e):
        rows = slice(a, e)
        fixed = None if views is None else views.get((a, e))
        if fixed is None:
            fixed = (take_rows(body, rows), reach_rows(reach, rows), take_rows(state, rows),
                     take_rows(scratch, rows))
            if views is not None:
                views[a, e] = fixed
        kernel(take_rows(cmd, rows), fixed[0], gaits, fixed[1], sc, fixed[2], fixed[3],
               take_rows(out, rows))
        if then is not None:
            then(a, e)

    run_blocks(block, n)
    return out


def reach_rows(reach: ReachTables, rows) -> ReachTables:
    """``reach`` with its per-row tables indexed by ``rows`` (``drops`` is
    every row's)."""
    return reach._replace(half_sweep=reach.half_sweep[rows], sweep_min=reach.sweep_min[rows],
                          sweep_cols=reach.sweep_cols[rows],
                          foot_offset=reach.foot_offset[rows],
                          top_height=reach.top_height[rows], top_ahead=reach.top_ahead[rows],
                          radius=reach.radius[rows], flex_lift=reach.flex_lift[rows])
