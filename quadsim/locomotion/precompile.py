"""On an empty cache, compile the plan in a second process.

A procedural run compiles, one after the other, the leg IK (at the
character's set-up), the plan (:func:`~quadsim.locomotion.plan_kernels.plan_rows`,
by far the largest), the posing (:func:`~quadsim.locomotion.pose_kernel.pose_rows`)
and the rotation conversions. When the plan is not cached yet, :func:`start`
launches ``python -m quadsim.locomotion.compile_plan``, which compiles the
plan into numba's cache on the other core while this process sets the
character up; at its first step this process compiles the posing and the
rotations (:func:`while_plan_compiles`), then waits for the plan's cache
entry and loads it. Each kernel is compiled once, by one of the two.

Whatever happens to the second process, the motion is the same: it starts
only when the plan is not cached, writes nothing to the terminal, is waited
for at most :data:`WAIT_LIMIT` seconds (after that, or if it fails, this
process compiles the plan as it would have), and is stopped when this
process exits. numba writes its cache files atomically (a temporary file
renamed), so an entry is read whole or not at all.
"""

from __future__ import annotations

import atexit
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from quadsim.kinematics.rotations import matrices_from_quaternions, quaternions_from_matrices
from quadsim.locomotion.plan_kernels import plan_rows

#: Longest wait (s) of the first step for the second process.
WAIT_LIMIT = 60.0
#: How often (s) the wait looks at the process and the cache.
POLL = 0.02
#: The second process's command, after the Python interpreter.
CHILD_ARGS = ("-m", "quadsim.locomotion.compile_plan")
#: Set (to anything but 0) to never start the second process.
DISABLE_ENV = "QUADSIM_NO_PRECOMPILE"

_child: subprocess.Popen | None = None


def is_cached(kernel) -> bool:
    """Whether numba's cache holds a current entry of ``kernel`` (a cached
    dispatcher); True when it cannot tell (nothing is then started)."""
    try:
        return bool(kernel._cache._cache_file._load_index())
    except Exception:  # noqa: BLE001 -- numba's private cache layout changed: do nothing
        return True


def start() -> bool:
    """Launch the second process if the plan is not cached (and none runs,
    and :data:`DISABLE_ENV` is not set); whether one was launched."""
    global _child
    if _child is not None or os.environ.get(DISABLE_ENV, "0") != "0":
        return False
    if is_cached(plan_rows):
        return False
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[2])  # this quadsim, whatever sys.path says
    env["PYTHONPATH"] = os.pathsep.join(p for p in (root, env.get("PYTHONPATH", "")) if p)
    env[DISABLE_ENV] = "1"
    try:
        _child = subprocess.Popen([sys.executable, *CHILD_ARGS], stdin=subprocess.DEVNULL,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                  env=env, close_fds=True)
    except OSError:
        return False
    atexit.register(stop)
    return True


def start_for(mode: str) -> bool:
    """:func:`start` for a run in ``mode``: only a procedural run compiles the plan."""
    return start() if mode == "procedural" else False


def compiling() -> bool:
    """Whether the second process runs and has not cached the plan yet."""
    return _child is not None and _child.poll() is None and not is_cached(plan_rows)


def wait(limit: float | None = None) -> None:
    """Wait while :func:`compiling`, at most ``limit`` s (:data:`WAIT_LIMIT`)."""
    deadline = time.monotonic() + (WAIT_LIMIT if limit is None else limit)
    while compiling() and time.monotonic() < deadline:
        time.sleep(POLL)


def while_plan_compiles(poser, columns: int) -> None:
    """Before the first step of the plan: if the second process is compiling
    it, compile (or load) what else a run needs -- ``poser``'s posing of a
    zero plan of ``columns`` columns and the rotation conversions -- then
    :func:`wait`. Nothing when no second process runs."""
    if not compiling():
        return
    poser.pose_packed(np.zeros((1, columns)))
    quaternions_from_matrices(np.eye(3)[None])
    matrices_from_quaternions(np.array([[1.0, 0.0, 0.0, 0.0]]))
    wait()


def stop() -> None:
    """End the second process if it still runs (at exit: no orphan)."""
    global _child
    child, _child = _child, None
    if child is None:
        return
    if child.poll() is None:
        child.kill()
    child.wait()
