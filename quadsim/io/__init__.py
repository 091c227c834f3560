"""File formats: one module per format, on top of the skeleton layer.

:mod:`quadsim.io.bvh` reads and writes Biovision hierarchy (BVH) files,
:mod:`quadsim.io.gltf` writes binary glTF 2.0 (``.glb``) with a skinned body,
:mod:`quadsim.io.npz` writes joint world positions and contacts as NumPy
``.npz`` or CSV. Every writer goes through :mod:`quadsim.io.atomic` (a file
is written whole or not at all, through symbolic links, never over a
read-only file); :mod:`quadsim.io.guess` tells what a file leaves unsaid
(its length unit, which joints are the feet).
"""

from quadsim.io.bvh import guess_foot_joints, read_bvh, write_bvh
from quadsim.io.gltf import write_glb
from quadsim.io.npz import write_csv, write_npz

__all__ = ["guess_foot_joints", "read_bvh", "write_bvh", "write_csv", "write_glb", "write_npz"]
