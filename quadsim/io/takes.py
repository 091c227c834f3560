"""A clip database cut out of a user's long motion-capture takes (``quadsim clips-from``).

:func:`read_take` puts a BVH take onto a character's skeleton by joint name:
each of the character's joints turns in the world as the take's joint of the
same name does (a joint the take lacks turns with its nearest ancestor that
it has; every leg joint must be there), in quadsim's frame (the take's up and
forward axes and its unit found from its rest pose, as ``quadsim rig`` finds
them), the root's path scaled by the ratio of the character's to the take's
standing root height (the take's floor is its ``y = 0``). Takes of the
character's own rig -- its extra face, helper and twist bones, another unit or
up axis -- read as they are; the take's rest pose must point its bones the
way the character's rest pose does.

:func:`measure_strides` times every stride of a take from its measured foot
contacts (:func:`quadsim.skeleton.contacts.stance_intervals`): from one
touchdown of the left hind foot to the next, each foot's touchdown phase and
duty factor, the speed, the contact time. :func:`label_gait` names the gait
of a stride from its footfalls against the character's gait tables
(:func:`quadsim.locomotion.gaits.gait_table`): the nearest touchdown phases
(asymmetric gaits mirrored for a right lead), the duty factor telling gaits of
one footfall order apart (walk and rack). :func:`steady_runs` finds runs of at
least :data:`MIN_STRIDES` strides of one gait, lead, period and speed;
:func:`cut_database` cuts the best looped cycle out of each run
(:func:`quadsim.horse.database.cut_cycles`, travel turned onto +Z, stance feet
pinned), keeps one clip per gait and speed, and fits each gait's
contact-time law ``Tc = a v^b`` to its steady strides (:func:`fit_law`).
:func:`write_database` writes the clips and their ``manifest.toml``
(:mod:`quadsim.io.clips`'s format) into a folder, whole or not at all.
"""

from __future__ import annotations

import math
import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from quadsim.errors import InputError
from quadsim.frames import LEGS
from quadsim.horse.database import ASYMMETRIC, GAIT_ALIASES, SpeedLaw, cut_cycles
from quadsim.horse.speed import DEFAULT_EXPONENT
from quadsim.kinematics.rotations import (
    matrices_about_axis,
    quaternion_multiply,
    quaternions_from_matrices,
)
from quadsim.skeleton.character import Character
from quadsim.skeleton.contacts import default_contact_thresholds, foot_contacts, stance_intervals
from quadsim.skeleton.motion import Motion

__all__ = ["LOOP_TOLERANCE_DEG", "MAX_PHASE_ERROR", "MIN_STRIDES", "CutDatabase", "Stride",
           "TakeClip", "cut_database", "fit_law", "label_gait", "measure_strides", "read_take",
           "resample", "smooth_take", "steady_runs", "write_database"]

#: Fewest strides of one gait in a row that make a steady run.
MIN_STRIDES = 3
#: Strides of a run differ from its median period by at most this fraction ...
STEADY_TOLERANCE = 0.10
#: ... and from its median speed by at most this one (a stride's speed, the root's
#: travel over it, is measured more closely than its period, which a touchdown's
#: frame moves: a dog cub's canter in a 3.0 m/s take strides 0.302 and 0.315 s in
#: turn, at 60 fps, but its stride into the gallop asked for at its end ran at
#: 3.24 m/s, and at 10 % it was cut as the canter's clip).
STEADY_SPEED_TOLERANCE = 0.05
#: On-ground band of a contact when strides are timed, as a fraction of the contact
#: height threshold (:func:`~quadsim.skeleton.contacts.default_contact_thresholds`):
#: wider than the default so that a foot's capture jitter does not move its touchdown.
CONTACT_BAND = 0.5
#: Largest mean touchdown-phase error (cycles) of a stride against its gait's table.
MAX_PHASE_ERROR = 0.08
#: Weight of the duty factor's distance from the table's range against the phase error.
DUTY_WEIGHT = 0.5
#: Loop tolerances of a cut cycle: joints (deg) and root height (m) (captured
#: strides are not whole numbers of frames; the residual is spread over the cycle).
LOOP_TOLERANCE_DEG = 15.0
ROOT_TOLERANCE = 0.05
#: Clips of one gait whose speeds differ by less than this fraction are one clip (the best kept).
SAME_SPEED = 0.06
#: Smallest spread of speeds (ratio fastest / slowest) over which an exponent ``b`` is fitted.
FIT_SPREAD = 1.15


