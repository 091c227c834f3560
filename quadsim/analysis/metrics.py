"""Quality measured from a produced motion: footfalls, sliding, penetration, smoothness.

Everything here is computed from joint world positions and local rotations,
never from a generator's own contact flags. Arrays follow the package
conventions: time leads, legs are ordered LF, RF, LH, RH, positions are
``(..., 3)`` in metres with +Y up (the ground is ``y = 0``), quaternions are
``(w, x, y, z)``. Times are seconds from the first frame given.

The figures live by topic -- contacts and their timing in
:mod:`quadsim.skeleton.contacts`, strides in :mod:`quadsim.analysis.strides`,
smoothness in :mod:`quadsim.analysis.smoothness`, sliding, penetration, speed
and the whole report in :mod:`quadsim.analysis.report` -- and are gathered
here under one name.
"""

from quadsim.analysis.report import (
    feet_over_ground,
    foot_slide,
    format_report,
    ground_penetration,
    motion_report,
    penetration_depth,
    report_from_positions,
    root_speed,
)
from quadsim.analysis.smoothness import (
    angular_acceleration,
    angular_velocity,
    angular_velocity_vectors,
)
from quadsim.analysis.strides import (
    duty_factors,
    phases,
    stride_frequency,
    stride_length,
    stride_table,
    strides_to_pattern,
    touchdown_times,
)
from quadsim.skeleton.contacts import (
    MIN_FRAMES,
    body_span,
    contact_intervals,
    default_contact_thresholds,
    foot_contacts,
    stance_intervals,
)

__all__ = [
    "MIN_FRAMES", "angular_acceleration", "angular_velocity", "angular_velocity_vectors",
    "body_span", "contact_intervals", "default_contact_thresholds", "duty_factors",
    "feet_over_ground", "foot_contacts", "foot_slide", "format_report", "ground_penetration",
    "motion_report", "penetration_depth", "phases", "report_from_positions", "root_speed",
    "stance_intervals", "stride_frequency", "stride_length", "stride_table",
    "strides_to_pattern", "touchdown_times",
]
