"""Measuring the data-driven horse's gait transitions from their joint positions.

:func:`transition_quality` measures a transition made by
:func:`quadsim.horse.timewarp.transition_motion` -- foot slide, joint
accelerations against the clips' own, strides until the new footfall pattern
holds, penetration -- from the foot and joint positions alone, never from
the engine's labels; :func:`steady_acceleration` is the steady reference.
The engine does not import this module: the tests and
``tools/horse_transition_table.py`` do.
"""

from __future__ import annotations

import numpy as np

from quadsim.analysis.metrics import angular_acceleration, foot_slide, strides_to_pattern
from quadsim.horse.database import Clip, looped
from quadsim.horse.timewarp import REFERENCE
from quadsim.skeleton.contacts import foot_contacts
from quadsim.skeleton.motion import Motion

__all__ = ["SKIM_HEIGHT", "steady_acceleration", "transition_quality"]

#: Height (m) under which :func:`transition_quality`'s ``skim`` counts a foot as down.
SKIM_HEIGHT = 0.003


def steady_acceleration(clip: Clip, cycles: int = 3) -> float:
    """Largest joint angular acceleration (rad/s^2) of a clip played looped, steady."""
    return float(angular_acceleration(looped(clip.motion, cycles, clip.speed)).max())


def transition_quality(motion: Motion, clip1: Clip, clip2: Clip, *, tol: float = 0.06) -> dict:
    """Measure a transition from its joint positions, not from its labels.

    Parameters
    ----------
    motion : Motion
        As made by :func:`~quadsim.horse.timewarp.transition_motion` (``extras["blend"]`` marks the blend).
    clip1, clip2 : Clip
        The old and new gait's clips.
    tol : float
        Phase tolerance (fraction of a stride) of the footfall pattern.

    Returns
    -------
    dict
        ``slide`` (m): the largest horizontal travel of a foot from where it
        touched down, over every contact of the whole motion, the contacts
        measured from the foot positions (:func:`~quadsim.skeleton.contacts.foot_contacts`:
        low and slow, trimmed to the on-ground band);
        ``accel_ratio``: the largest joint angular acceleration of the
        motion over the larger of the two clips' steady maxima
        (:func:`steady_acceleration`);
        ``strides``: left-hind strides from the blend's first frame until
        the new gait's footfall pattern (phases of the clip2 touchdowns)
        holds for good (:func:`~quadsim.analysis.metrics.strides_to_pattern`),
        None if never; ``penetration`` (m): deepest foot below the ground;
        ``skim`` (m): a stricter slide, the contacts taken as every frame a
        foot is within :data:`SKIM_HEIGHT` of the ground whatever its speed
        (it also counts a foot that grazes the ground as it lands or leaves).
    """
    feet = motion.foot_positions()
    c = foot_contacts(feet, motion.fps)
    start = int(np.argmax(motion.extras["blend"] > 0)) / motion.fps
    want = ((clip2.touchdown - clip2.touchdown[REFERENCE]) / clip2.frames) % 1.0
    steady = max(steady_acceleration(clip1), steady_acceleration(clip2))
    return {"slide": foot_slide(feet, c)[1],
            "accel_ratio": float(angular_acceleration(motion).max()) / steady,
            "strides": strides_to_pattern(c, motion.fps, want, feet=feet, start=start, tol=tol),
            "penetration": float(max(0.0, -feet[..., 1].min())),
            "skim": foot_slide(feet, feet[..., 1] <= SKIM_HEIGHT)[1]}