@dataclass(frozen=True)
class Stride:
    """One stride of a take, from a left-hind touchdown to the next.

    Attributes
    ----------
    take : str
    t0, t1 : float
        Its start and end (s).
    speed : float
        Horizontal root travel over the stride / its period (m/s).
    phase, duty : ndarray, shape (4,)
        Each foot's touchdown after ``t0`` and its stance, as fractions of the period.
    contact_time : float
        Mean stance time of the four feet (s).
    gait : str or None
        The gait table's nearest gait (None: no gait within :data:`MAX_PHASE_ERROR`).
    lead : str or None
        ``"left"`` or ``"right"`` for asymmetric gaits.
    error : float
        Mean touchdown-phase error against ``gait`` (cycles).
    """

    take: str
    t0: float
    t1: float
    speed: float
    phase: np.ndarray
    duty: np.ndarray
    contact_time: float
    gait: str | None
    lead: str | None
    error: float

    @property
    def period(self) -> float:
        return self.t1 - self.t0


@dataclass(frozen=True, eq=False)
class TakeClip:
    """A clip cut from a take: a :class:`~quadsim.horse.database.Cycle` and its labels."""

    name: str
    gait: str
    speed: float
    frames: int
    touchdown: np.ndarray
    lead: str | None
    motion: Motion
    take: str
    start_time: float
    loop_error_deg: float
    strides: int


@dataclass(frozen=True, eq=False)
class CutDatabase:
    """What :func:`cut_database` found: the clips, the fitted laws, the strides.

    ``laws`` maps a gait to its :class:`~quadsim.horse.database.SpeedLaw`,
    ``fits`` to ``(strides, slowest, fastest, rms)`` (m/s; rms of ``log Tc``
    about the fit); ``notes`` say what was skipped and why.
    """

    character: Character
    clips: list
    laws: dict
    fits: dict
    strides: list
    notes: list = field(default_factory=list)


# ------------------------------------------------------------------ reading
def read_take(path, character: Character) -> Motion:
    """A BVH take on the character's skeleton, by joint name (see the module notes).

    Raises
    ------
    InputError
        For an unreadable file, a take lacking some of the character's leg
        joints (named, with the fix) or with no frames.
    """
    from quadsim.io.bvh import read_bvh
    from quadsim.io.bvh_rig import read_bvh_rig

    path = Path(path)
    sk = character.skeleton
    raw = read_bvh(path, units="m")
    names = raw.skeleton.names
    legs = [sk.names[j] for leg in character.legs for j in leg.chain]
    # a foot of quadsim's own (the adopted rig's `<foot>_toe`) follows its rig foot
    missing = [n for n in legs if n not in names and not _own_toe(n, names)]
    if missing:
        raise InputError(
            f"{path}: the take lacks leg joint(s) of {character.id}: "
            f"{', '.join(missing[:8])}{' ...' if len(missing) > 8 else ''}; takes are read "
            "onto the character by joint name: rename the take's joints to the character "
            "file's (its [legs.*] chains) or adopt the take's rig with `quadsim rig`")
    if sk.names[0] not in names:
        raise InputError(f"{path}: the take has no joint {sk.names[0]!r} (the character's "
                         "root); rename the take's pelvis joint to it")
    if len(raw) < 2:
        raise InputError(f"{path}: the take has {len(raw)} frame(s); a take needs many strides")
    feet = [n if n in names else n[:-4] for n in character.foot_joints]
    rig = read_bvh_rig(path, feet=feet)
    A, scale = rig.axes, rig.scale
    index = {n: k for k, n in enumerate(names)}
    src = np.full(sk.n_joints, -1)
    for j, n in enumerate(sk.names):
        if n in index:
            src[j] = index[n]
        elif sk.parents[j] >= 0:
            src[j] = src[sk.parents[j]]
    G = raw.world_rotations()[:, src]                      # (T, J, 3, 3), take's frame
    W = A @ G @ A.T
    L = np.empty_like(W)
    L[:, 0] = W[:, 0]
    L[:, 1:] = np.swapaxes(W[:, sk.parents[1:]], -1, -2) @ W[:, 1:]
    rot = quaternions_from_matrices(L)
    P = raw.world_positions()[:, index[sk.names[0]]] @ A.T * scale
    P0 = raw.skeleton.rest_positions @ A.T * scale
    foot_ids = [index[n] for n in feet]
    take_h = float(P0[index[sk.names[0]], 1] - P0[foot_ids, 1].mean())
    char_h = float(sk.rest_positions[0, 1] - character.rest_foot_positions()[:, 1].mean())
    if not take_h > 0:
        raise InputError(f"{path}: the take's root {sk.names[0]!r} is not above its feet at "
                         "rest; is the take upside down or its rest pose not standing?")
    root = P * (char_h / take_h)                # the take's floor is its y = 0
    return Motion(sk, raw.fps, root, rot, foot_joints=character.foot_joints)


