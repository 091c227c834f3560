"""The feet stage of the plan, compiled: lift-off, touchdown and swing paths.

A planted foot stays where it landed, level; a character's paws may roll
over their toe tips through the last part of the stance (the heel rising,
the toe tip put: ``[locomotion] toe_roll_deg``). It lifts off when its stride fraction
passes the duty factor (or when it is about to fall out of reach), and
swings along the Catmull-Rom path (:func:`~quadsim.locomotion.footpath.swing_into`)
to a touchdown point planned about its girdle's key point where that will
be at touchdown, on the arc the speed and turn rate describe
(:func:`~quadsim.locomotion.turning.arc_step`), plus a lead into the next
stance. Units are SI (m, s, rad); legs LF, RF, LH, RH.
"""

from __future__ import annotations

import math

from quadsim.locomotion.footpath import bound_share, fast_share, swing_into, walk_share
from quadsim.locomotion.rowmath import MIN_SWING, frac, plan_inner, smooth_min
from quadsim.locomotion.turning import arc_step

TWO_PI = 2.0 * math.pi
#: Swing clearance on a short step: at most this fraction of the step's
#: length ...
CLEARANCE_PER_STEP = 0.35
#: ... plus this fraction of the gait's swing height (never more than the
#: swing height itself).
CLEARANCE_BASE = 0.3
#: Touchdown lead: at most this fraction of the stance time ahead of the
#: touchdown instant (the rest of the reach is the stride's).
LEAD_STANCE_FRACTION = 0.5
#: In the bounding gaits (by :func:`~quadsim.locomotion.footpath.bound_share`) a hind
#: foot's touchdown point is planned this fraction of its stance time (at the body's
#: speed) further back, its stance a little further back under the hip: landing less
#: far ahead, the leg closes less in the landing frame (the horse's transverse gallop's
#: hind stifle 2,025 -> 1,917 deg/s, 1,983 -> 1,873 at 240 fps; its gait changes 45 ->
#: 54 of 56 within every bound; the leopard's gallops 1,891 / 1,820 -> 1,862 / 1,791,
#: the leopard cub's transverse 2,319 -> 2,278). Further back, at 0.05 and 0.1, the
#: cubs' and dog's rotary gallops landed their first fore foot faster (the dog cub's
#: elbow 3,051 -> 3,758 and 4,092 deg/s at 60 fps), the trunk pitched otherwise.
HIND_LEAD_CUT = 0.02
#: A foot lifts only once its phase has moved this far (rad) past its touchdown.
MIN_STANCE_PHASE = 1e-9
#: The touchdown lead's reach term divides by at least this speed (m/s).
MIN_LEAD_SPEED = 1e-6
#: A swing has landed once its progress is within this of 1.
TOUCHDOWN_EPS = 1e-12
#: A swing foot stays within this fraction of its leg's reach of the leg's
#: top joint (the leg keeps a bend in swing rather than locking straight),
#: fully until this swing progress, the hold then easing off so the foot
#: still lands on its touchdown point.
SWING_REACH = 0.98
REACH_HOLD_UNTIL = 0.8
#: The gallops' swinging feet are held closer, within this fraction: their path
#: runs ahead of the touchdown point in the trunk's frame (the foot comes back
#: onto it at ground speed, :data:`~quadsim.locomotion.footpath.SWING_KNOTS_BOUND`),
#: out of the fore leg's reach mid-swing, and the elbow opened to about 157 degrees
#: there, folded again and re-opened to land (the horse's gallops' elbows at
#: 2,576-2,589 deg/s, then 2,306-2,536; the leopard's rotary gallop 2,106 -> 1,953;
#: the cubs' and the dog's gallops 2-5 % slower). Held at 0.95 the leopard cub's
#: transverse gallop's fore feet came down 0.05 of a stride early (low and slow a
#: frame before their touchdown); at 0.94 its rotary gallop turned faster (2,932).
SWING_REACH_BOUND = 0.96
#: ... fully at duty factors of the second figure and less, not at all from the first
#: (the canters': held closer, the dog cub's canter clip at 2.5 m/s stood 0.05 of a
#: stride longer than its table, and no canter turned a joint slower).
HOLD_DUTY = (0.32, 0.26)
#: ... and softly: a galloping foot is drawn in from this fraction of the hold's
#: radius inside it, the distance rounded onto the radius (:func:`smooth_min`), so
#: the leg slows into its reach rather than stopping at it. Held hard, the horse's
#: fore hoof ran out to the radius mid-swing, its elbow opening 84 degrees in three
#: frames (2,137-2,357 deg/s), hung there while the foot was pulled up, and reopened
#: to land; now 2,025 and 1,964, its hind stifles at landing the fastest joints (the
#: leopard's gallops 1,885 / 1,951 -> 1,820 / 1,891, the dog cub's 2,284 / 3,109 ->
#: 2,188 / 3,051, the leopard cub's transverse 2,391 -> 2,319). Over 0.3 the cubs'
#: feet landed faster (0.31 of the body's speed); in the walk, trot and pace (not
#: rounded) it raised the feet's landing speed to 0.25-0.31 of the body's.
HOLD_ROUNDING = 0.2
#: ... the rounding eased in (smoothstep) over this much of the swing: rounded from
#: the swing's first frame, a foot lifting at the back of its reach was drawn 5 mm up
#: and forward on it (the leopard cub's paws left the ground a frame before their heels
#: had risen a fifth of their length); eased in over a quarter of the swing, a toe tip
#: lingered on the ground (the cub's transverse gallop's left fore down for 0.276 of the
#: stride against its table's 0.22; 0.267 held hard, 0.257 now).
HOLD_ROUNDING_FROM = 0.1
#: ... fully at duty factors of the second figure and less, not at all from the first:
#: the gallops at and about their preferred speeds, not the canters (rounded, the horse's
#: canter at 7 m/s, duty 0.28, gained nothing, and its baked clip expanded to 6 m/s
#: stood 11 % shorter than its own contact time scaled by Hoyt's law).
ROUNDING_DUTY = (0.28, 0.24)
#: A swinging leg folds as ``sin^2(pi s^FOLD_SKEW)`` of its swing progress ``s``: most
#: folded at 0.47 of the swing, folding a little faster than it unfolds for the
#: landing. Folded symmetrically (1.0), the horse's gallops turned the fore elbow at
#: 2,306-2,536 deg/s, its canter 1,365, its pace 1,041 (now 2,137-2,357, 1,261 and
#: 938; the dog cub's transverse gallop 2,317 -> 2,284, every walk 2-4 % lower, the
#: cats' and dog's trots up to 2 % higher); at 0.9 the horse's fore hoof in the canter
#: no longer tucked behind the cannon's line, at 0.85 nor in the gallops.
FOLD_SKEW = 0.93
#: A swinging foot's toes curl by this many radians per unit of its fold (the
#: posing's toe pitch: positive lifts the toes).
TOE_PER_FOLD = 0.5
#: A foot that rolls over its toe tip by lift-off (``reach.roll``, the character
#: file's ``toe_roll_deg``) starts to lift its heel after this fraction of its
#: stance, its pitch growing as the square of the time since (so the joint leaves
#: the ground already rising: eased out to rest at lift-off, it stopped there
#: and the leg snapped straight in the swing's first frame, the leopard's canter
#: elbow at 2,368 deg/s).
ROLL_FROM = 0.4
#: ... in gaits of duty factor up to this; none at all where no foot lifts
#: (``1 - MIN_SWING``: standing), faded out in between, so a character that
#: stops comes onto flat feet (it stood on tiptoe, its heels 38-46 mm up).
ROLL_DUTY = 0.8
#: A planted foot's load (:func:`stance_load`) takes the duty factor as at least this.
MIN_LOAD_DUTY = 0.1


