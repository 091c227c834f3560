"""The second process of :mod:`quadsim.locomotion.precompile`: compile the
plan into numba's cache.

Run as ``python -m quadsim.locomotion.compile_plan``. It sets up a
controller of one character -- the leg sweeps replaced by a constant, so the
leg IK is neither compiled nor run here (the other process compiles it at
its own set-up) -- and takes one step of the plan: the bundles are built by
the controller's own code, so they have the very types a run's have (the
same for every character). The step's result is thrown away.
"""

from __future__ import annotations

import numpy as np

from quadsim.commands import Command
from quadsim.locomotion import tables
from quadsim.locomotion.controller import ProceduralController
from quadsim.skeleton import load_character

#: The character whose bundles the plan is compiled for (any would do).
CHARACTER = "leopard"


def _zero_sweeps(character, poser, drops):
    """Stand-in of :func:`~quadsim.locomotion.tables.measure_sweeps`: (D, 4), 0.1 m each."""
    return np.full((len(drops), 4), 0.1)


def compile_plan() -> None:
    """Compile (or load) :func:`~quadsim.locomotion.plan_kernels.plan_rows`."""
    tables.measure_sweeps = _zero_sweeps  # this process only: its plan is never used
    ProceduralController(load_character(CHARACTER))._plan(Command(speed=1.0), None)


if __name__ == "__main__":
    compile_plan()
