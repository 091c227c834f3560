"""Gait transitions by asynchronous time warping (the seed's equations 3-10).

Each clip is played in *generic time*: a fraction of its cycle, ``t`` in
cycles, the pose at ``t`` being the clip's frame ``t L`` (L frames per cycle,
looped, slerp between frames). A transition from clip M1 (L1 frames) to M2
(L2 frames) lasts 2.5 cycles of generic time,

    sum_{i=1..B} w1(i)/L1 + w2(i)/L2 = 2.5,  w1 = 1 - i/B,  w2 = i/B,
    B = (5 L1 L2 + L2 - L1) / (L1 + L2) frames                 (equation 3)

The reference leg (LH) advances by ``dt*(i) = w1(i)/L1 + w2(i)/L2``
(equation 4), ``sigma* = sum dt*`` (equation 5). Each leg j starts in M2 at
the same place of its own stride as it is in M1 (its phase since its
touchdown), and must end at the end posture ``M2(t2*(0) + sigma*)``: it has
``sigma_j`` of generic time to cover, and advances by
``dt_j(i) = dt*(i) sigma_j / sigma*`` (equation 6), in both clips
(equations 8, 9). Each leg's joints blend its M1 and M2 postures at its own
times (equation 7, slerp with weight w2); the body joints (spine, neck, head,
tail) blend the body postures of both clips at the four legs' times
(equation 10, a normalised quaternion mean). The root's height blends like
the body; it is moved forward by the landing feet (equation 11,
:mod:`quadsim.horse.root`), or at the blended speed ``w1 v1 + w2 v2``.

Stance alignment (our addition). Equations 8-9 keep each leg at the same
phase since its touchdown in both clips, but the gaits' duty factors differ
(walk 0.7, gallop 0.25): half-way through the blend a leg would mix a late
stance pose of M1 (leg swept back, foot down) with a swing pose of M2 (leg
reaching forward), and the slerp of the two passes the leg through the
vertical, the foot 0.1 m into the ground. So each leg's stance length blends
too, ``d = w1 duty1 + w2 duty2``, and both clips are sampled at the leg's
phase re-timed (:func:`stance_aligned_times`) so that the leg is down in both
for the first ``d`` of its cycle and up in both for the rest; with ``w2 = 0``
(``= 1``) M1 (M2) plays unchanged. The leg's planned contacts follow.

Feet on the ground (our addition to equation 11). The mean slip of
equation 11 holds the average stance foot, not each one: the legs run at
their own rates, so each stance foot still slips under the body (5-17 cm
over a contact before this step, see ``tools/horse_transition_table.py``).
:func:`transition_motion` holds every planned contact where the foot lands
(:func:`~quadsim.horse.legs.stance_targets`, anchor at touchdown; the swing
joins the held place over :data:`PIN_RAMP` frames), lowers the root smoothly
where a held foot is out of its leg's reach
(:func:`~quadsim.horse.legs.reach_drop`), poses the legs by IK, then
measures the contacts on the result and holds any the plan missed (a blended
foot may land a frame early).

:func:`synchronous_transition` is the baseline: every leg at the reference
leg's times, the whole pose slerped from M1 to M2, no stance alignment; its
feet are held by the same IK. :func:`quadsim.analysis.transitions.transition_quality`
measures a transition from its joint positions.
"""

from __future__ import annotations

import numpy as np

from ..kinematics.rotations import quaternion_slerp
from ..skeleton.contacts import foot_contacts
from ..skeleton.character import Character
from ..skeleton.motion import Motion
from .database import Clip, sample_frames

REFERENCE = 2  # LH
TRANSITION_CYCLES = 2.5
#: Frames over which a swing joins its held contact (see :func:`~quadsim.horse.legs.stance_targets`).
PIN_RAMP = 6


def blend_frames(L1: int, L2: int) -> int:
    """``B = (5 L1 L2 + L2 - L1) / (L1 + L2)``, rounded to whole frames."""
    return max(round((5 * L1 * L2 + L2 - L1) / (L1 + L2)), 1)


