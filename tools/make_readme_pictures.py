"""Make the README's pictures: one rendered frame of each character and a gait diagram.

Run from anywhere (no display needed; the frames render off screen)::

    python tools/make_readme_pictures.py [--out docs/img]

Writes ``<character>.png`` (480x320, side view, trotting, the character's
procedural body from :mod:`quadsim.mesh`, as ``render`` and the preview draw
it) for every shipped character and ``gait_diagram.png`` (the leopard's walk
-> trot -> gallop ramp, measured from its foot positions). The same inputs
give the same pictures. The contact sheets per character and gait are
``tools/contact_sheets.py``'s.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SIZE = (480, 320)
#: Seconds of trotting before the frame that is shown.
SETTLE = 2.5


def character_frame(cid: str) -> np.ndarray:
    """A side view of a character trotting, RGB (320, 480, 3)."""
    from quadsim import load_character
    from quadsim.locomotion import Command, simulate
    from quadsim.locomotion.gaits import gait_table
    from quadsim.viz import render_frames

    ch = load_character(cid)
    trot = gait_table(ch)["trot"]
    motion = simulate(ch, Command(speed=trot.preferred_speed, gait="trot"), SETTLE, 60.0)
    frames = render_frames(motion[-1:], size=SIZE, camera="side", character=ch,
                           anti_aliasing="ssaa")
    return next(iter(frames))


def ramp_diagram(path: Path) -> Path:
    """The leopard's walk -> trot -> gallop diagram."""
    from quadsim import load_character
    from quadsim.locomotion import Command, Script, simulate
    from quadsim.viz import gait_diagram

    ramp = Script((0.0, 4.5, 7.0), (Command(speed=1.0), Command(speed=3.0), Command(speed=8.0)))
    motion = simulate(load_character("leopard"), ramp, 10.5, 60.0)
    return gait_diagram(motion, path, dpi=80, title="Leopard at 1, 3 and 8 m/s: footfalls "
                        "measured from the foot positions")


def save_png(img: np.ndarray, path: Path) -> None:
    from PIL import Image

    Image.fromarray(img).save(path, optimize=True)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(REPO / "docs" / "img"), help="folder (docs/img)")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    from quadsim import list_characters

    for cid in list_characters():
        path = out / f"{cid}.png"
        save_png(character_frame(cid), path)
        print(f"wrote {path} ({path.stat().st_size // 1024} KiB)")
    path = ramp_diagram(out / "gait_diagram.png")
    print(f"wrote {path} ({path.stat().st_size // 1024} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
