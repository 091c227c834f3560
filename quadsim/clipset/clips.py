"""The clips of a set, each made from one run of the procedural controller.

Every clip is a :class:`Clip`: the motion at the set's frame rate, its packed
plans (:mod:`quadsim.clipset.rows`) and what it is. The makers:

- :func:`cycle_clips`: a gait held at a speed (and turn rate): the loop with
  root motion and its in-place twin, cut at the left hind foot's touchdown,
  ``N + 1`` frames whose last is the first carried on by the loop's travel
  (in place: the first itself), so an engine that plays the last key and wraps
  sees no seam;
- :func:`start_clip`: standing to a gait's loop, ending on the loop's first frame
  (the touchdown);
- :func:`stop_clip`: from a loop's first frame to standing still;
- :func:`transition_clip`: from one gait's loop to another's, start and end on
  the loops' first frames.

Clips that end on a loop are stepped so that the touchdown they end on falls on
a frame: the step is set, by a few reruns, to the touchdown's time over a whole
number of frames (labelled at the set's frame rate, like the loops).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from quadsim.clipset.rows import close_loop, in_place, on_path, place, pose_rows, turn
from quadsim.clipset.stepper import Stepper, steady_cycle
from quadsim.commands import Command
from quadsim.locomotion.pose_kernel import FEET, HEADING, ROOT
from quadsim.skeleton.motion import Motion

__all__ = ["Clip", "blend_into", "cycle_clips", "speed_label", "start_clip", "stop_clip",
           "tiled", "transition_clip"]

#: Warm-up before a loop is cut: this long at least, plus the time to reach the
#: speed at the controller's acceleration (s).
WARM_SECONDS = 3.0
#: A clip into a loop settles this long after reaching its speed before it ends (s).
SETTLE_SECONDS = 3.0
#: Longest stop (s): standing still is found sooner.
MAX_STOP_SECONDS = 8.0
#: Strides (at most half the clip) over which a clip's end eases into the loop it joins.
BLEND_STRIDES = 2
_FEET = slice(FEET, FEET + 12)
#: A stop ends once no foot moved more than this (m or rad) for
#: :data:`STILL_SECONDS`.
STILL = 1e-5
STILL_SECONDS = 0.25


@dataclass(frozen=True, eq=False)
class Clip:
    """One animation of a clip set.

    Attributes
    ----------
    name : str
        ``walk_1.0``, ``walk_1.0_inplace``, ``trot_turn_left_30``, ``start_walk``,
        ``stop_walk``, ``walk_to_trot``.
    kind : str
        ``"cycle"``, ``"turn"``, ``"start"``, ``"stop"`` or ``"transition"``.
    motion : Motion
        At the set's frame rate; frame 0 at the left hind foot's touchdown for every
        clip that starts in a gait.
    rows : ndarray, shape (T, F)
        The packed plans posed into ``motion``.
    loop : bool
        The last frame is the first carried on by the loop's travel.
    root_motion : bool
        The root travels (False: in place, the root above the origin).
    info : dict
        ``gait``, ``speed`` (m/s, commanded), ``turn_rate_deg_s``, ``strides``,
        ``time_scale`` (simulated over labelled time), ``closure`` and others by kind.
    """

    name: str
    kind: str
    motion: Motion
    rows: np.ndarray
    loop: bool
    root_motion: bool
    info: dict = field(default_factory=dict)

    @property
    def frames(self) -> int:
        return self.motion.n_frames


def speed_label(v: float) -> str:
    """A speed as clip names give it (m/s, one decimal)."""
    return f"{v:.1f}"


def _warm(stepper: Stepper, speed: float) -> float:
    return WARM_SECONDS + speed / stepper.ctl.settings.acceleration


def _motion(character, rows, fps, rec) -> Motion:
    """The motion of placed plans ``rows`` with the recording's contacts, gaits, phases
    (stride fractions), speeds (m/s), duty factors and the rows' headings (rad)."""
    return pose_rows(character, rows, fps, contacts=rec.contacts, gaits=rec.gaits,
                     extras={"phase": np.mod(rec.theta / (2 * np.pi), 1.0),
                             "speed": rec.speed, "duty": rec.duty,
                             "heading": rows[:, HEADING]})


