"""The procedural body: one skinned mesh around any quadruped skeleton (numpy).

- :mod:`quadsim.mesh.profiles`: per-character body profiles, as data.
- :mod:`quadsim.mesh.parts`: the profile laid along the skeleton's chains.
- :mod:`quadsim.mesh.body`: the implicit surface, meshed and skinned
  (:func:`skinned_body`).
- :mod:`quadsim.mesh.skinning`: weights and linear blend skinning.

The glTF export (:mod:`quadsim.io.body_mesh`) and the preview and render
(:mod:`quadsim.viz.body`) use the same mesh.
"""

from quadsim.mesh.body import SkinnedBody, profile_for, skinned_body
from quadsim.mesh.profiles import BODY_COLORS, DEFAULT_PROFILE, PROFILES, Profile
from quadsim.mesh.skinning import Skin, top_weights

__all__ = ["BODY_COLORS", "DEFAULT_PROFILE", "PROFILES", "Profile", "Skin", "SkinnedBody",
           "profile_for", "skinned_body", "top_weights"]
