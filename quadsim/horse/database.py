"""A database of looped gait clips, and the builder that cuts clips out of long takes.

:class:`Clip` is one looped clip with its labels (gait, speed, frames per
cycle, each foot's touchdown frame, the leading leg), :class:`ClipDatabase`
the clips of one character. Reading a clip folder (a ``manifest.toml`` and
its BVH files) is file work and lives in :mod:`quadsim.io.clips`
(:func:`~quadsim.io.clips.load_database`,
:func:`~quadsim.io.clips.load_default_database`); the engine takes the
database it is given.

:func:`cut_cycles` is the builder: it cuts steady, looped cycles out of a long
take by the measured foot contacts and labels their touchdowns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..skeleton.contacts import default_contact_thresholds, foot_contacts, stance_intervals
from ..errors import InputError
from ..kinematics.rotations import quaternion_multiply, quaternion_slerp
from .place_kernel import sample_rows
from ..skeleton.character import Character
from ..skeleton.motion import Motion

LEGS = ("LF", "RF", "LH", "RH")
#: Gaits a clip may have (the shared gait table's, slowest first, and the leap);
#: ``gallop`` is the transverse gallop.
CLIP_GAITS = ("walk", "amble", "trot", "rack", "pace", "canter", "gallop", "rotary_gallop",
              "leap")
#: Gaits with a leading fore leg.
ASYMMETRIC = ("canter", "gallop", "rotary_gallop", "leap")
#: Other names a clip's or a command's gait may be given by.
GAIT_ALIASES = {"transverse_gallop": "gallop"}
#: Largest joint rotation (deg) between a cycle's first pose and the pose one
#: period later for the cycle to count as looped.
LOOP_TOLERANCE_DEG = 6.0


@dataclass(frozen=True, eq=False)
class Clip:
    """One looped clip.

    Attributes
    ----------
    name, gait : str
    speed : float
        Forward speed (m/s).
    frames : int
        Frames per cycle; ``motion`` holds exactly these frames.
    touchdown : ndarray of int, shape (4,)
        Touchdown frame of each foot, leg order LF, RF, LH, RH.
    lead : str or None
        ``"left"`` or ``"right"`` for asymmetric gaits.
    motion : Motion
        On the character's skeleton.
    source : str
    start_gait : str or None
        Leap clips: the gait the leap starts from.
    height : float or None
        Leap clips: the feet's clearance at the top of the flight (m).
    """

    name: str
    gait: str
    speed: float
    frames: int
    touchdown: np.ndarray
    lead: str | None
    motion: Motion
    source: str = ""
    start_gait: str | None = None
    height: float | None = None

    @property
    def period(self) -> float:
        """Cycle duration (s)."""
        return self.frames / self.motion.fps


@dataclass(frozen=True)
class SpeedLaw:
    """A gait's contact-time law ``Tc = a v^b`` (Tc in s, v in m/s).

    Attributes
    ----------
    a : float
        Contact time (s) at 1 m/s.
    b : float
        Exponent (negative: faster, shorter contacts).
    anchor : {"law", "clip"}
        How a clip is expanded to another speed (:func:`quadsim.horse.speed.expand`):
        to ``a v^b`` itself, or by ``(v / v0)^b`` relative to the clip.
    """

    a: float
    b: float
    anchor: str = "law"

    def contact_time(self, speed):
        """``a v^b`` (s) at ``speed`` (m/s), any shape."""
        return self.a * np.asarray(speed, dtype=float) ** self.b


@dataclass(frozen=True, eq=False)
class ClipDatabase:
    """Clips by name, for one character.

    ``laws`` maps a gait to its :class:`SpeedLaw` (a clip folder's
    ``[laws.<gait>]`` tables); a gait without one uses the horse's Table 1
    (:data:`quadsim.horse.speed.HOYT`) where it has a row.
    """

    character: Character
    clips: dict
    folder: Path | None = None
    laws: dict = field(default_factory=dict)

    def by_gait(self, gait: str) -> list[Clip]:
        """Clips of a gait, slowest first."""
        gait = GAIT_ALIASES.get(gait, gait)
        return sorted((c for c in self.clips.values() if c.gait == gait), key=lambda c: c.speed)

    def nearest(self, gait: str, speed: float) -> Clip:
        """The clip of ``gait`` whose speed is closest to ``speed`` (m/s)."""
        cs = self.by_gait(gait)
        if not cs:
            raise InputError(f"the clip database has no {gait!r} clip")
        return min(cs, key=lambda c: abs(np.log(max(speed, 1e-3) / c.speed)))

    @property
    def gaits(self) -> tuple[str, ...]:
        return tuple(g for g in CLIP_GAITS if any(c.gait == g for c in self.clips.values()))


# ------------------------------------------------------------------ building
def sample_motion(motion: Motion, frames) -> tuple[np.ndarray, np.ndarray]:
    """Root positions and rotations at fractional frame indices.

    The root linearly, every joint by shortest-path slerp, between the two
    frames about each index (compiled: :func:`~quadsim.horse.place_kernel.sample_row`,
    as the controller samples its clips).

    Parameters
    ----------
    motion : Motion
    frames : array-like, shape (n,)
        Fractional frame indices within ``[0, T - 1]`` (clipped to it).

    Returns
    -------
    root : ndarray, shape (n, 3)
    rotations : ndarray, shape (n, J, 4)
    """
    f = np.clip(np.asarray(frames, dtype=float), 0, len(motion) - 1)
    i0 = np.floor(f).astype(np.int64)
    i1 = np.minimum(i0 + 1, len(motion) - 1)
    return sample_frames(motion.root_positions, motion.rotations, i0, i1, f - i0)


def sample_frames(roots, rotations, i0, i1, a) -> tuple[np.ndarray, np.ndarray]:
    """Poses a fraction ``a`` (n,) of the way from frames ``i0`` to ``i1`` (n,) int.

    ``roots`` (F, 3) (m) and ``rotations`` (F, J, 4) quaternions; returns the
    roots (n, 3) and rotations (n, J, 4) (:func:`~quadsim.horse.place_kernel.sample_rows`).
    """
    n = len(i0)
    root = np.empty((n, 3))
    rot = np.empty((n, rotations.shape[1], 4))
    sample_rows(np.ascontiguousarray(roots, dtype=float),
                np.ascontiguousarray(rotations, dtype=float),
                np.ascontiguousarray(i0, dtype=np.int64), np.ascontiguousarray(i1, dtype=np.int64),
                np.ascontiguousarray(a, dtype=float), root, rot)
    return root, rot


def pose_distance_deg(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Largest joint rotation (deg) between poses, shape (...) from (..., J, 4)."""
    d = np.abs(np.sum(q0 * q1, axis=-1)).clip(0.0, 1.0)
    return np.degrees(2.0 * np.arccos(d)).max(axis=-1)


