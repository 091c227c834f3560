"""Clip sets for game engines: every gait looped, in place and with root motion, turns,
starts, stops and transitions, matched in phase, in one file with a sidecar.

::

    from quadsim.clipset import make_clip_set, plan_clip_set, write_clip_set

    cub = quadsim.load_character("dog_cub")
    plan = plan_clip_set(cub)                      # which clips (names: plan.names())
    made = make_clip_set(cub, plan)                # [(Clip, measured figures), ...]
    write_clip_set(cub, plan, made, "out/dog_cub_clips.glb")   # and .json beside it

How loops close (:mod:`quadsim.clipset.stepper`), how clips are placed and their
travel taken out (:mod:`quadsim.clipset.rows`), the clips (:mod:`quadsim.clipset.clips`),
what is measured (:mod:`quadsim.clipset.measure`) and written
(:mod:`quadsim.clipset.export`).
"""

from quadsim.clipset.build import ClipSetPlan, make_clip_set, parse_speeds, plan_clip_set
from quadsim.clipset.clips import Clip
from quadsim.clipset.export import write_clip_set

__all__ = ["Clip", "ClipSetPlan", "make_clip_set", "parse_speeds", "plan_clip_set",
           "write_clip_set"]
