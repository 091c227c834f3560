"""Procedural locomotion: CPG, gaits, transitions, spine, foot paths, turning.

Knows nothing of files or screens.
"""

from quadsim.commands import Command, Script
from quadsim.errors import QuadsimClampWarning
from quadsim.locomotion.batch import BatchController
from quadsim.locomotion.controller import ControllerSettings, ProceduralController
from quadsim.locomotion.offline import simulate

__all__ = ["BatchController", "Command", "ControllerSettings", "ProceduralController",
           "QuadsimClampWarning", "Script", "simulate"]