def sample_cycle(clip: Clip, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations (n, J, 4) and root heights (n,) at generic times ``t`` (cycles),
    the clip looped (its last frame blends into its first)."""
    m = clip.motion
    L = clip.frames
    f = (np.asarray(t, dtype=float) % 1.0) * L
    i0 = np.floor(f).astype(np.int64) % L
    i1 = (i0 + 1) % L
    root, q = sample_frames(m.root_positions, m.rotations, i0, i1, f - np.floor(f))
    return q, root[:, 1]


def _leg_joint_sets(character: Character) -> tuple[list[np.ndarray], np.ndarray]:
    legs = [np.asarray(leg.chain, dtype=int) for leg in character.legs]
    used = np.zeros(character.skeleton.n_joints, dtype=bool)
    for c in legs:
        used[c] = True
    return legs, np.nonzero(~used)[0]


def leg_times(clip1: Clip, clip2: Clip, t_start: float) -> dict:
    """Generic times of each leg through an asynchronous transition.

    Parameters
    ----------
    clip1, clip2 : Clip
    t_start : float
        Generic time of M1 (cycles) when the transition starts.

    Returns
    -------
    dict with ``B`` (frames), ``w2`` (B,), ``t1`` and ``t2`` (B, 4) each leg's
    generic times in M1 and M2 after frames 1..B, ``end`` (M2 generic time
    of the end posture) and ``sigma`` (4,), the legs' transition lengths.
    """
    L1, L2 = clip1.frames, clip2.frames
    B = blend_frames(L1, L2)
    i = np.arange(1, B + 1)
    w2 = i / B
    w1 = 1.0 - w2
    dstar = w1 / L1 + w2 / L2                     # equation 4
    sigma_star = float(dstar.sum())               # equation 5
    # each leg's phase since its touchdown, kept when it enters M2
    ph = t_start - clip1.touchdown / L1
    t1_0 = np.full(4, float(t_start))
    t2_0 = ph + clip2.touchdown / L2
    end = t2_0[REFERENCE] + sigma_star
    sigma = end - t2_0
    # the leg's nearest way to the end posture (whole cycles apart are the same place)
    sigma = sigma_star + ((sigma - sigma_star + 0.5) % 1.0 - 0.5)
    dj = dstar[:, None] * (sigma / sigma_star)[None, :]   # equation 6
    cum = np.cumsum(dj, axis=0)
    return {"B": B, "w2": w2, "t1": t1_0 + cum, "t2": t2_0 + cum, "end": end,
            "sigma": sigma, "sigma_star": sigma_star}


def leg_stance(clip: Clip) -> np.ndarray:
    """Each leg's contact in a clip's cycle: ``[on, off]`` (cycles), shape (4, 2).

    The first measured contact of each foot (:func:`~quadsim.horse.root.clip_stance_cycles`);
    NaN for a leg with no contact or more than one per cycle.
    """
    from .root import clip_stance_cycles

    out = np.full((4, 2), np.nan)
    for j, s in enumerate(clip_stance_cycles(clip)):
        if len(s) == 1:
            out[j] = s[0]
    return out


def stance_aligned_times(t: np.ndarray, on: float, duty: float, d: np.ndarray) -> np.ndarray:
    """A leg's generic times re-timed so that its stance lasts ``d`` of a cycle.

    The leg's phase since its touchdown ``phi = (t - on) mod 1`` is mapped
    piecewise linearly: ``[0, d]`` onto the clip's stance ``[0, duty]`` and
    ``[d, 1]`` onto its swing ``[duty, 1]``. With ``d = duty`` the times are
    unchanged.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Generic times (cycles).
    on, duty : float
        The clip's touchdown of this leg and its stance length (cycles).
    d : ndarray, shape (n,)
        Wanted stance length (cycles), in (0, 1).

    Returns
    -------
    ndarray, shape (n,)
        Generic times (cycles) to sample the clip at.
    """
    t = np.asarray(t, dtype=float)
    phi = (t - on) % 1.0
    g = np.where(phi < d, phi * duty / d, duty + (phi - d) * (1.0 - duty) / (1.0 - d))
    return t - phi + g


def _transition(character, clip1, clip2, t_start, synchronous: bool):
    lt = leg_times(clip1, clip2, t_start)
    B, w2 = lt["B"], lt["w2"]
    if synchronous:
        # every leg on the reference leg's times, in both clips
        t1 = np.repeat(lt["t1"][:, REFERENCE][:, None], 4, axis=1)
        t2 = np.repeat(lt["t2"][:, REFERENCE][:, None], 4, axis=1)
        stance = None
    else:
        t1, t2 = np.array(lt["t1"]), np.array(lt["t2"])
        # each leg's stance blends from its length in M1 to that in M2; both
        # clips are re-timed to it, so the leg is down (or up) in both at once
        s1, s2 = leg_stance(clip1), leg_stance(clip2)
        stance = np.zeros((B, 4), dtype=bool)
        for j in range(4):
            if np.isnan(s1[j]).any() or np.isnan(s2[j]).any():
                stance = None
                break
            du1, du2 = s1[j, 1] - s1[j, 0], s2[j, 1] - s2[j, 0]
            d = (1 - w2) * du1 + w2 * du2
            stance[:, j] = (t1[:, j] - s1[j, 0]) % 1.0 < d
            t1[:, j] = stance_aligned_times(t1[:, j], s1[j, 0], du1, d)
            t2[:, j] = stance_aligned_times(t2[:, j], s2[j, 0], du2, d)
        if stance is None:
            t1, t2 = lt["t1"], lt["t2"]
    legs, body = _leg_joint_sets(character)
    J = character.skeleton.n_joints
    rot = np.zeros((B, J, 4))
    h = np.zeros(B)
    qb1, qb2, hb = [], [], []
    for j in range(4):
        q1, h1 = sample_cycle(clip1, t1[:, j])
        q2, h2 = sample_cycle(clip2, t2[:, j])
        ch = legs[j]
        rot[:, ch] = quaternion_slerp(q1[:, ch], q2[:, ch],
                                      np.broadcast_to(w2[:, None], (B, len(ch))))  # eq. 7
        qb1.append(q1[:, body])
        qb2.append(q2[:, body])
        hb.append((1 - w2) * h1 + w2 * h2)
    qs = np.concatenate([np.stack(qb1), np.stack(qb2)])             # (8, B, nb, 4)
    wts = np.concatenate([np.repeat((1 - w2)[None], 4, 0), np.repeat(w2[None], 4, 0)]) / 4
    # equation 10: per-frame weights, broadcast over body joints
    ref = qs[0]
    s = np.sign(np.sum(qs * ref, axis=-1, keepdims=True))
    s[s == 0] = 1.0
    m = np.sum(wts[:, :, None, None] * qs * s, axis=0)
    rot[:, body] = m / np.linalg.norm(m, axis=-1, keepdims=True)
    h = np.mean(hb, axis=0)
    speed = (1 - w2) * clip1.speed + w2 * clip2.speed
    lt = dict(lt, stance=stance)
    return rot, h, speed, lt


def transition_motion(character: Character, clip1: Clip, clip2: Clip, *, t_start: float = 0.0,
                      before: float = 2.0, after: float = 4.0, synchronous: bool = False,
                      root: str = "feet", pin: bool = True) -> Motion:
    """M1 for ``before`` cycles from generic time 0, then the transition
    (starting at M1 generic time ``before + t_start``), then M2 for ``after``
    cycles of M2.

    ``root="feet"`` moves the root by the landing feet (equation 11, see
    :mod:`quadsim.horse.root`) and, with ``pin`` (default), holds the stance
    feet still by IK where they land (see the module notes);
    ``root="speed"`` advances it at the blended speed only. ``pin=False``
    leaves the blend's legs as they are (to measure the blend itself).

    Returns a Motion at the clips' frame rate whose ``extras`` hold
    ``"blend"`` (T,), the M2 weight (0 before, 1 after the transition), and
    ``"foot_phase"`` (T, 4): stance, striking or flight per foot.
    """
    from .root import clip_stance_cycles, foot_phase, in_stance, root_from_feet

    if root not in ("feet", "speed"):
        raise ValueError(f"root must be 'feet' or 'speed', got {root!r}")
    fps = clip1.motion.fps
    n0 = round((before + t_start) * clip1.frames)
    t_pre = np.arange(n0) / clip1.frames
    q_pre, h_pre = sample_cycle(clip1, t_pre)
    rot_b, h_b, v_b, lt = _transition(character, clip1, clip2, (n0 - 1) / clip1.frames,
                                      synchronous)
    n2 = round(after * clip2.frames)
    t_post = lt["end"] + np.arange(1, n2 + 1) / clip2.frames
    q_post, h_post = sample_cycle(clip2, t_post)
    rot = np.concatenate([q_pre, rot_b, q_post])
    h = np.concatenate([h_pre, h_b, h_post])
    v = np.concatenate([np.full(n0, clip1.speed), v_b, np.full(n2, clip2.speed)])
    z = np.concatenate([[0.0], np.cumsum(v[1:]) / fps])
    pos = np.stack([np.zeros_like(z), h, z], axis=-1)
    blend = np.concatenate([np.zeros(n0), lt["w2"], np.ones(n2)])
    # which feet are down: each leg's generic time in the clip that dominates it
    s1, s2 = clip_stance_cycles(clip1), clip_stance_cycles(clip2)
    if synchronous:
        tb1 = np.repeat(lt["t1"][:, [REFERENCE]], 4, axis=1)
        tb2 = np.repeat(lt["t2"][:, [REFERENCE]], 4, axis=1)
    else:
        tb1, tb2 = lt["t1"], lt["t2"]
    a1, a2 = in_stance(s1, tb1), in_stance(s2, tb2)
    # each leg changes from M1's contacts to M2's while in the air in both,
    # as near the middle of the blend as it can
    B = lt["B"]
    idx = np.arange(B)
    st_b = np.empty_like(a1)
    for j in range(4):
        free = np.nonzero(~a1[:, j] & ~a2[:, j])[0]
        k = int(free[np.argmin(np.abs(free - B / 2))]) if len(free) else B // 2
        st_b[:, j] = np.where(idx < k, a1[:, j], a2[:, j])
    if lt["stance"] is not None:       # stance-aligned legs: down in both clips at once
        st_b = lt["stance"]
    stance = np.concatenate([in_stance(s1, np.repeat(t_pre[:, None], 4, axis=1)), st_b,
                             in_stance(s2, np.repeat(t_post[:, None], 4, axis=1))])
    m = Motion(character.skeleton, fps, pos, rot, foot_joints=character.foot_joints)
    if root == "feet":
        pos = root_from_feet(m, stance, clip1.speed)
        m = Motion(character.skeleton, fps, pos, rot, foot_joints=character.foot_joints)
        if pin:
            m, stance = _pin_measured(character, m, stance)
    return Motion(character.skeleton, fps, m.root_positions, m.rotations,
                  foot_joints=character.foot_joints,
                  extras={"blend": blend, "foot_phase": foot_phase(stance)})


def _pin_measured(character, motion, stance, ramp: int = PIN_RAMP, rounds: int = 3):
    """Hold the feet still through the planned contacts and any contact the motion shows.

    The planned contacts (``stance``, each leg's own clip contacts) are held
    where each foot lands, on the ground
    (:func:`~quadsim.horse.legs.stance_targets`, anchor at touchdown, the
    swing easing onto and off the held place over ``ramp`` frames); where a
    held foot lies beyond its leg's reach the root comes down, smoothly
    (:func:`~quadsim.horse.legs.reach_drop`), while every foot keeps its
    planned world path; :func:`~quadsim.horse.legs.place_feet` poses the legs.
    A blended leg may reach the ground a frame or two before its plan, so the
    contacts are then measured on the result
    (:func:`~quadsim.skeleton.contacts.foot_contacts`: low and slow, trimmed
    to the on-ground band), any measured contact frame outside the plan is
    added to it and the feet held again, up to ``rounds`` times.

    Parameters
    ----------
    character : Character
    motion : Motion
        The blend, root moved by equation 11, T frames.
    stance : ndarray of bool, shape (T, 4)
        The planned contacts.
    ramp : int
        Easing frames (see :func:`~quadsim.horse.legs.stance_targets`).
    rounds : int
        Most passes of holding and measuring.

    Returns
    -------
    motion : Motion
    stance : ndarray of bool, shape (T, 4)
        The contacts held.
    """
    from .legs import place_feet, reach_drop, stance_targets

    held = np.asarray(stance, dtype=bool)
    feet = motion.foot_positions()
    for _ in range(rounds):
        # where a held foot is out of the leg's reach, the root comes down
        tgt = stance_targets(feet, held, anchor="touchdown", ramp=ramp, clear=True)
        drop = reach_drop(character, motion, tgt, held)
        lowered = motion
        if drop.any():
            root = np.array(motion.root_positions)
            root[:, 1] -= drop
            lowered = Motion(motion.skeleton, motion.fps, root, motion.rotations,
                             foot_joints=motion.foot_joints)
        # the feet keep their planned world paths (a swing foot does not come
        # down with the root): the IK bends the legs instead
        out = Motion(motion.skeleton, motion.fps, lowered.root_positions,
                     place_feet(character, lowered, tgt), foot_joints=motion.foot_joints)
        got = foot_contacts(out.foot_positions(), motion.fps)
        if not (got & ~held).any():
            break
        held = held | got
    return out, held


def synchronous_transition(character, clip1, clip2, **kw) -> Motion:
    """The baseline: :func:`transition_motion` with every leg on the reference leg's times."""
    return transition_motion(character, clip1, clip2, synchronous=True, **kw)


__all__ = ["PIN_RAMP", "REFERENCE", "TRANSITION_CYCLES", "blend_frames", "leg_stance",
           "leg_times", "sample_cycle", "stance_aligned_times", "synchronous_transition",
           "transition_motion"]
