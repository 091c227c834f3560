"""The body stage of the plan, compiled: spine, height, pitch, sway and tail.

The spine bends by the concave/convex machine in the bounding gaits and
compresses and stretches with its oscillator in the others
(:mod:`quadsim.locomotion.spine`); the body bobs with the support and each
girdle drops as far as its planted feet need to stay in reach (vaulting
over them), which pitches the body; each girdle sways after its feet and
the tail lags behind. Units are SI (m, s, rad); legs LF, RF, LH, RH.
"""

from __future__ import annotations

import math

from quadsim.frames import GRAVITY
from quadsim.locomotion.cpg import TWO_PI
from quadsim.locomotion.rowmath import (
    ahead_of_mid,
    frac,
    interp_leg,
    plan_inline,
    plan_inner,
    smooth_min,
)
from quadsim.locomotion.spine import flex_of, rate_step, state_of, target_of

#: The bounding spine turns from one target to the other in 1 / (this many
#: strides): its rate is this times the target difference times the stride
#: frequency.
SPINE_RATE_PER_STRIDE = 5.0
#: Vertical bob of the body: this fraction of the gait's drop (of the hip
#: height), high with two feet down and low with none.
BOB_FRACTION = 0.6
#: Girdle sway: this fraction of the angle of the line between the left and
#: right feet.
SWAY_GAIN = 0.1
#: Tail pitch: this fraction of the spine's pitch, less this much per m/s
#: of speed (rad), spread over the tail joints.
TAIL_PITCH_FROM_SPINE = 0.6
TAIL_PITCH_PER_SPEED = 0.02
#: Tail yaw: this fraction of the spine's bend and of the hind girdle's sway,
#: against them.
TAIL_YAW_FROM_BEND = -0.8
TAIL_YAW_FROM_SWAY = -0.5
#: Narrowest stance width (m) the sway is measured over.
MIN_STANCE_WIDTH = 1e-3
#: Least duty factor the support measure divides by.
MIN_DUTY = 1e-3
#: The trunk's vertical motion: its centre is a mass the legs hold up. A
#: stance leg pushes with a half sine over its stance whose impulse carries a
#: quarter of the weight over a stride (``g T / 4``), the centre falls at
#: ``g`` while no foot is down -- every flight is ballistic -- and, only while
#: a foot is down, a weak spring and damper (natural frequency this fraction
#: of the stride frequency, damping ratio below) keep it about its held level
#: (:data:`HEAVE_REST_SHARE`). Where a girdle's planted feet cap its rise (below), the centre is
#: held down to the capped rise (its rate kept): at lift-off the trunk goes
#: on from where the legs held it (it jumped up by the whole cap in one frame
#: when only the drawn height was capped: 35-40 mm at the leopard trot's
#: shoulders, then 44 mm down at the next touchdown).
HEAVE_HOLD_PER_STRIDE = 0.35
HEAVE_DAMPING = 0.8
#: The centre's rise is at most this fraction of the hip height either way.
MAX_HEAVE = 0.2
#: The spring's rest follows the level the centre is held at, over this many
#: strides, and this fraction of the way from the standing height (a quarter of
#: the pull back to standing is kept) -- in the gaits
#: that do not bound, by ``1 - bound`` (the canter's and gallops' stay about the
#: standing height: adapted too, the horse's gallops turned their stifles at
#: 2,269 and 2,362 deg/s, from 2,025 and 1,967). Held about the standing height
#: while the planted and landing legs' reach kept it under it (the horse's trot
#: 0.12-0.15 m), the spring pushed the trunk up through every stance (0.14 g)
#: and the landing guidance pulled it back down before the flight: the trot's
#: trunk was highest late in the stance and dipped at take-off, where a trotting
#: body is lowest at mid-stance and highest in flight (the leopard's, dog's and
#: horse's trot now highest at 0.83-0.87 of the half stride, mid-flight 0.875,
#: from 0.41-0.58, the flight beginning at 0.75). At the whole way, the cats' and
#: dog's paces rocked 1.8-2.2 degrees (2.8-3.2 before), the horse's hind fetlocks
#: straight in 21-26 % of swing frames (6 %; 14-18 % now).
HEAVE_REST_STRIDES = 1.0
HEAVE_REST_SHARE = 0.75
#: The trunk's pitch: the fore legs' pushes lift the nose and the hind legs'
#: the tail, this much per m/s^2 of push over the body length (rad/s^2 per
#: (m/s^2 / m)); a spring and damper (natural frequency this fraction of the
#: stride frequency, damping ratio below) return it to level. The
#: diagonal pairs of the trot push fore and hind alike and barely rock it;
#: the canter and gallops, fore and hind in turn, rock it nose-up and
#: nose-down.
PITCH_TORQUE = 1.2
PITCH_HOLD_PER_STRIDE = 0.6
PITCH_DAMPING = 0.5
#: In flight (no foot down) the spring and damper hold the pitch by this fraction
#: of their strength: nothing but the trunk's own stiffness turns it back to level
#: (at full strength the horse's gallops, their trunks turning nose-down about the
#: centre in flight, fell at 0.70 g, the pelvis at 0.3 and the withers at 1.1; with
#: none, the cubs' and dog's canters at up to 1.32 g).
FLIGHT_PITCH_HOLD = 0.5
#: The flexing gaits (walk, trot, pace) rock by this fraction of it.
FLEX_ROCK = 0.4
#: The rocking is at most this (rad) either way.
MAX_ROCK = 0.35
#: In the flexing gaits (walk, trot, pace) the trunk also pitches by this
#: fraction of the spine's compress/stretch angle.
PITCH_FROM_FLEX = 0.16