@dataclass(frozen=True, eq=False)
class Cycle:
    """A cycle cut by :func:`cut_cycles`: looped motion and its labels."""

    motion: Motion
    frames: int
    touchdown: np.ndarray
    speed: float
    lead: str | None
    loop_error_deg: float
    start_time: float


def cut_cycles(motion: Motion, *, count: int = 1, reference: int = 2,
               loop_tolerance_deg: float = LOOP_TOLERANCE_DEG,
               steady_tolerance: float = 0.03, character: Character | None = None,
               where: str = "take", root_tolerance: float = 0.02,
               contact_tolerance: float | None = None) -> list[Cycle]:
    """Cut steady, looped stride cycles out of a long take by its foot contacts.

    Contacts are measured from the foot positions
    (:func:`quadsim.skeleton.contacts.foot_contacts`); a cycle runs from one
    touchdown of the ``reference`` foot (default LH) to its next (``contact_tolerance``,
    m: the contacts' widest on-ground band, see
    :func:`~quadsim.skeleton.contacts.foot_contacts`; a foot landing up to half a
    frame before the reference foot counts as landing with it). Cycles whose
    period differs from the take's median period by more than
    ``steady_tolerance`` (fraction) are not steady and skipped. The chosen
    cycle, one period long from the frame the reference foot comes to rest on
    (:func:`rest_frames`: its refined touchdown runs early by up to a frame), is
    resampled (slerp) to a whole number of frames at the take's frame rate, the
    root moved to start at the origin horizontally, and each foot's touchdown
    labelled (the frame it comes to rest on, :func:`label_touchdowns`). The
    ``count`` steady cycles that loop best are returned, in time order (a cycle
    whose feet do not each land once in it is left out, unless none does).

    The small remaining difference between the first pose and the pose one
    period later (``loop_error_deg``) is spread over the cycle (each joint's
    correction slerped in linearly, the root height likewise), so that the
    clip plays as a seamless loop. With ``character`` given, each foot is then
    held still on the ground through its contacts measured in the take, from the
    frame it comes to rest on (:func:`settled_stance`), by two-bone IK
    (:func:`quadsim.horse.legs.pin_stance`), and the touchdowns are labelled
    from the result.

    Raises
    ------
    InputError
        When the take has no two touchdowns of the reference foot, no steady
        cycle, or a cycle that does not loop (first pose and the pose one
        period later differ by more than ``loop_tolerance_deg`` in any joint,
        or the root height by more than ``root_tolerance`` m, default 2 cm).
    """
    if motion.foot_joints is None:
        raise InputError(f"{where}: the motion does not name its foot joints")
    fps = motion.fps
    feet = motion.foot_positions()
    c = foot_contacts(feet, fps, tolerance=contact_tolerance)
    iv = stance_intervals(c, fps, feet, tolerance=contact_tolerance)
    on = [s[np.isfinite(s[:, 0]), 0] for s in iv]
    ref = on[reference]
    if len(ref) < 2:
        raise InputError(f"{where}: fewer than two touchdowns of the {LEGS[reference]} foot; "
                         "cannot find a cycle")
    periods = np.diff(ref)
    med = float(np.median(periods[len(periods) // 2:]))
    tol = rest_tolerance(feet, contact_tolerance)
    rest = rest_frames(feet, c, reference, ref, fps, tol)
    steady = np.nonzero(np.abs(periods / med - 1.0) <= steady_tolerance)[0]
    # keep cycles wholly inside the take with all four feet landing in them
    steady = [k for k in steady if ref[k + 1] * fps <= len(motion) - 1]
    if not steady:
        raise InputError(f"{where}: no steady cycle (periods {np.round(periods, 3)} s)")
    cands = []
    for k in steady:
        t0, t1 = float(ref[k]), float(ref[k + 1])
        n = round((t1 - t0) * fps)
        # sampled from the frame the reference foot comes to rest on (``rest_frames``)
        src = rest[k] + np.arange(n + 1) * ((t1 - t0) * fps / n)
        root, rot = sample_motion(motion, src)
        err = float(pose_distance_deg(rot[0], rot[-1]))
        dh = float(abs(root[0, 1] - root[-1, 1]))
        cands.append((max(err / loop_tolerance_deg, dh / root_tolerance), k, t0, t1, n, root,
                      rot, err, dh))
    cands.sort(key=lambda x: x[0])
    if cands[0][0] > 1.0:
        _, k, t0, t1, n, root, rot, err, dh = cands[0]
        raise InputError(
            f"{where}: cannot loop a cycle: the best, at {t0:.3f}-{t1:.3f} s, has first and "
            f"last pose differing by {err:.1f} deg (allowed {loop_tolerance_deg}) and root "
            f"heights by {dh * 100:.1f} cm (allowed {root_tolerance * 100:g})")
    out, failed = [], []
    for score, k, t0, t1, n, root, rot, err, dh in sorted(
            [c for c in cands if c[0] <= 1.0][:count], key=lambda x: x[2]):
        try:
            out.append(_close_cycle(motion, character, fps, on, iv, where, t0, t1, rest[k] / fps,
                                    n, root, rot, err, tol))
        except InputError as e:  # (an unsteady cycle's feet may not land once in it)
            failed.append(e)
    if not out:
        raise failed[0]
    return out


def _close_cycle(motion, character, fps, on, iv, where, t0, t1, c0, n, root, rot, err,
                 tol):
    """The cycle sampled from ``c0`` (s; the reference foot's refined touchdowns
    ``t0``, ``t1``) as ``n`` frames of ``root`` and ``rot``, looped, labelled and,
    with ``character``, its feet pinned (:func:`cut_cycles`)."""
    P = t1 - t0
    # played back at n frames per cycle: the speed that loops seamlessly
    speed = float(np.linalg.norm((root[-1] - root[0])[[0, 2]]) * fps / n)
    # close the loop: spread the end pose's residual over the cycle
    frac = np.arange(n + 1) / n
    delta = quaternion_multiply(rot[0], rot[-1] * np.array([1.0, -1.0, -1.0, -1.0]))
    ident = np.zeros_like(delta)
    ident[..., 0] = 1.0
    corr = quaternion_slerp(np.broadcast_to(ident, rot.shape), np.broadcast_to(delta, rot.shape),
                            np.broadcast_to(frac[:, None], rot.shape[:2]))
    rot = quaternion_multiply(corr, rot)
    root = root.copy()
    root[:, 1] += (root[0, 1] - root[-1, 1]) * frac
    root = root[:n] - np.array([root[0, 0], 0.0, root[0, 2]])
    td = np.zeros(4, dtype=int)
    phase = np.zeros(4)
    for i in range(4):
        ti = on[i]
        inside = ti[(ti >= t0 - 0.5 / fps) & (ti < t1 - 0.5 / fps)]
        if len(inside) == 0:
            raise InputError(f"{where}: foot {LEGS[i]} does not land in the cycle at "
                             f"{t0:.3f}-{t1:.3f} s")
        phase[i] = (inside[0] - c0) / P
        td[i] = round(phase[i] * n) % n
    lead = "left" if (phase[0] - phase[1]) % 1.0 < 0.5 else "right"
    cyc = Motion(motion.skeleton, fps, root, rot[:n], foot_joints=motion.foot_joints)
    if character is not None:
        # the take's measured contacts starting in this cycle, in cycle frames
        scale = n / P
        stance = []
        for i in range(4):
            s_i = iv[i][np.isfinite(iv[i]).all(axis=1)]
            s_i = s_i[(s_i[:, 0] >= t0 - 1e-9) & (s_i[:, 0] < t1 - 1e-9)]
            stance.append((s_i - c0) * scale)
        stance = settled_stance(looped(cyc, 3, speed).foot_positions(), stance, n, tol)
        cyc = pin_cycle(character, cyc, speed, stance)
        td = label_touchdowns(cyc, speed)
    return Cycle(cyc, n, td, speed, lead, err, c0)


#: A foot comes to rest at most this many frames after the first frame of its refined
#: touchdown (the refinement runs early by under a frame); one still moving then is
#: taken as resting from that frame (a slow slide after the landing is the take's).
SETTLE_FRAMES = 1


def rest_tolerance(feet: np.ndarray, tolerance: float | None = None) -> float:
    """How far (m) a foot at rest may move horizontally from one frame to the next:
    ``tolerance`` if given, else the contacts' on-ground band for ``feet`` (T, 4, 3) (a
    tenth of their height threshold, at least 1 mm)."""
    if tolerance is not None:
        return float(tolerance)
    return max(0.1 * default_contact_thresholds(feet)[0], 1e-3)


def _steps(feet: np.ndarray) -> np.ndarray:
    """Each foot's horizontal travel (m) to the next frame, (T, 4), inf on the last."""
    step = np.full(feet.shape[:2], np.inf)
    step[:-1] = np.linalg.norm(np.diff(feet[..., [0, 2]], axis=0), axis=-1)
    return step


def _settle(step: np.ndarray, first: int, end: int, tolerance: float, down=None) -> int:
    """The first frame ``j`` from ``first``, before ``end`` and at most :data:`SETTLE_FRAMES`
    on, whose ``step`` (m) to the next frame is within ``tolerance`` (and ``down[j]``, if
    given); -1 when none is."""
    for j in range(first, min(end, first + SETTLE_FRAMES + 1)):
        if step[j] <= tolerance and (down is None or down[j]):
            return j
    return -1


def rest_frames(feet: np.ndarray, contacts: np.ndarray, leg: int, touchdowns: np.ndarray,
                fps: float, tolerance: float) -> np.ndarray:
    """The frame on which foot ``leg`` comes to rest after each of its ``touchdowns``.

    The refined touchdown (:func:`~quadsim.skeleton.contacts.stance_intervals`)
    extrapolates the foot's last descent rate to the ground; a foot that eases onto
    it comes to rest later, up to a frame (a galloping hoof 0.45-0.87 frame after,
    still moving at 0.16 of the body's speed into the next frame). Cut there, a
    cycle held the foot planted from its first frame while its last frame was
    nearly two frames of the swing back: the loop's seam carried the foot over both
    in one (the data mode's gallop landed its left hind at 0.45 of the body's speed,
    the other feet at 0.09-0.12).

    Parameters
    ----------
    feet : ndarray, shape (T, 4, 3)
        Foot positions (m).
    contacts : ndarray of bool, shape (T, 4)
        Their contacts (:func:`~quadsim.skeleton.contacts.foot_contacts`).
    leg : int
    touchdowns : ndarray, shape (n,)
        The foot's refined touchdown times (s).
    fps : float
    tolerance : float
        A foot at rest moves at most this far (m) to the next frame
        (:func:`rest_tolerance`).

    Returns
    -------
    frames : ndarray of int, shape (n,)
        The first contact frame at or after each touchdown (at most
        :data:`SETTLE_FRAMES` after the touchdown's frame rounded up, that frame when
        none) from which the foot moves no further than ``tolerance`` to the next frame.
    """
    T = len(feet)
    step = _steps(feet)[:, leg]
    out = np.empty(len(touchdowns), dtype=np.int64)
    for k, t in enumerate(touchdowns):
        first = min(int(np.ceil(t * fps - 1e-9)), T - 1)
        j = _settle(step, first, T - 1, tolerance, contacts[:, leg])
        out[k] = j if j >= 0 else first
    return out


def settled_stance(feet: np.ndarray, stance: list[np.ndarray], n: int,
                   tolerance: float) -> list[np.ndarray]:
    """A looped cycle's contacts ``stance`` (per foot ``[on, off]`` in frames, ``on`` in
    ``[-1, n)``, as :func:`cycle_stance` gives them) held from the frame each foot comes
    to rest on, not before: ``feet`` (3 n, 4, 3) the cycle's feet over three loops.

    The contacts' refined touchdowns run early by up to a frame for a foot that eases
    onto the ground (:func:`rest_frames`); held still from there, a foot stopped a
    frame short of where it lands and jumped there in one (the data mode's trot,
    expanded to 4 m/s, landed its left fore at 0.30 of the body's speed; now 0.06). A
    contact whose foot is not at rest within :data:`SETTLE_FRAMES` keeps its ``on``.
    """
    step = _steps(feet)
    out = []
    for i, s in enumerate(stance):
        s = np.array(s, dtype=float).reshape(-1, 2)
        for r in range(len(s)):
            on, off = s[r]
            j = _settle(step[:, i], math.ceil(on + n - 1e-9), math.ceil(n + off), tolerance)
            if j >= 0:
                s[r, 0] = max(on, j - n)
        out.append(s)
    return out


def label_touchdowns(cycle: Motion, speed: float) -> np.ndarray:
    """Touchdown frame of each foot in a looped cycle, measured, shape (4,): the frame
    it comes to rest on after its refined touchdown (:func:`rest_frames`)."""
    n = len(cycle)
    three = looped(cycle, 3, speed)
    feet = three.foot_positions()
    con = foot_contacts(feet, cycle.fps)
    iv = stance_intervals(con, cycle.fps, feet)
    tol = rest_tolerance(feet)
    td = np.zeros(4, dtype=int)
    for i in range(4):
        rest = rest_frames(feet, con, i, iv[i][np.isfinite(iv[i][:, 0]), 0], cycle.fps, tol)
        rest = rest[(rest >= n) & (rest < 2 * n)]
        if len(rest) == 0:
            raise InputError(f"foot {LEGS[i]} does not land in the cycle")
        td[i] = rest[0] - n
    return td


def cycle_stance(cycle: Motion, speed: float) -> list[np.ndarray]:
    """Stance intervals of a looped cycle in frames, ``[on, off]`` per contact.

    Returns a list of 4 arrays of shape (n_i, 2), ``on`` within ``[0, n)`` and
    ``off > on`` (it may pass ``n``: the contact wraps round the loop).
    """
    n = len(cycle)
    three = looped(cycle, 3, speed)
    feet = three.foot_positions()
    iv = stance_intervals(foot_contacts(feet, cycle.fps), cycle.fps, feet)
    out = []
    for s in iv:
        s = s[np.isfinite(s).all(axis=1)] * cycle.fps
        s = s[(s[:, 0] >= n - 0.5) & (s[:, 0] < 2 * n - 0.5)] - n
        out.append(s)
    return out


def contacts_from_stance(stance: list[np.ndarray], n: int, repeats: int = 3) -> np.ndarray:
    """Per-frame contacts (n * repeats, 4) of a loop from its stance intervals in frames."""
    f = np.arange(n * repeats)[:, None]
    c = np.zeros((n * repeats, 4), dtype=bool)
    for i, s in enumerate(stance):
        for on, off in s:
            for r in range(-1, repeats + 1):
                c[:, i] |= ((f[:, 0] >= on + r * n - 1e-9) & (f[:, 0] <= off + r * n + 1e-9))
    return c


def pin_cycle(character: Character, cycle: Motion, speed: float, stance=None) -> Motion:
    """A looped cycle with its feet held still through their contacts.

    ``stance`` (as from :func:`cycle_stance`, in frames) gives the contacts;
    by default they are measured.
    """
    from .legs import keep_foot_attitude, pin_stance

    n = len(cycle)
    three = looped(cycle, 3, speed)
    if stance is None:
        c = foot_contacts(three.foot_positions(), cycle.fps)
    else:
        c = contacts_from_stance(stance, n, 3)
    pinned = pin_stance(character, three, c)
    # the legs' IK tilts the hooves with the lower legs: keep their attitude, so a held
    # hoof's toe tip stays where the cycle had it
    rot = keep_foot_attitude(character, three, pinned.rotations)
    return Motion(cycle.skeleton, cycle.fps, cycle.root_positions, rot[n:2 * n],
                  foot_joints=cycle.foot_joints)


def looped(motion: Motion, repeats: int, speed: float) -> Motion:
    """A clip played ``repeats`` times, the root advancing at ``speed`` along +Z."""
    n = len(motion)
    rot = np.tile(motion.rotations, (repeats, 1, 1))
    base = motion.root_positions - np.array([0.0, 0.0, 1.0]) * (np.arange(n)[:, None] * speed
                                                                 / motion.fps)
    root = np.tile(base, (repeats, 1))
    root[:, 2] += np.arange(n * repeats) * speed / motion.fps
    return Motion(motion.skeleton, motion.fps, root, rot, foot_joints=motion.foot_joints)


__all__ = [
    "ASYMMETRIC",
    "CLIP_GAITS",
    "GAIT_ALIASES",
    "LEGS",
    "LOOP_TOLERANCE_DEG",
    "Clip",
    "ClipDatabase",
    "Cycle",
    "SpeedLaw",
    "contacts_from_stance",
    "cut_cycles",
    "cycle_stance",
    "label_touchdowns",
    "looped",
    "pin_cycle",
    "pose_distance_deg",
    "rest_frames",
    "rest_tolerance",
    "sample_frames",
    "sample_motion",
    "settled_stance",
]
