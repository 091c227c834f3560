"""Procedural locomotion: CPG, gaits, transitions, spine, foot paths, turning.

Knows nothing of files or screens.
"""

from quadsim.locomotion.batch import BatchController
from quadsim.commands import Command, Script
from quadsim.locomotion.controller import (
    ControllerSettings,
    ProceduralController,
    QuadsimClampWarning,
    simulate,
)

__all__ = ["BatchController", "Command", "ControllerSettings", "ProceduralController",
           "QuadsimClampWarning", "Script", "simulate"]