@plan_inner
def stance_duty(duty, landed_in, stopping):
    """The duty factor a planted foot lifts at: the gait's ``duty`` now, but no later
    than the gait it landed in (``landed_in``) would have it, unless the body is
    ``stopping`` (its feet then stay down). Slowing into the walk, a foot planted in
    the trot stayed down for the walk's longer stance, and the body slowed below the
    walk's speed to keep it in reach (to 0.30-0.55 of it), its feet landing moving."""
    return duty if stopping else min(duty, landed_in)


@plan_inner
def toe_pitch(p, roll, duty):
    """A planted foot's pitch, toes down (rad), ``p`` (0 to 1) into its stance in a
    gait of duty factor ``duty``: none until :data:`ROLL_FROM`, then ``roll`` times
    the square of the share of the rest of the stance gone by (faded out from
    :data:`ROLL_DUTY` to ``1 - MIN_SWING``)."""
    fade = min(max((1.0 - MIN_SWING - duty) / (1.0 - MIN_SWING - ROLL_DUTY), 0.0), 1.0)
    if roll <= 0.0 or p <= ROLL_FROM or fade <= 0.0:
        return 0.0
    e = min((p - ROLL_FROM) / (1.0 - ROLL_FROM), 1.0)
    return fade * roll * e * e


