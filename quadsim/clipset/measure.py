"""What a clip set's sidecar says of each clip, measured from the clip's joint positions.

- Seams (loops): a loop's frames ``0..N`` end on the first frame carried on by the
  loop's travel ``T`` (a turn about +Y and a shift, read from the clip's root path):
  ``last_key_error_m`` is how far the last key is from ``T(P_0)``. The seam itself,
  ``seam_m`` (measured as the clip is made, :func:`~quadsim.clipset.clips.cycle_clips`),
  is how far that last frame is from where the simulation went. An engine that wraps
  from the last frame it plays to the first sees the step ``T(P_0) - P_{N-1}`` and the
  change of velocity ``T(P_1) - 2 T(P_0) + P_{N-1}`` (``wrap_step_m``,
  ``wrap_velocity_change_m``), set against the largest step and change of velocity
  inside the loop -- the motion's own, at the phase of the cut (mid-swing of the
  trot's other diagonal), so the wrap's may be the largest by a sample. All on the
  world positions of every joint, the root among them.
- In place: how far the root moves along the ground from the first frame.
- Footfalls (:func:`quadsim.analysis.motion_report`, as ``quadsim metrics``): a
  loop played four times over with root motion -- duty factors and phases (after the
  left hind foot's touchdown) per leg, stride frequency and length, mean speed,
  foot slide and ground penetration; other clips as they are (slide, penetration).

Lengths in metres (``_mm`` keys in millimetres), speeds m/s, frequencies Hz.
"""

from __future__ import annotations

import numpy as np

from quadsim.clipset.clips import Clip, tiled
from quadsim.clipset.rows import pose_rows
from quadsim.frames import LEGS
from quadsim.locomotion.pose_kernel import HEADING, ROOT

__all__ = ["clip_figures", "loop_transform", "seam_figures"]

#: Copies of a loop measured end to end for its footfalls.
COPIES = 4


def loop_transform(rows: np.ndarray):
    """The loop's travel as a function of world positions (..., 3): the turn about +Y
    by the heading's change and the shift that take the first root to the last."""
    a = rows[-1, HEADING] - rows[0, HEADING]
    c, s = np.cos(a), np.sin(a)
    r0, r1 = rows[0, [ROOT, ROOT + 2]], rows[-1, [ROOT, ROOT + 2]]

    def move(p):
        p = np.array(p, dtype=float)
        x, z = p[..., 0] - r0[0], p[..., 2] - r0[1]
        p[..., 0] = c * x + s * z + r1[0]
        p[..., 2] = -s * x + c * z + r1[1]
        return p

    return move


def seam_figures(clip: Clip) -> dict:
    """The wrap of a loop against its inside (see the module's notes); metres."""
    P = clip.motion.world_positions()
    move = loop_transform(clip.rows)
    first = move(P[:2])
    inside = P[:-1]                                            # the frames an engine plays
    steps = np.linalg.norm(np.diff(inside, axis=0), axis=-1).max(axis=-1)
    accel = np.linalg.norm(inside[2:] - 2 * inside[1:-1] + inside[:-2], axis=-1).max(axis=-1)
    wrap = float(np.linalg.norm(first[0] - inside[-1], axis=-1).max())
    wrap_acc = float(np.linalg.norm(first[1] - 2 * first[0] + inside[-1], axis=-1).max())
    end = float(np.linalg.norm(first[0] - P[-1], axis=-1).max())
    return {"wrap_step_m": wrap, "max_step_m": float(steps.max()),
            "wrap_velocity_change_m": wrap_acc, "max_velocity_change_m": float(accel.max()),
            "last_key_error_m": end}


def _legs(values) -> dict | None:
    if values is None:
        return None
    return {leg: (None if v is None else round(float(v), 4)) for leg, v in zip(LEGS, values)}


def _footfalls(motion) -> dict:
    from quadsim.analysis import motion_report

    try:
        r = motion_report(motion)
    except ValueError as e:        # too short to measure
        return {"unmeasured": str(e)}
    legs = r["legs"]
    out = {"duty_factors": _legs([legs[k]["duty_factor"] for k in LEGS]),
           "phases": _legs([legs[k]["phase"] for k in LEGS]),
           "stride_frequency_hz": r["stride_frequency"], "stride_length_m": r["stride_length"],
           "mean_speed_mps": r["mean_speed"], "max_slide_mm": r["max_slide_mm"],
           "max_penetration_mm": r["max_penetration_mm"]}
    return out


def clip_figures(clip: Clip, character, *, twin: Clip | None = None) -> dict:
    """Everything measured of a clip for the sidecar. An in-place loop's footfalls are
    those of its root-motion ``twin`` (the same steps, on the ground)."""
    out: dict = {}
    if clip.loop:
        out.update(seam_figures(clip))
        ground = twin if (twin is not None and not clip.root_motion) else clip
        motion = pose_rows(character, tiled(ground, COPIES), clip.motion.fps)
        out.update(_footfalls(motion))
    else:
        feet = _footfalls(clip.motion)
        out.update({k: feet.get(k) for k in ("max_slide_mm", "max_penetration_mm")})
    root = clip.motion.root_positions[:, [0, 2]]
    out["root_travel_m"] = float(np.linalg.norm(root - root[0], axis=-1).max())
    return out
