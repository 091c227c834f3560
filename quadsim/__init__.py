"""quadsim: kinematic, real-time quadruped locomotion.

Conventions (see ``quadsim.frames``): SI units, right-handed world frame with
+Y up, characters face +Z with their left on +X, legs ordered LF, RF, LH, RH,
quaternions stored as (w, x, y, z).
"""

from quadsim.skeleton import Character, Motion, Skeleton, load_character, list_characters

__all__ = ["Character", "Motion", "Skeleton", "load_character", "list_characters"]
__version__ = "0.1.0"
