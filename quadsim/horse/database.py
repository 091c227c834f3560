"""A database of looped gait clips: BVH files plus a TOML manifest.

The manifest (``manifest.toml`` in the clip folder) has one table per clip::

    [clips.walk_1.4]
    file = "walk_1.4.bvh"          # BVH in the same folder, metres
    gait = "walk"                  # walk, amble, trot, rack, canter, gallop, leap
    speed = 1.4                    # forward speed of the clip (m/s)
    frames = 52                    # frames per cycle (the BVH holds at least this many)
    touchdown = { LF = 13, RF = 39, LH = 0, RH = 26 }   # frame of each foot's touchdown
    lead = "left"                  # canter, gallop and leap: the leading fore leg
    source = "how the clip was made"

A leap clip also gives ``start_gait`` (the gait it starts from) and
``height`` (the clearance of its feet at the top of the flight, m).

Clips are read onto the character's skeleton by joint name: every joint of
the character's legs must be present in the BVH; other character joints the
file lacks stay at rest.

:func:`cut_cycles` is the builder: it cuts steady, looped cycles out of a long
take by the measured foot contacts and labels their touchdowns.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..skeleton.contacts import foot_contacts, stance_intervals
from ..errors import InputError
from ..kinematics.rotations import quaternion_multiply, quaternion_slerp
from ..skeleton.character import Character
from ..skeleton.motion import Motion

LEGS = ("LF", "RF", "LH", "RH")
#: Gaits a clip may have; ``gallop`` is the horse's transverse gallop.
CLIP_GAITS = ("walk", "amble", "trot", "rack", "canter", "gallop", "leap")
#: Gaits with a leading fore leg.
ASYMMETRIC = ("canter", "gallop", "leap")
_ALIASES = {"transverse_gallop": "gallop"}
_KEYS = {"file", "gait", "speed", "frames", "touchdown", "lead", "source",
         "start_gait", "height"}
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


@dataclass(frozen=True, eq=False)
class ClipDatabase:
    """Clips by name, for one character."""

    character: Character
    clips: dict
    folder: Path | None = None

    def by_gait(self, gait: str) -> list[Clip]:
        """Clips of a gait, slowest first."""
        gait = _ALIASES.get(gait, gait)
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


# ------------------------------------------------------------------ loading
def load_database(folder, character: Character) -> ClipDatabase:
    """Read and validate a clip folder (``manifest.toml`` plus BVH files).

    Raises
    ------
    InputError
        Naming the manifest, the clip and the field at fault.
    """
    from ..io.bvh import read_bvh  # io sits above; imported at use

    folder = Path(folder)
    man = folder / "manifest.toml"
    if not man.is_file():
        raise InputError(f"{folder}: no manifest.toml in the clip folder")
    try:
        data = tomllib.loads(man.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{man}: not valid TOML: {e}") from None
    unknown = set(data) - {"clips", "description"}
    if unknown:
        raise InputError(f"{man}: unknown top-level key(s) {sorted(unknown)}; "
                         "allowed: clips, description")
    table = data.get("clips")
    if not isinstance(table, dict) or not table:
        raise InputError(f"{man}: `clips` must be a table with at least one clip")
    clips = {}
    for name, entry in table.items():
        where = f"{man}: clip {name!r}"
        clips[name] = _load_clip(name, entry, where, folder, character, read_bvh)
    return ClipDatabase(character, clips, folder)


def _load_clip(name, entry, where, folder, character, read_bvh) -> Clip:
    if not isinstance(entry, dict):
        raise InputError(f"{where}: must be a table")
    bad = set(entry) - _KEYS
    if bad:
        raise InputError(f"{where}: unknown field(s) {sorted(bad)}; allowed: {sorted(_KEYS)}")
    for key in ("file", "gait", "speed", "frames", "touchdown"):
        if key not in entry:
            raise InputError(f"{where}: missing field `{key}`")
    gait = _ALIASES.get(entry["gait"], entry["gait"])
    if gait not in CLIP_GAITS:
        raise InputError(f"{where}: `gait` = {entry['gait']!r} is not a known gait; "
                         f"allowed: {', '.join(CLIP_GAITS)}")
    speed = entry["speed"]
    if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not speed > 0:
        raise InputError(f"{where}: `speed` must be a positive number (m/s), got {speed!r}")
    frames = entry["frames"]
    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 4:
        raise InputError(f"{where}: `frames` must be an integer >= 4, got {frames!r}")
    td = entry["touchdown"]
    if not isinstance(td, dict):
        raise InputError(f"{where}: `touchdown` must be a table {{ LF = .., RF = .., LH = .., RH = .. }}")
    for leg in LEGS:
        if leg not in td:
            raise InputError(f"{where}: `touchdown` is missing foot {leg}")
    extra = set(td) - set(LEGS)
    if extra:
        raise InputError(f"{where}: `touchdown` has unknown foot/feet {sorted(extra)}; "
                         f"allowed: {', '.join(LEGS)}")
    tdf = []
    for leg in LEGS:
        v = td[leg]
        if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < frames:
            raise InputError(f"{where}: `touchdown.{leg}` = {v!r} is out of range; "
                             f"expected a frame in [0, {frames})")
        tdf.append(v)
    lead = entry.get("lead")
    if gait in ASYMMETRIC:
        if lead not in ("left", "right"):
            raise InputError(f"{where}: `lead` must be \"left\" or \"right\" for a {gait} clip, "
                             f"got {lead!r}")
    elif lead is not None:
        raise InputError(f"{where}: `lead` is only for {', '.join(ASYMMETRIC)} clips")
    start_gait = entry.get("start_gait")
    height = entry.get("height")
    if gait == "leap":
        if _ALIASES.get(start_gait, start_gait) not in CLIP_GAITS[:-1]:
            raise InputError(f"{where}: a leap clip needs `start_gait`, one of "
                             f"{', '.join(CLIP_GAITS[:-1])}; got {start_gait!r}")
        start_gait = _ALIASES.get(start_gait, start_gait)
        if isinstance(height, bool) or not isinstance(height, (int, float)) or not height > 0:
            raise InputError(f"{where}: a leap clip needs `height` > 0 (m), got {height!r}")
    path = folder / str(entry["file"])
    if not path.is_file():
        raise InputError(f"{where}: `file` {str(entry['file'])!r}: BVH file not found at {path}")
    try:
        raw = read_bvh(path)
    except (InputError, ValueError, OSError) as e:
        raise InputError(f"{where}: `file` {path.name!r} is not a usable BVH: {e}") from None
    motion = _retarget(raw, character, f"{where}: `file` {path.name!r}")
    if len(motion) < frames:
        raise InputError(f"{where}: `frames` = {frames} is out of range: "
                         f"the BVH holds only {len(motion)} frames")
    motion = motion[:frames]
    return Clip(name, gait, float(speed), frames, np.array(tdf), lead, motion,
                str(entry.get("source", "")), start_gait,
                None if height is None else float(height))


def _retarget(raw: Motion, character: Character, where: str) -> Motion:
    """Put a read motion on the character's skeleton by joint name."""
    skel = character.skeleton
    names = set(raw.skeleton.names)
    leg_joints = [skel.names[j] for leg in character.legs for j in leg.chain]
    missing = [n for n in leg_joints if n not in names]
    if missing:
        raise InputError(f"{where}: joint names do not match the character's legs "
                         f"({character.id}); missing {', '.join(missing[:6])}"
                         f"{' ...' if len(missing) > 6 else ''}")
    if raw.skeleton.names[0] != skel.names[0]:
        raise InputError(f"{where}: the root joint is {raw.skeleton.names[0]!r}, "
                         f"expected {skel.names[0]!r}")
    T = len(raw)
    rot = np.zeros((T, skel.n_joints, 4))
    rot[..., 0] = 1.0
    for j, n in enumerate(skel.names):
        if n in names:
            rot[:, j] = raw.rotations[:, raw.skeleton.index(n)]
    return Motion(skel, raw.fps, raw.root_positions, rot, foot_joints=character.foot_joints)