#: A planted foot is kept within this fraction of its leg's reach ...
STANCE_REACH = 0.97
#: ... from this fraction at its touchdown, eased down (as the square of the time
#: left) over this long (s): the landing leg gives under the body, which no longer
#: drops onto it in one frame (the horse, landing out of a long flight in a
#: rotary gallop -> trot, dropped its pelvis 78 mm in one frame, 35 g; now 52 mm;
#: the leopard's rotary gallop's peak joint speed 2,341 -> 2,106 deg/s). Guided
#: onto the landing at this reach too, the girdles came down later and the horse's
#: change dropped 78 mm again.
LANDING_REACH = 0.99
LANDING_EASE = 0.05
#: Landings in the flexing gaits: a swinging foot's touchdown point caps its
#: girdle ahead of the landing, by the cap it will set then (:func:`_reach_cap`)
#: raised by half this acceleration (m/s^2) times the square of the time left.
#: A girdle held under it comes down onto the cap with its descent slowing at
#: this rate, level at touchdown: on the landing frame it had dropped by the
#: whole difference instead (30-110 mm; the pelvis's or withers' jolt 7-43 g in
#: walk, trot and pace).
LAND_ACCEL = 0.5 * GRAVITY
#: ... in the gaits that do not bound, this (weighted by ``1 - bound``; the
#: bounding gaits' fore guidance keeps :data:`LAND_ACCEL`), reckoned from where
#: the girdle is drawn: its base height lags the drops' target (the drops are
#: filtered once more for a smooth base), and reckoned from the target the caps let
#: a girdle up as a landing foot's drop came in, a frame before its base came down
#: (the horse's rack: the pelvis 6 mm up, then 10 mm down, 6.0 g). With the lag
#: reckoned at half a g, the trots met the guidance before their flights (the
#: horse's trunk highest in the flight in 70 % of its half strides); at 0.75 g in
#: all of them (81 % before; the leopard cub's in 86 %, 80 before), every horse
#: walk, trot, pace, amble and rack within 5 g (3.9-5.0; 4.2-6.0 before; 4.0-4.8 once
#: the amble and rack strode by Alexander's law), the cats' and the dog's within 4.7
#: (2.4-4.7; 2.2-4.4 before).
LAND_ACCEL_FREE = 0.75 * GRAVITY
#: Only the gaits that do not bound are so guided, and only while a foot is
#: down: the canter's and gallops' landings came out worse (the horse canter's
#: jolt 1.9 -> 9.8 g, its rotary gallop's peak joint speed 3,662 -> 4,663 deg/s),
#: and a flight held under the cap no longer fell ballistically (the horse
#: trot's flights at -0.15 g). Through a change between the two the guidance
#: comes in and goes out with the bound, weighted by ``1 - bound`` (switched on
#: at half of it, the cap dropped the horse's pelvis 206 mm in one frame of a
#: canter -> trot). In every gait, though, the fore girdle is guided while one
#: fore foot is planted (through a change weighted by the larger of ``bound`` and
#: ``1 - bound``): in the gallops the second fore foot lands a few frames
#: after the first, and the shoulders, vaulting up over the first, had risen out
#: of its reach: the leg locked straight before it landed and snapped bent on
#: the landing frame (the leopard's rotary gallop: the shoulders up 88 mm in
#: four frames, then 37 mm down in one, the elbow at 2,986 deg/s).
#: ... and no lower than a planted fore foot at this fraction of its leg's reach
#: allows: the fore girdle lowered further pitched the trunk nose-down over the
#: planted hind legs, whose stifles passed their limit (the horse's rack: 72
#: degrees against 70).
CROUCH_REACH = 0.86
#: A girdle meets the cap of its planted or landing feet rounded over this
#: fraction of the hip height (:func:`smooth_min`): its rate has no kink.
CAP_ROUNDING = 0.02
#: In the bounding gaits the fore girdle is also guided while a hind foot alone
#: is down, coming in over the last this fraction of a stride before its first
#: fore foot lands (smoothly: at full weight at once the shoulders dropped by the
#: whole difference on a hind landing frame, the gallops' jolts at 30-40 g).
#: Without it the shoulders, carried along by the trunk's rocking, met the landing
#: cap only on the fore landing frame: the horse's withers dropped 82 mm in one
#: frame of its transverse gallop and the landing elbow bent 55 degrees (3,308
#: deg/s; now 2,588). Over 0.15 of a stride the horse's rotary gallop kept 3,050,
#: over 0.4 the leopard cub's canter went 1,779 -> 2,288.
FORE_GUIDE_STRIDES = 0.25
#: In the gaits that do not bound the guidance comes back in over this fraction of
#: a stride after a flight, and before a girdle's own landing by the share of the
#: time gone since the flight ended (``since / (since + tau)``): switched fully on
#: at the first touchdown after a flight, the other girdle dropped onto its landing
#: cap in one frame (the horse's pelvis 123 mm slowing from a gallop to a walk,
#: 48 g). ``MAX_FOOTING`` (s) caps the time kept since the last flight.
FOOTING_STRIDES = 0.25
MAX_FOOTING = 10.0
#: ... and lowers a girdle by at most this many hip heights a second: a touchdown
#: point re-planned for the walk, its longer stance asked for in the middle of a
#: swing, moved its girdle's landing cap 72 mm in one frame, and a flight then
#: released it (52 g, now 24; the bounding fore guidance above is not so limited).
#: The swinging feet's vaulting drops (:func:`body_rows`) come in with the guidance,
#: over the last :data:`FORE_GUIDE_STRIDES` of a swing: on its landing frame a
#: foot's drop took the withers 26 mm down at once (the horse's walk, 8.6 g; now 3.5).
GUIDE_DESCENT = 1.0
#: In the gaits that do not bound, a girdle rising towards its ceiling (the cap of
#: its planted feet, and of its landing feet where guided) slows down before it,
#: decelerating by at most this (m/s^2) against the ceiling's own rate: met at full
#: speed, the girdle turned from rising to the ceiling's descent in one frame (a
#: trot's late stance, rising at 0.5-0.9 m/s into the guidance of the pair about to
#: land: the horse's trot and pace jolted at 7.6 and 6.5 g, the leopard's trot at
#: 6.8). Only a girdle still under its ceiling is braked, and through a change the
#: bound weakens it by ``1 - bound``.
CEILING_BRAKE = 2.0 * GRAVITY
#: A ceiling moving faster than this many hip heights a second has changed hands
#: (a foot landed or lifted, the guidance came in): no girdle is braked for that
#: (braked at once for a landing foot's new cap, the horse's walk dropped its
#: pelvis 170 mm in one frame).
CEILING_JUMP_RATE = 2.0
#: In the gaits that do not bound, a trunk leaving the ground takes its rocking
#: this fraction of the way to the tilt its girdles were held at (their rates
#: go on): a trot's fore girdle, held 16 mm under its hind one by the guidance
#: of the pair about to land, sprang up by that on the flight's first frame
#: (the leopard's trot, 6.8 g at the withers; 4.8 now). Taken all the way, the
#: dog cub's trot landed its hind knees at 2,005 deg/s (from 1,753; 1,914 now);
#: half of the way, the leopard's trot jolted at 5.5 g.
TAKE_OFF_TILT = 0.75