@plan_inner
def stance_load(p, duty):
    """A planted foot's load over the body's weight, ``p`` (0 to 1) into its stance
    in a gait of duty factor ``duty``: ``sin^2(pi p)`` times ``pi / (8 duty)``, the
    peak of a half sine of force over the stance that carries a quarter of the
    weight over a stride (a walk's 0.65, a trot's 1.0, a gallop's 1.6). Its rate
    starts and ends at zero, so a digit sunk under it (``[locomotion]
    fetlock_sink_deg``) turns smoothly from the swing's pose and back to it."""
    s = math.sin(math.pi * min(max(p, 0.0), 1.0))
    return math.pi / (8.0 * max(duty, MIN_LOAD_DUTY)) * s * s


@plan_inner
def pivot_on_toe(feet, n, i, x, y, z, yaw, toe, a):
    """Put foot ``i``'s joint of row ``n`` into ``feet`` (N, 4, 3) where it is with
    the foot standing level at (``x``, ``y``, ``z``) (m) facing world yaw ``yaw``
    (rad), then pitched toes down by ``a`` (rad) about its toe tip (``toe[n, i]``:
    forward and up from the joint, m): the toe tip stays where it was, the heel
    (the joint) rises."""
    f, u = toe[n, i, 0], toe[n, i, 1]
    c, s = math.cos(a), math.sin(a)
    ahead = f * (1.0 - c) - u * s
    feet[n, i, 0] = x + ahead * math.sin(yaw)
    feet[n, i, 1] = y + u * (1.0 - c) + f * s
    feet[n, i, 2] = z + ahead * math.cos(yaw)