def smooth_take(motion: Motion, sigma: float = 1.0) -> Motion:
    """The take low-passed in time: a Gaussian of ``sigma`` frames (0: unchanged) over
    the root's path and each joint's rotation (quaternions aligned to the previous
    frame's hemisphere, averaged and normalised). Capture noise of a few tenths of a
    degree per joint moves a foot by millimetres per frame, which breaks its contacts
    into pieces; a frame of smoothing keeps them whole."""
    if not sigma > 0:
        return motion
    r = max(int(math.ceil(3 * sigma)), 1)
    w = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    w /= w.sum()
    q = np.array(motion.rotations)
    flip = np.sum(q[1:] * q[:-1], axis=-1) < 0
    sign = np.concatenate([np.ones((1, q.shape[1])), np.where(flip, -1.0, 1.0)])
    q *= np.cumprod(sign, axis=0)[..., None]

    def conv(x):
        pad = np.concatenate([np.repeat(x[:1], r, 0), x, np.repeat(x[-1:], r, 0)])
        return sum(wk * pad[k:k + len(x)] for k, wk in enumerate(w))

    q = conv(q)
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return Motion(motion.skeleton, motion.fps, conv(np.asarray(motion.root_positions)), q,
                  foot_joints=motion.foot_joints)


def resample(motion: Motion, fps: float) -> Motion:
    """The take at another frame rate (root linearly, joints by slerp, same duration)."""
    from quadsim.horse.database import sample_motion

    n = int(math.floor((len(motion) - 1) * fps / motion.fps + 1e-9)) + 1
    root, rot = sample_motion(motion, np.arange(n) * (motion.fps / fps))
    return Motion(motion.skeleton, fps, root, rot, foot_joints=motion.foot_joints)


def _own_toe(name: str, names) -> bool:
    return name.endswith("_toe") and name[:-4] in names


# ------------------------------------------------------------------ strides
def _gait_patterns(character: Character) -> list[tuple[str, str | None, np.ndarray, tuple]]:
    """(clip gait, lead, phases (4,), duty range) of every gait the character has."""
    from quadsim.locomotion.gaits import gait_table

    out = []
    for name, g in gait_table(character).items():
        clip_gait = GAIT_ALIASES.get(name, name)
        ph = np.asarray(g.phases, dtype=float)
        duty = (min(g.duty_range), max(g.duty_range))
        if clip_gait in ASYMMETRIC:
            out.append((clip_gait, "left", ph, duty))
            m = ph[[1, 0, 3, 2]]                 # mirrored: right lead, re-timed from LH
            out.append((clip_gait, "right", (m - m[2]) % 1.0, duty))
        else:
            out.append((clip_gait, None, ph, duty))
    return out


def label_gait(phase: np.ndarray, duty: np.ndarray, character: Character
               ) -> tuple[str | None, str | None, float]:
    """The gait of a stride from its touchdown phases and duty factors (4,) each.

    Returns ``(gait, lead, error)``: the character's gait whose table phases
    are nearest (mean circular distance, cycles) plus :data:`DUTY_WEIGHT` times
    the mean duty factor's distance from the table's duty range; ``gait`` is
    None when the nearest phase error exceeds :data:`MAX_PHASE_ERROR`.
    """
    best = (math.inf, None, None, math.inf)
    d = float(np.mean(duty))
    for gait, lead, ph, (lo, hi) in _gait_patterns(character):
        err = float(np.mean(np.abs((np.asarray(phase) - ph + 0.5) % 1.0 - 0.5)))
        off = max(lo - d, d - hi, 0.0)
        score = err + DUTY_WEIGHT * off
        if score < best[0]:
            best = (score, gait, lead, err)
    if best[3] > MAX_PHASE_ERROR:
        return None, None, best[3]
    return best[1], best[2], best[3]