def cycle_clips(character, gait: str, speed: float, fps: float, *, turn_deg_s: float = 0.0,
                seed: int = 0) -> tuple[Clip, Clip, Stepper]:
    """A gait's loop at ``speed`` (m/s) and turn rate (deg/s, left positive), with root
    motion and in place, and the stepper left at the loop's end (its first frame again).

    Returns
    -------
    root_motion, in_place : Clip
    stepper : Stepper
    """
    stepper = Stepper(character, gait=gait, seed=seed)
    cmd = Command(speed=speed, gait=gait, turn_rate=math.radians(turn_deg_s))
    rec, n, gap = steady_cycle(stepper, cmd, fps, warm=_warm(stepper, speed))
    path = place(rec.rows)
    local, _ = close_loop(in_place(path))
    moving = on_path(local, path)
    base = {"gait": gait, "speed": float(speed), "turn_rate_deg_s": float(turn_deg_s),
            "strides": int(n), "time_scale": float(rec.dt * fps), "closure": float(gap),
            "simulated_step_s": rec.dt}
    label = speed_label(speed)
    if turn_deg_s:
        side = "left" if turn_deg_s > 0 else "right"
        name, kind = f"{gait}_turn_{side}_{round(abs(turn_deg_s))}", "turn"
    else:
        name, kind = f"{gait}_{label}", "cycle"
    rm = Clip(name, kind, _motion(character, moving, fps, rec), moving, True, True, dict(base))
    ip = Clip(f"{name}_inplace", kind, _motion(character, local, fps, rec), local, True, False,
              dict(base))
    # the seam: how far the closed loop's last frame is from the simulated one
    for clip, sim in ((rm, path[-1:]), (ip, in_place(path[-1:]))):
        P = pose_rows(character, sim, fps).world_positions()[0]
        clip.info["seam_m"] = float(np.linalg.norm(P - clip.motion.world_positions()[-1],
                                                   axis=-1).max())
    return rm, ip, stepper


def _ending_on_touchdown(stepper: Stepper, command: Command, dt: float, settle: float,
                         reruns: int = 12) -> tuple:
    """Record from the stepper's present state under ``command`` until the left hind
    foot's first touchdown after ``settle`` seconds, the step set so that the touchdown
    falls on a frame: the secant method on the step, for the whole number of steps nearest
    to the first run's. Returns the recording and how far its last step missed a whole one
    (a fraction of a step)."""
    saved = stepper.state_copy()
    settle_steps = max(int(round(settle / dt)), 1)
    target = None

    def run(step):
        nonlocal target
        stepper.restore(saved)
        stepper.record()
        for _ in range(settle_steps):
            stepper.step(command, step)
        rest, target = stepper.to_touchdown(command, step, target)
        rec = stepper.take(step)
        steps = len(rec) - 1
        return rec, (steps - 1 + rest / step if rest > 0 else steps), rest

    first, w0, rest0 = run(dt)
    best = (first, abs(w0 - round(w0)), rest0, dt)
    # the touchdown's time moves little with the step, but jumps where a decision of the
    # controller moves to the next step: try the nearest whole numbers of steps in turn
    for k in sorted({max(int(math.floor(w0)) + j, 1) for j in (-1, 0, 1, 2)},
                    key=lambda k: abs(k - w0)):
        tried = [(dt, w0)]
        step = dt * w0 / k
        for _ in range(reruns):
            rec, whole, rest = run(step)
            miss = abs(whole - k)
            if miss < best[1]:
                best = (rec, miss, rest, step)
            if miss < 1e-6:
                break
            tried.append((step, whole))
            (d0, x0), (d1, x1) = tried[-2], tried[-1]
            step = d1 - (x1 - k) * (d1 - d0) / (x1 - x0) if x1 != x0 else d1 * x1 / k
            if not 0.97 * dt < step < 1.03 * dt:
                break
        if best[1] < 1e-6:
            break
    rec, miss, rest, step = best
    if 0 < rest < 0.5 * step:   # the last step a sliver: its frame is the one before
        rec = _drop_last(rec)
    return rec, miss


def _drop_last(rec):
    from copy import copy

    out = copy(rec)
    for k in ("rows", "contacts", "theta", "gaits", "speed", "duty", "freq"):
        setattr(out, k, getattr(rec, k)[:-1])
    return out


def _to_loop(character, stepper, command, loop: Clip, fps, name, kind, info, start_rows=None):
    dt = loop.info["simulated_step_s"]
    settle = SETTLE_SECONDS + abs(command.speed - stepper.ctl.speed) / \
        stepper.ctl.settings.acceleration
    rec, miss = _ending_on_touchdown(stepper, command, dt, settle)
    rows = place(rec.rows)
    before = _join(rows[-1], loop.rows[0])
    rows = blend_into(rows, loop)
    feet = _join(rows[-1], loop.rows[0], _FEET)
    info = dict(info, simulated_step_s=rec.dt, end_miss_steps=float(miss),
                joins=loop.name, join_error_unblended=before,
                join_error=_join(rows[-1], loop.rows[0]), join_feet_m=feet,
                time_scale=float(rec.dt * fps))
    return Clip(name, kind, _motion(character, rows, fps, rec), rows, False, True, info)


