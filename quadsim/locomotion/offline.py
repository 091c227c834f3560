"""The fast offline path: a script of commands to a :class:`~quadsim.skeleton.motion.Motion`.

:func:`simulate` steps a :class:`~quadsim.locomotion.controller.ProceduralController`
once per frame, plan only, copying each frame's plan into the clip's arrays,
then poses every frame in one compiled pass: the same motion as stepping
the controller posed frame by frame (tests hold the two together).
"""

from __future__ import annotations

import math
from itertools import chain

import numpy as np

from quadsim.commands import Command, Script
from quadsim.kinematics.rotations import quaternions_from_matrices
from quadsim.locomotion.controller import ControllerSettings, ProceduralController
from quadsim.locomotion.cpg import TWO_PI
from quadsim.locomotion.pose_kernel import BEND_PITCH, HEADING, ROOT, plan_columns
from quadsim.skeleton.character import Character
from quadsim.skeleton.motion import Motion

_ARRAY_KEYS = ("root", "heading", "pitch", "sway", "bend_yaw", "bend_pitch", "feet", "fold",
               "toe", "load", "tail", "look", "foot_yaw", "contacts", "phase", "speed", "duty",
               "spine", "heading_rate", "amplitude")


def stack_plans(plans: list[dict]) -> dict[str, np.ndarray]:
    """Stack per-frame plans (:meth:`ProceduralController.plan_step
    <quadsim.locomotion.controller.ProceduralController.plan_step>`) into
    arrays with a leading frame axis."""
    T = len(plans)
    out = {}
    for k in _ARRAY_KEYS:
        first = plans[0][k] if T else 0.0
        shape = np.shape(first)
        dtype = bool if k == "contacts" else float
        if isinstance(first, np.ndarray) or not shape:
            out[k] = np.array([pl[k] for pl in plans], dtype=dtype).reshape((T,) + shape)
            continue
        # nested lists: flatten level by level and read them in one pass
        flat = (pl[k] for pl in plans)
        for _ in shape:
            flat = chain.from_iterable(flat)
        out[k] = np.fromiter(flat, dtype=dtype, count=T * math.prod(shape)).reshape(
            (T,) + shape)
    n_tail = len(plans[0]["tail"]) if plans else 0
    out["tail"] = out["tail"].reshape(T, n_tail, 2)
    out["gait"] = np.array([pl["gait"] for pl in plans], dtype=object)
    return out


def simulate(character: Character, script: Script | Command, duration: float, fps: float,
             *, seed: int = 0, settings: ControllerSettings | None = None) -> Motion:
    """Run a scripted sequence of commands and return the motion.

    Parameters
    ----------
    character : Character
    script : Script or Command
        The commands over time (a single command is held throughout).
    duration : float
        Seconds to simulate (> 0).
    fps : float
        Frames per second; the controller steps once per frame.
    seed : int
    settings : ControllerSettings, optional

    Returns
    -------
    Motion
        ``int(round(duration * fps))`` frames, frame ``k`` at ``t = k / fps``
        (the state after ``k`` steps), with planned contacts, gait labels
        and, in ``extras``, the CPG stride fractions ``phase`` (T, 4), the
        spine angle ``spine`` (T,), the duty factor ``duty`` (T,), the speed
        ``speed`` (T,), the heading ``heading`` (T,), the IK error
        ``ik_error`` (T, 4) and the oscillator amplitudes ``cpg_amplitude`` (T, 5).
    """
    if isinstance(script, Command):
        script = Script.constant(script)
    if not (math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a positive number of seconds, got {duration!r}")
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive number, got {fps!r}")
    n = round(duration * fps)
    dt = 1.0 / fps
    first = script.commands[0]
    ctl = ProceduralController(character, dt=dt, seed=seed, gait=first.gait, settings=settings)
    # frame 0 is the starting state; frame k follows k steps of dt. The plan
    # kernel packs each frame's plan for the posing (the row pack_plan makes of
    # the plan dict): that row and the few channels it lacks are copied into the
    # clip's arrays, no per-frame dicts
    st = ctl.state
    mo, cpg, stance, duty_now = st.motion, st.cpg, st.feet.stance, st.schedule.params.duty
    packed = np.empty((n, plan_columns(len(character.tail))))
    contacts, theta = np.empty((n, 4), dtype=bool), np.empty((n, 4))
    speed, duty, amp = np.empty(n), np.empty(n), np.empty((n, 5))
    gaits = []
    step, command_at = ctl._plan, script.command_at
    for k in range(n):
        out = step(command_at((k - 1) * dt), dt, True) if k else step(first, 0.0, True)
        packed[k], contacts[k], theta[k] = out.packed[0], stance[0], cpg.theta[0]
        speed[k], duty[k] = mo.speed[0], duty_now[0]
        amp[k, :4], amp[k, 4] = cpg.r[0], cpg.r_s[0]
        gaits.append(ctl.gait)
    local, _, err = ctl.poser.pose_packed(packed)
    root = packed[:, ROOT:ROOT + 3].copy()
    plan = {"contacts": contacts, "gait": np.array(gaits, dtype=object),
            "phase": np.mod(theta / TWO_PI, 1.0), "spine": packed[:, BEND_PITCH].copy(),
            "duty": duty, "speed": speed, "heading": packed[:, HEADING].copy(),
            "amplitude": amp}
    return Motion(
        character.skeleton, fps, root, quaternions_from_matrices(local),
        contacts=plan["contacts"], gaits=plan["gait"], foot_joints=character.foot_joints,
        extras={"phase": plan["phase"], "spine": plan["spine"], "duty": plan["duty"],
                "speed": plan["speed"], "ik_error": err, "heading": plan["heading"],
                "cpg_amplitude": plan["amplitude"]},
    )


__all__ = ["simulate", "stack_plans"]
