"""Quality measured from produced motion: footfalls, sliding, penetration, smoothness.

See :mod:`quadsim.analysis.metrics` for the definitions (contact detection,
touchdown timing, strides) and the defaults.
"""

from quadsim.analysis.metrics import (
    angular_acceleration,
    angular_velocity,
    angular_velocity_vectors,
    body_span,
    contact_intervals,
    default_contact_thresholds,
    duty_factors,
    foot_contacts,
    foot_slide,
    format_report,
    ground_penetration,
    motion_report,
    penetration_depth,
    phases,
    report_from_positions,
    root_speed,
    stance_intervals,
    stride_frequency,
    stride_length,
    stride_table,
    touchdown_times,
)

__all__ = [
    "angular_acceleration", "angular_velocity", "angular_velocity_vectors",
    "body_span", "contact_intervals", "default_contact_thresholds", "duty_factors",
    "foot_contacts", "foot_slide", "format_report", "ground_penetration", "motion_report",
    "penetration_depth", "phases", "report_from_positions", "root_speed",
    "stance_intervals", "stride_frequency", "stride_length", "stride_table",
    "touchdown_times",
]