def measure_strides(motion: Motion, character: Character, take: str = "take") -> list[Stride]:
    """Every stride of a take from its measured foot contacts, in time order.

    A stride runs from a touchdown of the left hind foot to its next; one in
    which some foot does not land, or whose contacts are cut by the take's
    ends, is left out.
    """
    fps = motion.fps
    feet = motion.foot_positions()
    tol = CONTACT_BAND * default_contact_thresholds(feet)[0]
    iv = stance_intervals(foot_contacts(feet, fps, tolerance=tol), fps, feet, tolerance=tol)
    iv = [s[np.isfinite(s).all(axis=1)] for s in iv]
    ref = iv[LEGS.index("LH")][:, 0]
    t = np.arange(len(motion)) / fps
    xz = motion.root_positions[:, [0, 2]]
    out = []
    for t0, t1 in zip(ref[:-1], ref[1:]):
        P = t1 - t0
        phase, duty = np.zeros(4), np.zeros(4)
        ok = True
        for i, s in enumerate(iv):
            # a foot landing with the left hind (a trot's diagonal) may land a hair before it
            k = np.nonzero((s[:, 0] >= t0 - 0.5 / fps) & (s[:, 0] < t1 - 0.5 / fps))[0]
            if len(k) == 0:
                ok = False
                break
            on, off = s[k[0]]
            phase[i], duty[i] = (on - t0) / P, (off - on) / P
        if not ok:
            continue
        p0 = np.array([np.interp(t0, t, xz[:, 0]), np.interp(t0, t, xz[:, 1])])
        p1 = np.array([np.interp(t1, t, xz[:, 0]), np.interp(t1, t, xz[:, 1])])
        speed = float(np.linalg.norm(p1 - p0) / P)
        gait, lead, err = label_gait(phase, duty, character)
        out.append(Stride(take, float(t0), float(t1), speed, phase, duty,
                          float(duty.mean() * P), gait, lead, err))
    return out


def steady_runs(strides: list[Stride], min_strides: int = MIN_STRIDES) -> list[list[Stride]]:
    """Runs of at least ``min_strides`` consecutive strides of one gait and lead whose
    periods lie within :data:`STEADY_TOLERANCE` of the run's median and speeds within
    :data:`STEADY_SPEED_TOLERANCE` of its median."""
    runs, cur = [], []

    def steady(run):
        P = np.median([s.period for s in run])
        v = np.median([s.speed for s in run])
        return all(abs(s.period / P - 1) <= STEADY_TOLERANCE
                   and abs(s.speed / max(v, 1e-9) - 1) <= STEADY_SPEED_TOLERANCE for s in run)

    for s in strides:
        joined = (cur and s.gait is not None and s.gait == cur[-1].gait
                  and s.lead == cur[-1].lead and abs(s.t0 - cur[-1].t1) < 1e-6
                  and steady(cur + [s]))
        if joined:
            cur.append(s)
            continue
        if len(cur) >= min_strides:
            runs.append(cur)
        cur = [s] if s.gait is not None else []
    if len(cur) >= min_strides:
        runs.append(cur)
    return runs


# ------------------------------------------------------------------ cutting
def _facing_z(motion: Motion) -> Motion:
    """The motion turned about +Y so that its travel from first to last frame is along +Z."""
    d = motion.root_positions[-1] - motion.root_positions[0]
    yaw = math.atan2(d[0], d[2])
    if abs(yaw) < 1e-9:
        return motion
    R = matrices_about_axis(1, np.array(-yaw))
    root = motion.root_positions @ R.T
    q = quaternions_from_matrices(R)
    rot = np.array(motion.rotations)
    rot[:, 0] = quaternion_multiply(np.broadcast_to(q, rot[:, 0].shape), rot[:, 0])
    return Motion(motion.skeleton, motion.fps, root, rot, foot_joints=motion.foot_joints)


def _cut_run(motion: Motion, run: list[Stride], character: Character, where: str):
    fps = motion.fps
    a = max(int(math.floor((run[0].t0 - 0.5 * run[0].period) * fps)), 0)
    b = min(int(math.ceil((run[-1].t1 + 0.5 * run[-1].period) * fps)) + 1, len(motion))
    part = _facing_z(motion[a:b])
    tol = CONTACT_BAND * default_contact_thresholds(part.foot_positions())[0]
    cyc = cut_cycles(part, character=character, where=where, steady_tolerance=STEADY_TOLERANCE,
                     loop_tolerance_deg=LOOP_TOLERANCE_DEG, root_tolerance=ROOT_TOLERANCE,
                     contact_tolerance=tol)[0]
    return cyc, a / fps