@plan_inline
def _leg_top(n, i, reach, dropped, flex, tilt):
    """Height (m) of leg ``i``'s top joint over the ground, of row ``n``: standing,
    less its girdle's drop ``dropped`` (m), raised by the spine's flexion ``flex``
    (rad) and the girdle's ``tilt`` (m)."""
    return reach.top_height[n, i] - dropped + reach.flex_lift[n, i] * flex + tilt


@plan_inner
def _reach_cap(n, g, left, right, ft, keys, c, sn, feet, reach, dropped, flex, tilt, theta,
               freq):
    """How far (m) girdle ``g`` of row ``n`` may rise over its dropped height
    (``dropped`` m below standing) with its planted feet ``left``, ``right``
    within :data:`STANCE_REACH` of their legs' reach (infinite with none
    planted): each leg's top over the ground point of its key and offsets,
    lifted by the spine's flexion ``flex`` (rad) and by ``tilt`` (m, the
    trunk's pitch with the flexion); ``ft`` is the feet state, ``c``, ``sn``
    the cosine and sine of the girdle's key heading; ``theta`` (N, 4) the legs'
    phases (rad) and ``freq`` the stride frequency (Hz), which give the time since
    each foot landed (:data:`LANDING_REACH`). Also the least rise that
    keeps them within :data:`CROUCH_REACH` (minus infinity with none planted):
    ``(cap, floor)``."""
    cap, floor = math.inf, -math.inf
    for i in (left, right):
        if not ft.stance[n, i]:
            continue
        fx, fz = feet[n, i, 0], feet[n, i, 2]
        ox, oz = reach.foot_offset[n, i, 0], reach.top_ahead[n, i]
        dx = fx - (keys[n, g, 0] + c * ox + sn * oz)
        dz = fz - (keys[n, g, 2] - sn * ox + c * oz)
        since = (theta[n, i] - ft.theta_td[n, i]) / (TWO_PI * freq)
        e = max(1.0 - since / LANDING_EASE, 0.0)
        r = (STANCE_REACH + (LANDING_REACH - STANCE_REACH) * e * e) * reach.radius[n, i]
        top = _leg_top(n, i, reach, dropped, flex, tilt)
        cap = min(cap, math.sqrt(max(r * r - dx * dx - dz * dz, 0.0)) - top)
        r = CROUCH_REACH * reach.radius[n, i]
        floor = max(floor, math.sqrt(max(r * r - dx * dx - dz * dz, 0.0)) - top)
    return cap, floor


