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

:func:`synchronous_transition` is the baseline: every leg at the reference
leg's times, the whole pose slerped from M1 to M2.
"""

from __future__ import annotations

import numpy as np

from ..kinematics.rotations import quaternion_slerp
from ..skeleton.character import Character
from ..skeleton.motion import Motion
from .database import Clip

REFERENCE = 2  # LH
TRANSITION_CYCLES = 2.5


def blend_frames(L1: int, L2: int) -> int:
    """``B = (5 L1 L2 + L2 - L1) / (L1 + L2)``, rounded to whole frames."""
    return max(round((5 * L1 * L2 + L2 - L1) / (L1 + L2)), 1)


def sample_cycle(clip: Clip, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations (n, J, 4) and root heights (n,) at generic times ``t`` (cycles)."""
    m = clip.motion
    L = clip.frames
    f = (np.asarray(t, dtype=float) % 1.0) * L
    i0 = np.floor(f).astype(int) % L
    i1 = (i0 + 1) % L
    a = f - np.floor(f)
    J = m.skeleton.n_joints
    q = quaternion_slerp(m.rotations[i0], m.rotations[i1], np.broadcast_to(a[:, None], (len(f), J)))
    h = m.root_positions[i0, 1] * (1 - a) + m.root_positions[i1, 1] * a
    return q, h


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


def _transition(character, clip1, clip2, t_start, synchronous: bool):
    lt = leg_times(clip1, clip2, t_start)
    B, w2 = lt["B"], lt["w2"]
    if synchronous:
        # every leg on the reference leg's times, in both clips
        t1 = np.repeat(lt["t1"][:, REFERENCE][:, None], 4, axis=1)
        t2 = np.repeat(lt["t2"][:, REFERENCE][:, None], 4, axis=1)
    else:
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
    return rot, h, speed, lt


def transition_motion(character: Character, clip1: Clip, clip2: Clip, *, t_start: float = 0.0,
                      before: float = 2.0, after: float = 4.0, synchronous: bool = False,
                      root: str = "feet") -> Motion:
    """M1 for ``before`` cycles from generic time 0, then the transition
    (starting at M1 generic time ``before + t_start``), then M2 for ``after``
    cycles of M2.

    ``root="feet"`` moves the root by the landing feet (equation 11, see
    :mod:`quadsim.horse.root`) and holds the stance feet still by IK;
    ``root="speed"`` advances it at the blended speed only.

    Returns a Motion at the clips' frame rate whose ``extras`` hold
    ``"blend"`` (T,), the M2 weight (0 before, 1 after the transition), and
    ``"foot_phase"`` (T, 4): stance, striking or flight per foot.
    """
    from .legs import pin_stance
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
    stance = np.concatenate([in_stance(s1, np.repeat(t_pre[:, None], 4, axis=1)), st_b,
                             in_stance(s2, np.repeat(t_post[:, None], 4, axis=1))])
    m = Motion(character.skeleton, fps, pos, rot, foot_joints=character.foot_joints)
    if root == "feet":
        pos = root_from_feet(m, stance, clip1.speed)
        m = Motion(character.skeleton, fps, pos, rot, foot_joints=character.foot_joints)
        m = pin_stance(character, m, stance)
    return Motion(character.skeleton, fps, m.root_positions, m.rotations,
                  foot_joints=character.foot_joints,
                  extras={"blend": blend, "foot_phase": foot_phase(stance)})


def synchronous_transition(character, clip1, clip2, **kw) -> Motion:
    """The baseline: :func:`transition_motion` with every leg on the reference leg's times."""
    return transition_motion(character, clip1, clip2, synchronous=True, **kw)


__all__ = ["REFERENCE", "blend_frames", "leg_times", "sample_cycle", "synchronous_transition",
           "transition_motion"]