def fit_law(points: np.ndarray, anchor: str = "law") -> tuple[SpeedLaw, float]:
    """``Tc = a v^b`` fitted to strides' ``(speed m/s, contact time s)`` rows, shape (n, 2).

    Least squares on ``log Tc = log a + b log v``; over speeds spread less than
    :data:`FIT_SPREAD` the exponent is :data:`DEFAULT_EXPONENT` and only ``a``
    is fitted. Returns the law and the rms residual of ``log Tc``.
    """
    p = np.asarray(points, dtype=float)
    lv, lt = np.log(p[:, 0]), np.log(p[:, 1])
    if lv.max() - lv.min() >= math.log(FIT_SPREAD) and len(p) >= 2:
        b, la = np.polyfit(lv, lt, 1)
        b = float(np.clip(b, -3.0, 0.5))
        la = float(np.mean(lt - b * lv))
    else:
        b = DEFAULT_EXPONENT
        la = float(np.mean(lt - b * lv))
    rms = float(np.sqrt(np.mean((lt - la - b * lv) ** 2)))
    return SpeedLaw(math.exp(la), b, anchor), rms


def cut_database(takes: list[tuple[str, Motion]], character: Character) -> CutDatabase:
    """Cut a clip database out of takes already on the character (:func:`read_take`).

    ``takes`` are ``(name, motion)`` pairs; takes at another frame rate than
    the first are resampled to it (:func:`resample`), so every clip has one rate.

    Raises
    ------
    InputError
        When a take is too short for any stride, has no steady run of a gait,
        or no run could be cut into a looped cycle (the take named, with what
        was found and the fix).
    """
    clips, strides, notes, points = [], [], [], {}
    if takes:                          # one database, one frame rate: the first take's
        fps = takes[0][1].fps
        takes = [(n, m if m.fps == fps else resample(m, fps)) for n, m in takes]
    for name, motion in takes:
        ss = measure_strides(motion, character, name)
        strides += ss
        runs = steady_runs(ss)
        if not ss:
            raise InputError(
                f"{name}: no whole stride found in {len(motion) / motion.fps:.2f} s (the left "
                "hind foot must land at least twice with every foot landing in between); "
                "give a longer take of steady locomotion")
        if not runs:
            found = ", ".join(f"{g} x{sum((s.gait or 'unlabelled') == g for s in ss)}"
                              for g in sorted({s.gait or "unlabelled" for s in ss}))
            raise InputError(
                f"{name}: no steady gait: {len(ss)} strides ({found}) but no "
                f"{MIN_STRIDES} in a row of one gait at one speed (periods within "
                f"{STEADY_TOLERANCE:.0%} and speeds within {STEADY_SPEED_TOLERANCE:.0%}, "
                f"footfalls within {MAX_PHASE_ERROR} cycles of a gait "
                "of the character's table); leave the take out or keep longer steady stretches")
        for run in runs:
            g, lead = run[0].gait, run[0].lead
            where = f"{name}: {g} at {run[0].t0:.2f}-{run[-1].t1:.2f} s"
            try:
                cyc, t_off = _cut_run(motion, run, character, where)
            except InputError as e:
                notes.append(f"skipped {e}")
                continue
            points.setdefault(g, []).extend((s.speed, s.contact_time) for s in run)
            clips.append(TakeClip("", g, cyc.speed, cyc.frames, cyc.touchdown,
                                  lead if g in ASYMMETRIC else None, cyc.motion, name,
                                  cyc.start_time + t_off, cyc.loop_error_deg, len(run)))
    if not clips:
        raise InputError(
            "no steady gait in the takes: " + "; ".join(notes or ["no stride measured"])
            + f"; a clip needs {MIN_STRIDES} strides in a row of one gait at one speed "
            f"(periods within {STEADY_TOLERANCE:.0%} and speeds within "
            f"{STEADY_SPEED_TOLERANCE:.0%}): record or keep longer "
            "steady stretches")
    kept = _one_per_speed(clips)
    laws, fits = {}, {}
    for g, pts in points.items():
        if any(c.gait == g for c in kept):
            p = np.asarray(pts)
            laws[g], rms = fit_law(p)
            fits[g] = (len(p), float(p[:, 0].min()), float(p[:, 0].max()), rms)
    return CutDatabase(character, kept, laws, fits, strides, notes)