def clip_folder(character: Character) -> Path | None:
    """The shipped clip folder of a character, ``characters/<id>/clips``, if it exists."""
    from ..skeleton.character import characters_dir

    d = characters_dir() / character.id / "clips"
    return d if (d / "manifest.toml").is_file() else None


def playable_gaits(character: Character) -> tuple[str, ...]:
    """The gaits the character's shipped clips can be asked for (leap clips excepted),
    read from the manifest alone (no clip is loaded); empty without a clip folder."""
    d = clip_folder(character)
    if d is None:
        return ()
    try:
        table = tomllib.loads((d / "manifest.toml").read_text(encoding="utf-8")).get("clips")
    except tomllib.TOMLDecodeError:
        return ()                       # loading the database names the fault
    gaits = {_ALIASES.get(e.get("gait"), e.get("gait")) for e in (table or {}).values()
             if isinstance(e, dict)}
    return tuple(g for g in CLIP_GAITS if g in gaits and g != "leap")


def load_default_database(character: Character) -> ClipDatabase:
    """The character's shipped clip database (``characters/<id>/clips``)."""
    d = clip_folder(character)
    if d is None:
        raise InputError(f"character {character.id!r} has no clip database "
                         f"(characters/{character.id}/clips/manifest.toml)")
    return load_database(d, character)


