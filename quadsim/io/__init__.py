"""File formats: one module per format, on top of the skeleton layer.

:mod:`quadsim.io.bvh` reads and writes Biovision hierarchy (BVH) files.
"""

from quadsim.io.bvh import guess_foot_joints, read_bvh, write_bvh

__all__ = ["guess_foot_joints", "read_bvh", "write_bvh"]