@plan_inner
def _landing_cap(n, g, left, right, ft, scratch, reach, dropped, flex, tilt, accel):
    """How far (m) girdle ``g`` of row ``n`` may rise so that its swinging feet
    ``left``, ``right`` land within :data:`STANCE_REACH` of their legs' reach: the
    cap each touchdown point will set (its squared ground distance from the leg's
    top then, ``scratch.td_reach2``), raised by ``accel tau^2 / 2`` (m/s^2) for the
    time ``tau`` left to it (``scratch.td_tau``); infinite with none swinging.
    ``dropped``, ``flex`` and ``tilt`` as :func:`_reach_cap`."""
    cap = math.inf
    for i in (left, right):
        tau = scratch.td_tau[n, i]
        if ft.stance[n, i] or tau < 0.0:
            continue
        r = STANCE_REACH * reach.radius[n, i]
        high = math.sqrt(max(r * r - scratch.td_reach2[n, i], 0.0))
        top = _leg_top(n, i, reach, dropped, flex, tilt)
        cap = min(cap, high - top + 0.5 * accel * tau * tau)
    return cap


@plan_inner
def _ease(x):
    """``x`` clamped to [0, 1] and eased in and out (smoothstep): its rate is zero at
    both ends."""
    e = min(max(x, 0.0), 1.0)
    return e * e * (3.0 - 2.0 * e)


@plan_inner
def _landing_near(tau, freq):
    """How near (0 to 1) a touchdown ``tau`` s ahead is: 0 until the last
    :data:`FORE_GUIDE_STRIDES` of a stride (of frequency ``freq``, Hz) before it, rising
    linearly to 1 at it."""
    return min(max(1.0 - tau * freq / FORE_GUIDE_STRIDES, 0.0), 1.0)


