"""Making a sweep's clips: generated in batches, measured, turned into file bytes.

The clips of one character (with the same length and frame rate) are
stepped together by one :class:`~quadsim.locomotion.batch.BatchController`,
posed at every step, and cut into one :class:`~quadsim.skeleton.motion.Motion`
each. Every row follows exactly the path of a lone controller -- the same
compiled kernels, row by row -- so a clip is bit for bit the motion
:func:`quadsim.simulate` makes of the same character, command and seed, and
it does not matter which other clips share its batch (tests hold both).
Fewer than :data:`BATCH_MIN_ROWS` clips are simulated one by one instead,
which is faster for so few.

As each step is posed, its local rotation matrices become the clips'
quaternions and, while still in the cache, the forward kinematics *of those
quaternions* (:mod:`quadsim.dataset.kernels`), which each motion is handed:
the very numbers it would compute itself. A batch's motions are then
measured together (:func:`measure_clips`,
:func:`quadsim.analysis.measure.measure_motions`: their contacts, touchdowns
and per-frame arrays in one pass, each clip's figures read from its own),
which gives every clip exactly the figures, contacts and file it would have
measured alone -- so a resumed run, which batches other clips together,
writes the same bytes (tests hold it).

A clip's file is made in memory (:func:`clip_bytes`): an ``.npz`` holds the
arrays of :func:`quadsim.io.npz.npz_arrays`, stored uncompressed in a zip
whose every entry has the same fixed date, so the bytes depend on the motion
alone; ``.bvh`` and ``.glb`` come from :func:`quadsim.save`.
"""

from __future__ import annotations

import math
import tempfile
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from quadsim.dataset.grid import ClipSpec

__all__ = ["BATCH_MIN_ROWS", "ZIP_DATE", "clip_bytes", "generate", "make_clips", "measure",
           "measure_clip", "measure_clips", "npz_bytes"]

#: The date every entry of a sweep's ``.npz`` carries (zip's earliest).
ZIP_DATE = (1980, 1, 1, 0, 0, 0)
#: Fewest clips stepped together by a BatchController: below, each clip is
#: simulated alone, which is faster there (the same bytes either way).
BATCH_MIN_ROWS = 5

_CHARACTERS: dict[tuple[str, str], object] = {}
_ANATOMY: dict[tuple, tuple] = {}  # each skeleton's anatomy, found once


def _load(spec: ClipSpec):
    """The spec's character, loaded once per process."""
    from quadsim.errors import InputError
    from quadsim.skeleton.character import load_character

    key = (spec.source, spec.digest)
    ch = _CHARACTERS.get(key)
    if ch is None:
        ch = load_character(spec.source)
        if spec.digest:
            import hashlib

            if hashlib.sha256(Path(spec.source).read_bytes()).hexdigest() != spec.digest:
                raise InputError(f"{spec.source}: the character file changed since the grid "
                                 "was read; run the sweep again")
        _CHARACTERS[key] = ch
    return ch


