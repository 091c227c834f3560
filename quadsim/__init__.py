"""quadsim: kinematic, real-time quadruped locomotion.

Conventions (see ``quadsim.frames``): SI units, right-handed world frame with
+Y up, characters face +Z with their left on +X, legs ordered LF, RF, LH, RH,
quaternions stored as (w, x, y, z).
"""

from quadsim.skeleton import Character, Motion, Skeleton, list_characters, load_character

__all__ = ["Character", "Motion", "Skeleton", "list_characters", "load_character"]
__version__ = "0.1.0"