@plan_inner
def _ballistic_excess(n, g, left, right, ft, scratch, reach, dropped, flex, tilt, rise, rate):
    """How far (m) girdle ``g`` of row ``n``, at ``rise`` and rising at ``rate``
    (m/s), would fly above the height its first landing foot (``left`` or
    ``right``) reaches at the whole of its leg's reach when it lands, falling at g
    until then, and the time to that landing (s); ``(0, tau)`` if not (``dropped``,
    ``flex``, ``tilt`` as :func:`_reach_cap`)."""
    tau, high, top = math.inf, 0.0, 0.0
    for i in (left, right):
        t = scratch.td_tau[n, i]
        if ft.stance[n, i] or t < 0.0 or t >= tau:
            continue
        r = reach.radius[n, i]
        tau = t
        high = math.sqrt(max(r * r - scratch.td_reach2[n, i], 0.0))
        top = _leg_top(n, i, reach, dropped, flex, tilt)
    if tau == math.inf or tau <= 0.0:
        return 0.0, tau
    return max(rise + rate * tau - 0.5 * GRAVITY * tau * tau - (high - top), 0.0), tau


@plan_inner
def _next_landing(n, td_tau, first):
    """Time (s) to the first touchdown of row ``n``'s swinging feet ``first`` and
    ``first + 1`` (``td_tau``, negative when planted); infinite with none swinging."""
    tau = math.inf
    for i in range(first, first + 2):
        if td_tau[n, i] >= 0.0:
            tau = min(tau, td_tau[n, i])
    return tau


@plan_inner
def _braked(rise, before, ceiling, ceiling_before, same_feet, free, h, dt):
    """A girdle's rise (m) this step: ``rise``, or lower if it comes up to its
    ``ceiling`` (m; ``ceiling_before`` a step ago, both infinite with none) from
    ``before`` (m) a step ago faster than :data:`CEILING_BRAKE` lets it, weakened by
    ``free`` (``1 - bound``; 0 leaves ``rise`` as it is); not braked when its planted
    feet changed (``same_feet`` false). ``h`` is the hip height (m), ``dt`` the step
    (s)."""
    if (free <= 0.0 or dt <= 0.0 or not same_feet or ceiling == math.inf
            or ceiling_before == math.inf):
        return rise
    moved = ceiling - ceiling_before
    room = ceiling - before
    if room <= 0.0 or abs(moved) >= CEILING_JUMP_RATE * h * dt:
        return rise
    return min(rise, before + moved + math.sqrt(2.0 * CEILING_BRAKE / free * room) * dt)


