"""Contact sheets: eight phases of one stride, side view, per character and gait.

Run from anywhere (no display needed; frames render off screen)::

    python tools/contact_sheets.py [--out docs/img/sheets] [--character ID ...]
                                   [--gait NAME ...] [--size 240x180]

For every shipped character and each of its gaits, the character runs at
the gait's preferred speed (``quadsim.run(id, gait=g, seconds=...)``); after
:data:`SETTLE` seconds, one stride is cut from the left fore foot's
touchdown to its next one and eight evenly spaced phases of it are drawn
from the character's left side, four to a row, into
``<out>/<id>-<gait>.png`` (the phase of each frame written in its corner).
The same inputs give the same pictures.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
#: Seconds run before the stride that is shown.
SETTLE = 2.0
#: Phases shown per stride, and per row of the sheet.
PHASES, PER_ROW = 8, 4
#: Colours in the optimised PNG palette.
PALETTE = 64


def stride_frames(contacts: np.ndarray, fps: float, phases: int = PHASES) -> np.ndarray:
    """Frame indices of ``phases`` evenly spaced phases of the first full stride.

    Parameters
    ----------
    contacts : ndarray of bool, shape (T,)
        The reference foot's contact per frame.
    fps : float
    phases : int

    Returns
    -------
    ndarray of int, shape (phases,)
        From the first touchdown after :data:`SETTLE` seconds up to (not
        including) the next one; evenly spaced frames over the settled run
        when there are not two touchdowns.
    """
    c = np.asarray(contacts, dtype=bool)
    start = int(SETTLE * fps)
    down = np.nonzero(c[1:] & ~c[:-1])[0] + 1
    down = down[down >= start]
    if len(down) >= 2:
        a, b = down[0], down[1]
    else:
        a, b = start, len(c)
    return np.round(a + (b - a) * np.arange(phases) / phases).astype(int)


def sheet(cid: str, gait: str, size=(240, 180)) -> tuple[np.ndarray, float]:
    """The contact sheet of a character's gait, RGB, and the speed it ran at (m/s)."""
    import quadsim
    from quadsim import load_character
    from quadsim.locomotion.gaits import gait_table
    from quadsim.viz import render_frames

    ch = load_character(cid)
    speed = gait_table(ch)[gait].preferred_speed
    motion = quadsim.run(cid, gait=gait, speed=speed, seconds=SETTLE + 3.0)
    contacts = motion.contacts[:, 0] if motion.contacts is not None else np.ones(len(motion))
    idx = stride_frames(contacts, motion.fps)
    lo, hi = int(idx[0]), int(idx[-1]) + 1
    frames = list(render_frames(motion[lo:hi], size=size, camera="side", character=ch))
    picked = [frames[i - lo] for i in idx]
    stride = max(idx[-1] - idx[0], 1) * PHASES / (PHASES - 1)
    labelled = [_label(img, f"{(i - idx[0]) / stride:.2f}") for i, img in zip(idx, picked)]
    rows = [np.concatenate(labelled[r:r + PER_ROW], axis=1)
            for r in range(0, len(labelled), PER_ROW)]
    return _label(np.concatenate(rows, axis=0), f"{ch.name}: {gait.replace('_', ' ')}, {speed:.1f} m/s",
                  at=(6, 4)), speed


def _label(img: np.ndarray, text: str, at=None) -> np.ndarray:
    from PIL import Image, ImageDraw

    im = Image.fromarray(img)
    draw = ImageDraw.Draw(im)
    xy = at if at is not None else (im.width - 8 * len(text) - 4, im.height - 16)
    draw.text(xy, text, fill=(20, 20, 20))
    return np.asarray(im)


def save_png(img: np.ndarray, path: Path) -> None:
    """An optimised palette PNG."""
    from PIL import Image

    Image.fromarray(img).quantize(PALETTE, dither=Image.Dither.NONE).save(path, optimize=True)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(REPO / "docs" / "img" / "sheets"),
                   help="folder (docs/img/sheets)")
    p.add_argument("--character", nargs="*", help="character ids (default: all)")
    p.add_argument("--gait", nargs="*", help="gaits (default: all of each character's)")
    p.add_argument("--size", default="240x180", help="one frame, WxH (240x180)")
    args = p.parse_args(argv)
    from quadsim import list_characters, load_character
    from quadsim.locomotion.gaits import gait_table

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    w, h = (int(x) for x in args.size.lower().split("x"))
    for cid in args.character or list_characters():
        for gait in gait_table(load_character(cid)):
            if args.gait and gait not in args.gait:
                continue
            img, _ = sheet(cid, gait, size=(w, h))
            path = out / f"{cid}-{gait}.png"
            save_png(img, path)
            print(f"wrote {path} ({path.stat().st_size // 1024} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