def blend_into(rows: np.ndarray, loop: Clip) -> np.ndarray:
    """Plans of a clip that ends on ``loop``'s first frame (at the same phase) with the
    body's values over their last strides eased into the loop's, seen from the clip's own
    root path; the feet stay where the clip planted them (easing a planted foot would
    slide it). Some gaits have more than one steady state -- the spine's pitch in a canter
    reached from the trot, the tail's lag -- so the ease takes :data:`BLEND_STRIDES`
    strides, at most a third of the clip."""
    own, theirs = in_place(rows), in_place(loop.rows)
    N = len(theirs) - 1
    W = min(BLEND_STRIDES * N // max(loop.info.get("strides", 1), 1), (len(rows) - 1) // 3)
    if W < 1:
        return rows
    j = np.arange(W + 1)
    s = 1.0 - j / W
    w = (s * s * (3.0 - 2.0 * s))[:, None]           # smoothstep: 1 at the end, 0 at W
    ends = len(own) - 1 - j
    body = np.ones(own.shape[1], dtype=bool)
    body[_FEET] = False
    eased = (1.0 - w) * own[ends] + w * theirs[np.mod(N - j, N)]   # the loop repeats
    own[np.ix_(ends, body)] = eased[:, body]
    return on_path(own, rows)


def _join(a: np.ndarray, b: np.ndarray, columns=slice(None)) -> float:
    """The largest difference of two plans seen from their own roots (m or rad), of all
    values or of ``columns``."""
    ab = in_place(np.stack([a, b]))
    return float(np.abs(ab[0, columns] - ab[1, columns]).max())


def start_clip(character, loop: Clip, fps: float, *, seed: int = 0,
               stand_seconds: float = 1.0) -> Clip:
    """Standing still to ``loop`` (a root-motion cycle), named ``start_<gait>``."""
    gait, speed = loop.info["gait"], loop.info["speed"]
    stepper = Stepper(character, seed=seed)
    stepper.run(Command(speed=0.0), stand_seconds, 1.0 / fps)
    cmd = Command(speed=speed, gait=gait)
    return _to_loop(character, stepper, cmd, loop, fps, f"start_{gait}", "start",
                    {"gait": gait, "speed": float(speed), "from_gait": "stand"})


def stop_clip(character, loop: Clip, stepper: Stepper, fps: float) -> Clip:
    """From ``loop``'s first frame (``stepper`` there, as :func:`cycle_clips` leaves it) to
    standing still, named ``stop_<gait>``."""
    gait = loop.info["gait"]
    dt = loop.info["simulated_step_s"]
    cmd = Command(speed=0.0)
    stepper.record()
    still, last = 0, None
    for _ in range(int(MAX_STOP_SECONDS / dt)):
        stepper.step(cmd, dt)
        row = stepper.last_row
        moved = np.inf if last is None else float(np.abs(row[_FEET] - last[_FEET]).max())
        last = row
        still = still + 1 if (moved < STILL and stepper.ctl.gait == "stand") else 0
        if still * dt >= STILL_SECONDS:
            break
    rec = stepper.take(dt)
    rows = place(rec.rows)
    info = {"gait": gait, "speed": loop.info["speed"], "to_gait": "stand",
            "from": loop.name, "start_error": _join(rows[0], loop.rows[0]),
            "time_scale": float(dt * fps), "still": bool(still * dt >= STILL_SECONDS)}
    return Clip(f"stop_{gait}", "stop", _motion(character, rows, fps, rec), rows, False, True,
                info)


def transition_clip(character, source: Clip, stepper: Stepper, target: Clip,
                    fps: float) -> Clip:
    """From ``source``'s first frame (``stepper`` there) to ``target``'s, named
    ``<gait>_to_<gait>``; both root-motion cycles."""
    a, b = source.info["gait"], target.info["gait"]
    cmd = Command(speed=target.info["speed"], gait=b)
    clip = _to_loop(character, stepper, cmd, target, fps, f"{a}_to_{b}", "transition",
                    {"gait": a, "to_gait": b, "speed": source.info["speed"],
                     "to_speed": target.info["speed"], "from": source.name})
    clip.info["start_error"] = _join(clip.rows[0], source.rows[0])
    return clip


def tiled(clip: Clip, copies: int) -> np.ndarray:
    """A loop's plans played ``copies`` times end to end, each carried on by the loop's
    travel: ``copies * N + 1`` rows."""
    rows = clip.rows
    step = rows[-1, HEADING] - rows[0, HEADING]
    shift = rows[-1, [ROOT, ROOT + 2]]
    out, cur = [rows[:-1]], rows
    for _ in range(copies - 1):
        cur = turn(cur, step, shift) if clip.root_motion else cur
        out.append(cur[:-1])
    out.append(cur[-1:])
    return np.concatenate(out)