def generate(specs: Sequence[ClipSpec]) -> list:
    """The motions of clips of one character, length and frame rate, stepped together.

    Parameters
    ----------
    specs : sequence of ClipSpec, length N
        All with the same ``source``, ``seconds`` and ``fps``.

    Returns
    -------
    list of Motion
        One per spec, ``frames`` long, as :func:`quadsim.simulate` gives it
        (planned contacts, gait labels, extras), its forward kinematics
        already found; fewer than :data:`BATCH_MIN_ROWS` clips are simulated
        one by one. A batch's motions hold read-only views of the batch's
        arrays (one motion kept keeps them all: copy it, ``m[:]``, to let
        the rest go).
    """
    from quadsim.config import constant_command
    from quadsim.dataset.kernels import quaternions_and_kinematics
    from quadsim.locomotion.batch import BatchController
    from quadsim.skeleton.fk import skeleton_plan
    from quadsim.skeleton.motion import Motion

    first = specs[0]
    if any((s.source, s.seconds, s.fps) != (first.source, first.seconds, first.fps)
           for s in specs):
        raise ValueError("generate() takes clips of one character, length and frame rate")
    ch = _load(first)
    n, T, dt = len(specs), first.frames, 1.0 / first.fps
    cmds = [constant_command(ch, speed=s.speed, gait=s.gait, turn_rate_deg_s=s.turn_rate_deg_s)
            for s in specs]
    if n < BATCH_MIN_ROWS:
        from quadsim.api import simulate

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return [simulate(ch, c, seconds=s.seconds, fps=s.fps, seed=s.seed)
                    for s, c in zip(specs, cmds)]
    b = BatchController([ch] * n, dt=dt, seeds=[s.seed for s in specs],
                        gaits=[c.gait for c in cmds])
    speed = np.array([c.speed for c in cmds], dtype=float)
    turn = np.array([c.turn_rate or 0.0 for c in cmds], dtype=float)
    gait = b.gait_ids([c.gait for c in cmds])
    J = ch.skeleton.n_joints
    plan = skeleton_plan(ch.skeleton)
    # clip-major arrays, one frame of every clip written a step: each clip's own
    # arrays are then contiguous; the step's matrices become quaternions and the
    # forward kinematics of those while still in the cache (quadsim.dataset.kernels)
    a = _skeleton_anatomy(ch.skeleton, ch.foot_joints)
    keep = _kept_rotations(a)
    quats, G, P = np.empty((n, T, J, 4)), np.empty((n, T, len(keep), 3, 3)), np.empty((n, T, J, 3))
    root, contacts = np.empty((n, T, 3)), np.empty((n, T, 4), dtype=bool)
    heading, spine, v, duty = (np.empty((n, T)) for _ in range(4))
    err, amp, theta = np.empty((n, T, 4)), np.empty((n, T, 5)), np.empty((n, T, 4))
    labels = []
    st = b.state
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # clamps: the measured figures show them
        for k in range(T):
            # frame 0 is the starting state (a step of 0 s), as quadsim.simulate
            fr = b.step(speed, turn, None, gait, dt if k else 0.0, pose=True)
            quaternions_and_kinematics(fr["local_rotations"][0], fr["root"], plan, keep,
                                       quats[:, k], G[:, k], P[:, k])
            err[:, k], root[:, k], contacts[:, k] = fr["ik_error"][0], fr["root"], fr["contacts"]
            heading[:, k], spine[:, k], v[:, k] = fr["heading"], fr["spine"], fr["speed"]
            duty[:, k], amp[:, k], theta[:, k] = fr["duty"], fr["amplitude"], st.cpg.theta
            labels.append(b.labels)
    phase = np.mod(theta / (2.0 * math.pi), 1.0)
    gaits = np.ascontiguousarray(np.array(labels, dtype=object).T)  # (n, T)
    out = []
    for i in range(n):
        # the batch's own arrays, in the form Motion(...) would check and copy them to
        m = Motion._of_checked_arrays(
            ch.skeleton, first.fps, root[i], quats[i], contacts[i], gaits[i], ch.foot_joints,
            {"phase": phase[i], "spine": spine[i], "duty": duty[i], "speed": v[i],
             "ik_error": err[i], "heading": heading[i], "cpg_amplitude": amp[i]})
        m._given_kinematics(P[i], keep, G[i])
        out.append(m)
    return out


def _skeleton_anatomy(skeleton, foot_joints):
    """The anatomy of a skeleton with these foot joints (None for no quadruped), found
    once."""
    from quadsim.skeleton.anatomy import find_anatomy

    key = (id(skeleton), tuple(foot_joints))
    hit = _ANATOMY.get(key)
    if hit is None or hit[0] is not skeleton:
        try:
            a = find_anatomy(skeleton, foot_joints)
        except ValueError:  # no quadruped structure to measure the trunk and head on
            a = None
        hit = _ANATOMY[key] = (skeleton, a)
    return hit[1]


def _anatomy(motion):
    """The anatomy of the motion's skeleton (None for no quadruped), found once."""
    return _skeleton_anatomy(motion.skeleton, motion.foot_joints)


