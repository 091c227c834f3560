"""The data-driven mode: a clip database expanded to any speed (the horse's shipped
one, or any character's: :mod:`quadsim.io.takes` cuts one from long takes).

Modules: :mod:`.database` (looped clips and the database of them; the
:func:`~.database.cut_cycles` builder; clip folders are read by
:mod:`quadsim.io.clips`), :mod:`.legs` (two-bone IK that keeps
the lower leg; holding stance feet), :mod:`.speed` (Hoyt's contact-time law,
speed expansion), :mod:`.timewarp` (asynchronous time warping between gaits),
:mod:`.root` (foot phases and the root from the landing feet),
:mod:`.turning` (the head-first lead into turns and slopes, planted feet),
:mod:`.slope` (the ground: flat, or planar ramps along the heading),
:mod:`.place_kernel` (the compiled per-frame work) and :mod:`.bundles` (the
named bundles it reads), :mod:`.playback` (gait bands, expanded clips, poses
at a generic time), :mod:`.placement` (the world placement each frame),
:mod:`.steering` (heading and turn limits; clamp notices),
:mod:`.controller` (:class:`~.controller.HorseDataController`, the interactive
data-driven horse, a :class:`quadsim.controller.Controller`, and
:func:`~.controller.simulate`, used by ``mode = "data"``).
"""

from .database import Clip, ClipDatabase, Cycle, cut_cycles
from .controller import DataController, HorseDataController
from .controller import simulate as simulate_data
from .speed import HOYT, SPEED_UNIT, contact_time, expand, step_length
from .timewarp import blend_frames, leg_times, synchronous_transition, transition_motion

__all__ = [
    "DataController",
    "HOYT",
    "HorseDataController",
    "SPEED_UNIT",
    "Clip",
    "ClipDatabase",
    "Cycle",
    "blend_frames",
    "contact_time",
    "cut_cycles",
    "expand",
    "leg_times",
    "simulate_data",
    "step_length",
    "synchronous_transition",
    "transition_motion",
]