@plan_inner
def feet_rows(state, scratch, reach, sc, out):
    """Stage 5 of the step for N rows: lift-off and touchdown, swing
    progress, touchdown targets on the turning arc and swing paths.

    Parameters
    ----------
    state : PlanState
        Reads the phases ``cpg.theta`` (after this step's CPG update),
        ``cpg.freq``, the speed and turn rate, the duty factor and swing
        height and bound of ``schedule.params``; updates ``feet`` in place.
    scratch : StepScratch
        ``theta_prev``, the key points, ``final_duty``, ``trailing`` and
        ``half_min`` of this step.
    reach : ReachTables
        ``foot_offset``.
    sc : StepConstants
        ``reach_margin`` and ``dt``.
    out : PlanOutputs
        Receives ``feet`` (N, 4, 3) foot positions (m), ``fold`` (N, 4) and the
        planted feet's ``load`` (N, 4) (:func:`stance_load`).
    """
    theta, freq = state.cpg.theta, state.cpg.freq
    v, yaw_rate = state.motion.speed, state.motion.yaw_rate
    ft = state.feet
    stance, swing_s, theta_lo, theta_td = ft.stance, ft.swing_s, ft.theta_lo, ft.theta_td
    planted, liftoff = ft.planted, ft.liftoff
    keys, key_heading = scratch.keys, scratch.key_heading
    foot_offset = reach.foot_offset
    feet, fold = out.feet, out.fold
    for n in range(theta.shape[0]):
        dn = state.schedule.params.duty[n]
        stopping = scratch.final_duty[n] > 1.0 - MIN_SWING  # entering the standing state
        stance_time = max(dn, min(scratch.final_duty[n], 1.0 - MIN_SWING)) / freq[n]
        omega = TWO_PI * freq[n]
        for i in range(4):
            th = theta[n, i]
            if stance[n, i]:
                u = frac(th / TWO_PI)
                d_own = stance_duty(dn, ft.duty_td[n, i], stopping)
                due = d_own <= u <= 1.0 - MIN_SWING
                if (due or scratch.trailing[n, i]) and th - theta_td[n, i] > MIN_STANCE_PHASE:
                    stance[n, i] = False
                    # it leaves from where its heel has rolled to, its toe tip last
                    a = toe_pitch((th - theta_td[n, i]) / (TWO_PI * d_own), reach.roll[n, i],
                                  d_own)
                    ft.toe_lo[n, i] = a
                    pivot_on_toe(liftoff, n, i, planted[n, i, 0], planted[n, i, 1],
                                 planted[n, i, 2], ft.yaw[n, i], reach.toe, a)
                    ft.yaw_lo[n, i] = ft.yaw[n, i]
                    cross = TWO_PI * (math.floor(th / TWO_PI) + d_own)
                    theta_lo[n, i] = cross if due and cross > scratch.theta_prev[n, i] else th
                    td = TWO_PI * (math.floor(th / TWO_PI) + 1.0)
                    if td - th < TWO_PI * MIN_SWING:
                        td += TWO_PI
                    theta_td[n, i] = td
                    swing_s[n, i] = 0.0
            if not stance[n, i]:
                sp = min(max((th - theta_lo[n, i]) / (theta_td[n, i] - theta_lo[n, i]), 0.0),
                         1.0)
                swing_s[n, i] = max(swing_s[n, i], sp)
        fast = fast_share(dn, state.schedule.params.bound[n])  # the fast gaits' swing path
        walk = walk_share(dn)  # and the walk's
        bounding = bound_share(dn, state.schedule.params.bound[n])  # and the bounding gaits'
        # the swinging feet's reach hold, closer in the gallops
        galloping = bounding * min(max(
            (HOLD_DUTY[0] - dn) / (HOLD_DUTY[0] - HOLD_DUTY[1]), 0.0), 1.0)
        hold = SWING_REACH + galloping * (SWING_REACH_BOUND - SWING_REACH)
        rounding = bounding * min(max(
            (ROUNDING_DUTY[0] - dn) / (ROUNDING_DUTY[0] - ROUNDING_DUTY[1]), 0.0), 1.0)
        lead = min(LEAD_STANCE_FRACTION * stance_time,
                   sc.reach_margin * scratch.half_min[n] / max(v[n], MIN_LEAD_SPEED))
        for i in range(4):
            fold[n, i] = 0.0
            out.load[n, i] = 0.0
            scratch.td_tau[n, i] = -1.0
            if stance[n, i]:  # a planted foot keeps its place and the yaw it landed with,
                # its toe tip put while the heel lifts, its digit sinking under the load
                d_own = stance_duty(dn, ft.duty_td[n, i], stopping)
                p = (theta[n, i] - theta_td[n, i]) / (TWO_PI * d_own)
                a = toe_pitch(p, reach.roll[n, i], d_own)
                out.load[n, i] = stance_load(p, d_own)
                out.toe[n, i] = -a  # (the posing's toe pitch lifts the toes)
                pivot_on_toe(feet, n, i, planted[n, i, 0], planted[n, i, 1], planted[n, i, 2],
                             ft.yaw[n, i], reach.toe, a)
                continue
            # a swinging foot turns from its lift-off yaw to the body's (the fore feet's
            # with the spine's yaw), eased in over the swing: it lands with the body's
            want = state.motion.heading[n] + (state.motion.bend[n] if i < 2 else 0.0)
            x = swing_s[n, i]
            turn = (want - ft.yaw_lo[n, i] + math.pi) % TWO_PI - math.pi
            ft.yaw[n, i] = ft.yaw_lo[n, i] + x * x * (3.0 - 2.0 * x) * turn
            g = 1 if i < 2 else 0  # the fore legs follow the fore key point
            # time to the planned touchdown, negative on the frame that lands
            # past it, so the touchdown point stands still in the world under
            # a steady command (clamped at the planned instant, it moved
            # ahead with the body on the landing frame: the foot skidded onto
            # the ground at 0.7-0.9 of the body's speed); plus the lead, and
            # the half frame by which a foot lands, on average, after its
            # planned instant (so the stance sits where it would at any frame
            # rate)
            # (at the leg's own phase rate this step: re-phasing through a gait change
            # its oscillator may run faster or slower than the clock, and timed by the
            # clock the touchdown point moved back by up to 15 mm on the landing frame)
            rate = omega if sc.dt <= 0.0 else max(
                (theta[n, i] - scratch.theta_prev[n, i]) / sc.dt, 0.5 * omega)
            back = 0.0 if g else HIND_LEAD_CUT * bounding * stance_time
            tau = max((theta_td[n, i] - theta[n, i]) / rate + lead - back + 0.5 * sc.dt, 0.0)
            dx, dz, kh = arc_step(key_heading[n, g], v[n], yaw_rate[n], tau)
            cs, sn = math.cos(kh), math.sin(kh)
            ox, oz = foot_offset[n, i, 0], foot_offset[n, i, 2]
            tx = (keys[n, g, 0] + dx) + (cs * ox + sn * oz)
            tz = (keys[n, g, 2] + dz) + (-sn * ox + cs * oz)
            ax, ay, az = liftoff[n, i, 0], liftoff[n, i, 1], liftoff[n, i, 2]
            ddx, ddy, ddz = tx - ax, 0.0 - ay, tz - az
            step_len = math.sqrt(ddx * ddx + ddy * ddy + ddz * ddz)
            hs = state.schedule.params.swing_height[n]
            # over the ground: the path's chord rises from the lift-off point, by half
            # its height at mid-swing, which the clearance need not add to (a heel
            # risen 40 mm at a hoof's rolled lift-off flexed the horse's stifle in the
            # gallop's swing to 73 degrees, past its 70)
            height = max(min(hs, CLEARANCE_PER_STEP * step_len + CLEARANCE_BASE * hs)
                         - 0.5 * ay, 0.0)
            s = swing_s[n, i]
            if s >= 1.0 - TOUCHDOWN_EPS:  # touchdown, flat
                planted[n, i, 0], planted[n, i, 1], planted[n, i, 2] = tx, 0.0, tz
                feet[n, i, 0], feet[n, i, 1], feet[n, i, 2] = tx, 0.0, tz
                out.toe[n, i] = 0.0
                stance[n, i] = True
                ft.duty_td[n, i] = dn
                continue
            # the foot's pitch turns from its lift-off roll back to level over the
            # swing, plus the swing's curl
            x = 1.0 - s
            out.toe[n, i] = TOE_PER_FOLD * math.sin(math.pi * s) ** 2 \
                - ft.toe_lo[n, i] * x * x * (3.0 - 2.0 * x)
            swing_into((ax, ay, az), (tx, 0.0, tz), height, s, fast, walk, bounding, feet,
                       n, i)
            # how far the touchdown point will be from the leg's top joint then
            # (the body stage lowers the trunk ahead of a landing out of its reach)
            t_td = max((theta_td[n, i] - theta[n, i]) / rate, 0.0)
            kx, kz, kh1 = arc_step(key_heading[n, g], v[n], yaw_rate[n], t_td)
            c1, s1 = math.cos(kh1), math.sin(kh1)
            ux = tx - (keys[n, g, 0] + kx + c1 * ox + s1 * reach.top_ahead[n, i])
            uz = tz - (keys[n, g, 2] + kz - s1 * ox + c1 * reach.top_ahead[n, i])
            scratch.td_tau[n, i] = t_td
            scratch.td_reach2[n, i] = ux * ux + uz * uz
            fold[n, i] = math.sin(math.pi * s ** FOLD_SKEW) ** 2
            # within reach of the leg's top (where the body left it last step)
            oz = reach.top_ahead[n, i]
            px = keys[n, g, 0] + cs * ox + sn * oz
            pz = keys[n, g, 2] - sn * ox + cs * oz
            py = reach.top_height[n, i] * (1.0 - state.body.drops_now[n, g]) \
                + state.body.rise[n, g] + reach.flex_lift[n, i] * state.body.spine_smooth[n]
            rx, ry, rz = feet[n, i, 0] - px, feet[n, i, 1] - py, feet[n, i, 2] - pz
            r = math.sqrt(rx * rx + ry * ry + rz * rz)
            rmax = hold * reach.radius[n, i]
            e = min(s / HOLD_ROUNDING_FROM, 1.0)
            held = smooth_min(r, rmax, HOLD_ROUNDING * rounding * rmax * e * e * (3.0 - 2.0 * e))
            if held < r:
                w = 1.0 if s <= REACH_HOLD_UNTIL else max(
                    1.0 - (s - REACH_HOLD_UNTIL) / (1.0 - REACH_HOLD_UNTIL), 0.0)
                k = 1.0 - w * (1.0 - held / r)
                feet[n, i, 0] = px + rx * k
                feet[n, i, 1] = py + ry * k
                feet[n, i, 2] = pz + rz * k
