"""Build the shipped characters' body meshes into the package (quadsim/data/bodies).

::

    python tools/build_body_meshes.py

Run it after changing a body profile or the mesh builder; the tests check the
shipped files against a fresh build. Old files of the shipped characters are
removed.
"""

from __future__ import annotations

import sys
from pathlib import Path

import quadsim
from quadsim.mesh.body import body_key, build_body, profile_for, save_body

OUT = Path(__file__).resolve().parents[1] / "quadsim" / "data" / "bodies"


def main() -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    keep = set()
    for cid in quadsim.list_characters():
        sk = quadsim.load_character(cid).skeleton
        profile = profile_for(sk)
        body = build_body(sk, profile)
        path = OUT / f"{body_key(sk, profile)}.npz"
        save_body(body, path)
        keep.add(path.name)
        print(f"{cid}: {body.n_vertices} vertices, {len(body.triangles)} triangles -> "
              f"{path.relative_to(OUT.parents[2])} ({path.stat().st_size // 1024} KiB)")
    for old in OUT.glob("*.npz"):
        if old.name not in keep:
            old.unlink()
    return 0


if __name__ == "__main__":
    sys.exit(main())