def _kept_rotations(anatomy) -> np.ndarray:
    """The joints whose world rotations a batch keeps: those measuring its motions
    reads (:func:`quadsim.analysis.appearance.appearance_many`: the feet, for their
    toe tips, and the head)."""
    if anatomy is None:
        return np.zeros(0, dtype=np.int64)
    return np.array(list(dict.fromkeys([*anatomy.feet, anatomy.head])), dtype=np.int64)


def measure_clip(motion):
    """:func:`measure`'s figures and the motion's measured contacts, each found once
    (:func:`quadsim.analysis.measure.measure_motion`): ``.report`` and ``.contacts``."""
    from quadsim.analysis.measure import measure_motion

    a = _anatomy(motion)
    return measure_motion(motion, anatomy=a, appearance=a is not None)


def measure_clips(motions) -> list:
    """:func:`measure_clip` of each of a batch's motions (one character, length and frame
    rate), their contacts found together
    (:func:`quadsim.analysis.measure.measure_motions`): the same figures and contacts."""
    from quadsim.analysis.measure import measure_motions

    if not motions:
        return []
    a = _anatomy(motions[0])
    return measure_motions(motions, anatomy=a, appearance=a is not None)


def measure(motion) -> dict:
    """The figures ``quadsim metrics --json`` reports of ``motion``: footfalls, duty
    factors, phases, stride, speed, slide, penetration, smoothness and, under
    ``appearance``, what a viewer sees (None when it cannot be measured)."""
    return measure_clip(motion).report


def npz_bytes(motion, contacts=None) -> bytes:
    """The ``.npz`` file of ``motion`` (the arrays of :func:`quadsim.io.npz.npz_arrays`,
    stored, every entry dated :data:`ZIP_DATE`): the same bytes for the same motion.
    ``contacts``: the motion's measured contacts when already found."""
    from quadsim.io.npz import npz_arrays
    from quadsim.io.stored_npz import stored_npz_bytes

    return stored_npz_bytes(npz_arrays(motion, contacts), ZIP_DATE)


def clip_bytes(motion, fmt: str, character=None) -> bytes:
    """The file of ``motion`` in format ``fmt`` (``"npz"``, ``"bvh"``, ``"glb"``)."""
    if fmt == "npz":
        return npz_bytes(motion)
    from quadsim.api import save

    with tempfile.TemporaryDirectory(prefix="quadsim-sweep-") as tmp:
        path = Path(tmp) / f"clip.{fmt}"
        save(motion, path, character=character)
        return path.read_bytes()


def _groups(specs: Sequence[ClipSpec]) -> list[list[ClipSpec]]:
    groups: dict[tuple, list[ClipSpec]] = {}
    for s in specs:
        groups.setdefault((s.source, s.digest, s.seconds, s.fps), []).append(s)
    return list(groups.values())


def make_clips(specs: Sequence[ClipSpec], out: str | None = None) -> list[dict]:
    """Generate, measure and write (or return) clips: one task of a sweep.

    Parameters
    ----------
    specs : sequence of ClipSpec
        Any clips; those of one character, length and frame rate are generated
        together.
    out : str, optional
        The sweep's folder: each clip is written atomically to
        ``out/<spec.path>``, then its line appended to the manifest
        (:func:`~quadsim.dataset.manifest.publish`). Without it the bytes are
        returned instead (a worker on another machine).

    Returns
    -------
    list of dict
        One manifest entry per spec, in the order given: ``id``, the
        parameters, ``path``, ``frames``, ``bytes`` (the file's size),
        ``metrics``; without ``out`` also ``data`` (the file's bytes).
    """
    from quadsim._version import __version__
    from quadsim.dataset.manifest import publish

    done = {}
    for group in _groups(specs):
        motions = generate(group)
        for spec, motion, measured in zip(group, motions, measure_clips(motions)):
            data = npz_bytes(motion, measured.contacts) if spec.format == "npz" else \
                clip_bytes(motion, spec.format, _load(spec))
            entry = {"id": spec.id, **spec.parameters(), "path": spec.path,
                     "frames": len(motion), "bytes": len(data), "quadsim": __version__,
                     "metrics": measured.report}
            if out is None:
                done[spec.id] = dict(entry, data=data)
            else:
                publish(out, entry, data)
                done[spec.id] = entry
    return [done[s.id] for s in specs]