def _one_per_speed(clips: list[TakeClip]) -> list[TakeClip]:
    """One clip per gait (and lead) and speed (:data:`SAME_SPEED`), the best-looping, named
    ``<gait>_<speed>``, by gait then speed."""
    from quadsim.horse.database import CLIP_GAITS

    out = []
    for c in sorted(clips, key=lambda c: c.loop_error_deg):
        if not any(o.gait == c.gait and abs(math.log(o.speed / c.speed)) < SAME_SPEED
                   for o in out):
            out.append(c)
    out.sort(key=lambda c: (CLIP_GAITS.index(c.gait), c.speed))
    named, used = [], set()
    for c in out:
        base = f"{c.gait}_{c.speed:.2f}"
        name, k = base, 2
        while name in used:
            name, k = f"{base}_{k}", k + 1
        used.add(name)
        named.append(TakeClip(name, *[getattr(c, f) for f in (
            "gait", "speed", "frames", "touchdown", "lead", "motion", "take", "start_time",
            "loop_error_deg", "strides")]))
    return named


# ------------------------------------------------------------------ writing
def _manifest(cut: CutDatabase, takes: list[str]) -> str:
    lines = ["# A clip database cut by `quadsim clips-from` from the takes",
             *[f"#   {t}" for t in takes],
             f'description = "Clips of {cut.character.id} cut from {len(takes)} take(s)."', ""]
    for c in cut.clips:
        td = ", ".join(f"{leg} = {int(x)}" for leg, x in zip(LEGS, c.touchdown))
        lines += [f'[clips."{c.name}"]', f'file = "{c.name}.bvh"', f'gait = "{c.gait}"',
                  f"speed = {c.speed:.4f}", f"frames = {c.frames}", f"touchdown = {{ {td} }}"]
        if c.lead is not None:
            lines.append(f'lead = "{c.lead}"')
        lines += [f'source = "{_esc(Path(c.take).name)}: {c.strides} steady strides; the cycle '
                  f'at {c.start_time:.3f} s cut by cut_cycles (loop error '
                  f'{c.loop_error_deg:.2f} deg spread over it, stance feet pinned by IK)"', ""]
    for g, law in cut.laws.items():
        n, lo, hi, rms = cut.fits[g]
        lines += [f"[laws.{g}]", f"a = {law.a:.6g}", f"b = {law.b:.6g}",
                  f'anchor = "{law.anchor}"',
                  f'source = "fitted to {n} steady strides at {lo:.3g}-{hi:.3g} m/s '
                  f'(rms {rms:.3f} in log Tc)"', ""]
    return "\n".join(lines)


def _esc(s: str) -> str:
    return s.replace("\\", "\\\\").replace('"', '\\"')


def write_database(cut: CutDatabase, out, takes: list[str]) -> Path:
    """Write the clips (BVH, metres) and ``manifest.toml`` into the folder ``out``.

    The folder is written beside ``out`` under a temporary name and moved into
    place when complete; an existing clip database there (a folder with a
    ``manifest.toml``) is replaced, any other non-empty folder refused.

    Raises
    ------
    InputError
        When ``out`` is a file or a non-empty folder that is not a clip database.
    """
    from quadsim.io.bvh import write_bvh

    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"`--out` {out}: is a file; give a folder for the clip database")
    if out.is_dir() and any(out.iterdir()) and not (out / "manifest.toml").is_file():
        raise InputError(f"`--out` {out}: the folder holds other files and no clip database "
                         "(manifest.toml); give a new or empty folder")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.parent / f".{out.name}.{os.getpid()}.tmp"
    old = out.parent / f".{out.name}.{os.getpid()}.old"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    try:
        for c in cut.clips:
            write_bvh(c.motion, tmp / f"{c.name}.bvh", precision=6)
        (tmp / "manifest.toml").write_text(_manifest(cut, takes), encoding="utf-8")
        if out.exists():
            os.replace(out, old)
        os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        if old.exists() and not out.exists():
            os.replace(old, out)
        raise
    shutil.rmtree(old, ignore_errors=True)
    return out