@plan_inner
def body_rows(body, state, scratch, reach, sc, out):
    """Stage 6 of the step for N rows: the spine's concave/convex machine
    and slow flexion, the bob and vaulting drops, body height and pitch,
    girdle sway and the lagging tail.

    Parameters
    ----------
    body : BodyConstants
    state : PlanState
        Reads the contacts, the phases, the blended gait parameters and the
        key points' source (``motion``); updates ``body`` in place.
    scratch : StepScratch
        This step's key points ``keys``, the cosines and sines of their
        headings ``key_cs`` (the path stage's), ``theta_prev``, the swinging
        feet's touchdowns ahead ``td_tau`` and ``td_reach2`` (the feet stage's);
        ``need``, ``lx`` and ``lz`` are worked in.
    reach : ReachTables
        ``drops``, ``sweep_cols`` and ``foot_offset``.
    sc : StepConstants
    out : PlanOutputs
        Reads ``feet`` and the stride fractions ``phase``; receives
        ``pitch`` (N,) and ``sway`` (N, 2) (hind, fore) (rad).
    """
    stance, u = state.feet.stance, out.phase
    params, bs = state.schedule.params, state.body
    keys, key_cs = scratch.keys, scratch.key_cs
    feet, sway = out.feet, out.sway
    dt = sc.dt
    need, lx, lz = scratch.need, scratch.lx, scratch.lz
    for n in range(stance.shape[0]):
        flexed, extended = body.spine_flexed[n], body.spine_extended[n]
        # the concave/convex machine: flexed while no hind foot is down
        tgt = target_of(state_of(stance[n, 0] or stance[n, 1], stance[n, 2] or stance[n, 3]),
                        flexed, extended)
        rate = SPINE_RATE_PER_STRIDE * abs(flexed - extended) * state.cpg.freq[n]
        bs.spine_angle[n] = rate_step(bs.spine_angle[n], tgt, rate, dt)
        slow = flex_of(state.cpg.theta_s[n], body.spine_slow_scale[n] * params.spine_amplitude[n])
        bound = params.bound[n]
        raw = bound * bs.spine_angle[n] + (1.0 - bound) * slow
        bs.spine_smooth[n] += (raw - bs.spine_smooth[n]) * sc.a_smooth
        sdut = max(params.duty[n], MIN_DUTY)
        support = 0.0
        for i in range(4):
            if stance[n, i]:
                support += math.sin(math.pi * min(max(u[n, i] / sdut, 0.0), 1.0))
        drop = params.drop[n]
        h = body.hip_height[n]
        bob = BOB_FRACTION * drop * h * (0.5 - support / 4) * (1.0 - bound)
        # the trunk's centre, pushed up by the legs' stances and falling at g
        # when free, and its rocking. A leg's push over the step is the
        # integral of its half sine between the stride fractions before and
        # after the step (exact, however few frames a stance spans).
        f = state.cpg.freq[n]
        dv_leg = GRAVITY / (8.0 * f)
        z, w = bs.heave, bs.heave_rate
        dv = -GRAVITY * dt
        fore_hind = 0.0
        held = False
        for i in range(4):
            held = held or stance[n, i]
            u1 = u[n, i]
            u0 = frac(scratch.theta_prev[n, i] / TWO_PI)
            c0 = math.cos(math.pi * min(u0 / sdut, 1.0))
            c1 = math.cos(math.pi * min(u1 / sdut, 1.0))
            push = dv_leg * (c0 - c1 if u0 <= u1 else c0 + 2.0 - c1)  # wrapped: a touchdown
            dv += push
            fore_hind += push if i < 2 else -push
        taking_off = not held and bs.footing[n] > 0.0 and bound < 1.0
        if taking_off:
            # leaving the ground, the trunk's rocking flies on (most of the way)
            # from where its girdles were held (TAKE_OFF_TILT; by ``1 - bound``
            # through a change)
            tilt = math.asin(min(max((bs.rise[n, 1] - bs.rise[n, 0]) / body.body_length[n],
                                     -1.0), 1.0))
            z[n, 1] += TAKE_OFF_TILT * (1.0 - bound) * (tilt - z[n, 1])
        if held:
            wn = 2.0 * math.pi * HEAVE_HOLD_PER_STRIDE * f
            dv -= (wn * wn * (z[n, 0] - bs.heave_rest[n])
                   + 2.0 * HEAVE_DAMPING * wn * w[n, 0]) * dt
        w[n, 0] += dv
        z[n, 0] = min(max(z[n, 0] + w[n, 0] * dt, -MAX_HEAVE * h), MAX_HEAVE * h)
        wp = 2.0 * math.pi * PITCH_HOLD_PER_STRIDE * f
        torque = PITCH_TORQUE * (bound + FLEX_ROCK * (1.0 - bound))
        hold = 1.0 if held else FLIGHT_PITCH_HOLD
        w[n, 1] += (torque * fore_hind / body.body_length[n]
                    - hold * (wp * wp * z[n, 1] + 2.0 * PITCH_DAMPING * wp * w[n, 1]) * dt)
        z[n, 1] = min(max(z[n, 1] + w[n, 1] * dt, -MAX_ROCK), MAX_ROCK)
        # vaulting: each girdle drops as far as its planted feet need (the
        # girdles' headings' cosines and sines taken once)
        c0, s0, c1, s1 = key_cs[n, 0, 0], key_cs[n, 0, 1], key_cs[n, 1, 0], key_cs[n, 1, 1]
        for i in range(4):
            g = 1 if i < 2 else 0
            c, sn = (c1, s1) if g else (c0, s0)
            along = ahead_of_mid(keys, reach.foot_offset, feet, n, i, c0, s0, c1, s1)
            need[n, i] = 0.0
            # (a swinging foot's comes in before it lands, in the gaits that do not bound)
            tau = scratch.td_tau[n, i]
            near = 1.0 if stance[n, i] else _ease((1.0 - bound) * _landing_near(tau, f)) \
                if tau >= 0.0 and held else 0.0
            if near > 0.0:  # np.interp(x, sweep_cols[n, i], drops)
                need[n, i] = near * interp_leg(abs(along) / sc.reach_margin, reach.drops,
                                               reach.sweep_cols, n, i)
            # the foot in its girdle's frame, for the sway: turned by -heading,
            # whose cosine is c and sine -sn
            fx, fz = feet[n, i, 0] - keys[n, g, 0], feet[n, i, 2] - keys[n, g, 2]
            lx[n, i] = c * fx - sn * fz
            lz[n, i] = sn * fx + c * fz
        dh = max(drop, max(need[n, 2], need[n, 3]))
        df = max(drop, max(need[n, 0], need[n, 1]))
        drops_now = bs.drops_now
        drops_now[n, 0] += (dh - drops_now[n, 0]) * sc.a_drop
        drops_now[n, 1] += (df - drops_now[n, 1]) * sc.a_drop
        pelvis = body.pelvis_height[n]
        target_h = pelvis * (1.0 - drops_now[n, 0]) + bob
        bs.base_height[n] += (target_h - bs.base_height[n]) * sc.a_drop
        # the rises about the trunk's centre, their difference scaled; a
        # girdle rises no higher than its planted feet reach
        mid = z[n, 0]
        half = 0.5 * body.body_length[n] * math.sin(z[n, 1])
        flex = bs.spine_smooth[n]
        # the pitch with the spine's flexion turns the trunk about the pelvis;
        # the nose-up part lifts the shoulders off planted fore feet: the cap
        # holds them down by it (an adopted fox, whose fore legs stand
        # straight, lifted its left fore foot off the ground late in every
        # trot stance, its shoulders 20 mm higher than the cap allowed for)
        flexing = (1.0 - bound) * PITCH_FROM_FLEX * slow
        tilt_f = -body.body_length[n] * math.sin(min(flexing, 0.0))
        dropped_h, dropped_f = pelvis * drops_now[n, 0], pelvis * drops_now[n, 1]
        # and no higher than its landing feet will let it be (LAND_ACCEL), the
        # fore girdle no lower for it than its planted feet allow (CROUCH_REACH)
        # (after a flight the guidance comes in over FOOTING_STRIDES of a stride)
        since = min(bs.footing[n] + dt, MAX_FOOTING) if held else 0.0
        bs.footing[n] = since
        footing = _ease(since * f / FOOTING_STRIDES)
        tau_h = _next_landing(n, scratch.td_tau, 2)
        tau_f = _next_landing(n, scratch.td_tau, 0)
        prog_h = since / (since + tau_h) if since > 0.0 else 0.0
        prog_f = since / (since + tau_f) if since > 0.0 else 0.0
        guided = (1.0 - bound) * max(footing, prog_h)
        guided_f = (1.0 - bound) * max(footing, prog_f)
        if stance[n, 0] or stance[n, 1]:
            bounding_f = bound
        else:
            bounding_f = bound * min(_ease(_landing_near(tau_f, f)), prog_f)
        theta = state.cpg.theta
        cap_h, _ = _reach_cap(n, 0, 2, 3, state.feet, keys, c0, s0, feet, reach, dropped_h,
                              flex, 0.0, theta, f)
        cap_f, floor_f = _reach_cap(n, 1, 0, 1, state.feet, keys, c1, s1, feet, reach,
                                    dropped_f, flex, tilt_f, theta, f)
        rise_h = min(mid - half, cap_h)
        rise_f = min(mid + half, cap_f)
        ceil_h, ceil_f = cap_h, cap_f
        if guided > 0.0 or guided_f > 0.0 or bounding_f > 0.0:
            lag = (1.0 - bound) * (bs.base_height[n] - target_h)
            accel = LAND_ACCEL + (1.0 - bound) * (LAND_ACCEL_FREE - LAND_ACCEL)
            land_h = _landing_cap(n, 0, 2, 3, state.feet, scratch, reach, dropped_h - lag, flex,
                                  0.0, accel)
            land_f = max(floor_f, _landing_cap(n, 1, 0, 1, state.feet, scratch, reach,
                                               dropped_f - lag, flex, tilt_f, accel))
            step = GUIDE_DESCENT * h * dt
            over_h, over_f = max(rise_h - land_h, 0.0), max(rise_f - land_f, 0.0)
            if guided > 0.0:
                ceil_h = min(ceil_h, max(land_h + (1.0 - guided) * over_h, bs.rise[n, 0] - step))
            if guided_f > 0.0:
                ceil_f = min(ceil_f, max(land_f + (1.0 - guided_f) * over_f, bs.rise[n, 1] - step))
            if bounding_f > 0.0:
                ceil_f = min(ceil_f, land_f + (1.0 - bounding_f) * over_f)
            rise_h = min(rise_h, max(rise_h - guided * over_h, bs.rise[n, 0] - step))
            rise_f = min(rise_f, max(rise_f - guided_f * over_f, bs.rise[n, 1] - step),
                         rise_f - bounding_f * over_f)
        if taking_off:
            # a trunk leaving the ground rises no faster than lets it come down within
            # the whole reach of its first landing feet, falling at g (by ``1 - bound``):
            # launched by a change's gallop-like pushes, the horse's rotary gallop ->
            # trot flew 45 mm above its landing hind foot's reach and dropped onto it
            # (a stifle at 1,992 deg/s; 2,360-2,387 with the lag reckoned above)
            spin = 0.5 * body.body_length[n] * math.cos(z[n, 1]) * w[n, 1]
            ex_h, t_h = _ballistic_excess(n, 0, 2, 3, state.feet, scratch, reach, dropped_h,
                                          flex, 0.0, rise_h, w[n, 0] - spin)
            ex_f, t_f = _ballistic_excess(n, 1, 0, 1, state.feet, scratch, reach, dropped_f,
                                          flex, tilt_f, rise_f, w[n, 0] + spin)
            cut = max(ex_h / t_h if ex_h > 0.0 else 0.0, ex_f / t_f if ex_f > 0.0 else 0.0)
            w[n, 0] -= (1.0 - bound) * min(cut, max(w[n, 0], 0.0))
        if rise_h < mid - half or rise_f < mid + half:
            # the planted legs hold the trunk down: its centre is where they let it
            # be (it would jump up by the whole cap at lift-off); its rate goes on
            z[n, 0] = 0.5 * (rise_h + rise_f)
        # each girdle meets its cap rounded (a kink in its rate is a jolt)
        rounding = CAP_ROUNDING * h
        rise_h = smooth_min(mid - half, rise_h, rounding)
        rise_f = smooth_min(mid + half, rise_f, rounding)
        # and comes up to its ceiling no faster than it can stop under it
        planted_h = 1.0 * stance[n, 2] + 2.0 * stance[n, 3]
        planted_f = 1.0 * stance[n, 0] + 2.0 * stance[n, 1]
        rise_h = _braked(rise_h, bs.rise[n, 0], ceil_h, bs.ceiling[n, 0],
                         planted_h == bs.ceiling_feet[n, 0], 1.0 - bound, h, dt)
        rise_f = _braked(rise_f, bs.rise[n, 1], ceil_f, bs.ceiling[n, 1],
                         planted_f == bs.ceiling_feet[n, 1], 1.0 - bound, h, dt)
        bs.ceiling[n, 0], bs.ceiling[n, 1] = ceil_h, ceil_f
        bs.ceiling_feet[n, 0], bs.ceiling_feet[n, 1] = planted_h, planted_f
        if held:  # the spring's rest follows the level the centre is held at
            bs.heave_rest[n] += ((1.0 - bound) * HEAVE_REST_SHARE * z[n, 0]
                                 - bs.heave_rest[n]) * min(dt * f / HEAVE_REST_STRIDES, 1.0)
        bs.height[n] = bs.base_height[n] + rise_h
        bs.rise[n, 0] = rise_h
        bs.rise[n, 1] = rise_f
        # (a positive pitch tips the nose down)
        out.pitch[n] = math.atan2((drops_now[n, 1] - drops_now[n, 0]) * pelvis
                                  - (rise_f - rise_h), body.body_length[n]) + flexing
        # girdle sway from where the left and right feet are
        for g, (left, right) in enumerate(((2, 3), (0, 1))):  # hind, fore
            width = max(abs(lx[n, left] - lx[n, right]), MIN_STANCE_WIDTH)
            sway[n, g] = min(max(SWAY_GAIN * math.atan2(lz[n, left] - lz[n, right], width),
                                 -sc.max_sway), sc.max_sway)
        # tail: each joint follows the one before with a lag
        nt = body.n_tail[n]
        p0 = (TAIL_PITCH_FROM_SPINE * bs.spine_smooth[n]
              - TAIL_PITCH_PER_SPEED * state.motion.speed[n]) / nt
        p1 = (TAIL_YAW_FROM_BEND * state.motion.bend[n] + TAIL_YAW_FROM_SWAY * sway[n, 0]) / nt
        tail = bs.tail
        for k in range(tail.shape[1]):
            t0, t1 = tail[n, k, 0], tail[n, k, 1]
            tail[n, k, 0] = t0 + sc.a_tail * (p0 - t0)
            tail[n, k, 1] = t1 + sc.a_tail * (p1 - t1)
            p0, p1 = t0, t1