# ------------------------------------------------------------------ building
def sample_motion(motion: Motion, frames) -> tuple[np.ndarray, np.ndarray]:
    """Root positions and rotations at fractional frame indices.

    Parameters
    ----------
    motion : Motion
    frames : array-like, shape (n,)
        Fractional frame indices within ``[0, T - 1]``.

    Returns
    -------
    root : ndarray, shape (n, 3)
    rotations : ndarray, shape (n, J, 4)
    """
    f = np.clip(np.asarray(frames, dtype=float), 0, len(motion) - 1)
    i0 = np.floor(f).astype(int)
    i1 = np.minimum(i0 + 1, len(motion) - 1)
    a = f - i0
    root = motion.root_positions[i0] * (1 - a[:, None]) + motion.root_positions[i1] * a[:, None]
    J = motion.skeleton.n_joints
    rot = quaternion_slerp(motion.rotations[i0], motion.rotations[i1],
                           np.broadcast_to(a[:, None], (len(f), J)))
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
               where: str = "take") -> list[Cycle]:
    """Cut steady, looped stride cycles out of a long take by its foot contacts.

    Contacts are measured from the foot positions
    (:func:`quadsim.analysis.metrics.foot_contacts`); a cycle runs from one
    touchdown of the ``reference`` foot (default LH) to its next. Cycles whose
    period differs from the take's median period by more than
    ``steady_tolerance`` (fraction) are not steady and skipped. The chosen
    cycle is resampled (slerp) to a whole number of frames at the take's frame
    rate, the root moved to start at the origin horizontally, and each foot's
    touchdown labelled. The ``count`` steady cycles that loop best are
    returned, in time order.

    The small remaining difference between the first pose and the pose one
    period later (``loop_error_deg``) is spread over the cycle (each joint's
    correction slerped in linearly, the root height likewise), so that the
    clip plays as a seamless loop. With ``character`` given, each foot is then
    held still on the ground through its contacts measured in the take by
    two-bone IK (:func:`quadsim.horse.legs.pin_stance`), and the touchdowns
    are labelled from the result.

    Raises
    ------
    InputError
        When the take has no two touchdowns of the reference foot, no steady
        cycle, or a cycle that does not loop (first pose and the pose one
        period later differ by more than ``loop_tolerance_deg`` in any joint,
        or the root height by more than 2 cm).
    """
    if motion.foot_joints is None:
        raise InputError(f"{where}: the motion does not name its foot joints")
    fps = motion.fps
    feet = motion.foot_positions()
    c = foot_contacts(feet, fps)
    iv = stance_intervals(c, fps, feet)
    on = [s[np.isfinite(s[:, 0]), 0] for s in iv]
    ref = on[reference]
    if len(ref) < 2:
        raise InputError(f"{where}: fewer than two touchdowns of the {LEGS[reference]} foot; "
                         "cannot find a cycle")
    periods = np.diff(ref)
    med = float(np.median(periods[len(periods) // 2:]))
    steady = np.nonzero(np.abs(periods / med - 1.0) <= steady_tolerance)[0]
    # keep cycles wholly inside the take with all four feet landing in them
    steady = [k for k in steady if ref[k + 1] * fps <= len(motion) - 1]
    if not steady:
        raise InputError(f"{where}: no steady cycle (periods {np.round(periods, 3)} s)")
    cands = []
    for k in steady:
        t0, t1 = float(ref[k]), float(ref[k + 1])
        n = round((t1 - t0) * fps)
        src = t0 * fps + np.arange(n + 1) * ((t1 - t0) * fps / n)
        root, rot = sample_motion(motion, src)
        err = float(pose_distance_deg(rot[0], rot[-1]))
        dh = float(abs(root[0, 1] - root[-1, 1]))
        cands.append((max(err / loop_tolerance_deg, dh / 0.02), k, t0, t1, n, root, rot, err, dh))
    cands.sort(key=lambda x: x[0])
    if cands[0][0] > 1.0:
        _, k, t0, t1, n, root, rot, err, dh = cands[0]
        raise InputError(
            f"{where}: cannot loop a cycle: the best, at {t0:.3f}-{t1:.3f} s, has first and "
            f"last pose differing by {err:.1f} deg (allowed {loop_tolerance_deg}) and root "
            f"heights by {dh * 100:.1f} cm (allowed 2)")
    out = []
    for score, k, t0, t1, n, root, rot, err, dh in sorted(
            [c for c in cands if c[0] <= 1.0][:count], key=lambda x: x[2]):
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
            inside = ti[(ti >= t0 - 1e-9) & (ti < t1 - 1e-9)]
            if len(inside) == 0:
                raise InputError(f"{where}: foot {LEGS[i]} does not land in the cycle at "
                                 f"{t0:.3f}-{t1:.3f} s")
            phase[i] = (inside[0] - t0) / P
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
                stance.append((s_i - t0) * scale)
            cyc = pin_cycle(character, cyc, speed, stance)
            td = label_touchdowns(cyc, speed)
        out.append(Cycle(cyc, n, td, speed, lead, err, t0))
    return out


def label_touchdowns(cycle: Motion, speed: float) -> np.ndarray:
    """Touchdown frame of each foot in a looped cycle, measured, shape (4,)."""
    n = len(cycle)
    three = looped(cycle, 3, speed)
    feet = three.foot_positions()
    iv = stance_intervals(foot_contacts(feet, cycle.fps), cycle.fps, feet)
    td = np.zeros(4, dtype=int)
    for i in range(4):
        on = iv[i][np.isfinite(iv[i][:, 0]), 0] * cycle.fps
        on = on[(on >= n - 0.5) & (on < 2 * n - 0.5)]
        if len(on) == 0:
            raise InputError(f"foot {LEGS[i]} does not land in the cycle")
        td[i] = round(on[0] - n) % n
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
    from .legs import pin_stance

    n = len(cycle)
    three = looped(cycle, 3, speed)
    if stance is None:
        c = foot_contacts(three.foot_positions(), cycle.fps)
    else:
        c = contacts_from_stance(stance, n, 3)
    pinned = pin_stance(character, three, c)
    return Motion(cycle.skeleton, cycle.fps, cycle.root_positions, pinned.rotations[n:2 * n],
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
    "LEGS",
    "LOOP_TOLERANCE_DEG",
    "Clip",
    "ClipDatabase",
    "Cycle",
    "clip_folder",
    "contacts_from_stance",
    "cut_cycles",
    "cycle_stance",
    "playable_gaits",
    "label_touchdowns",
    "load_database",
    "load_default_database",
    "looped",
    "pin_cycle",
    "pose_distance_deg",
    "sample_motion",
]
