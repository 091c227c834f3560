"""The skeleton layer: skeletons, forward kinematics, motions, characters."""

from quadsim.skeleton.character import (
    Character,
    LegSpec,
    characters_dir,
    list_characters,
    load_character,
)
from quadsim.skeleton.fk import forward_kinematics
from quadsim.skeleton.motion import Motion
from quadsim.skeleton.skeleton import Skeleton

__all__ = ["Character", "LegSpec", "Motion", "Skeleton", "characters_dir",
           "forward_kinematics", "list_characters", "load_character"]
