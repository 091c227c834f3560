"""Off-screen frame time of the live preview.

    python -m benchmarks.preview_frame [--character leopard] [--mode procedural|data]
                                       [--size 640x480] [--frames 120] [--repeats 5]

One frame is what the preview's timer does sixty times a second: one
controller step, posing the skeleton, updating the body mesh, the ground
grid, the camera and the text (:meth:`Preview.update`), then drawing
(:meth:`Preview.render`). The character trots, with a left turn, after a
warm-up of a second. The figure reported is the median over the repeats of
each repeat's median frame time; the 95th percentile and the split between
update and drawing are printed too, and the longest frame of the second
after a gait change (to a canter: the data mode builds the transition on its
first frame). Target: under 20 ms at 640x480.

Rendering is off screen (EGL or OSMesa on a machine without a display, a
software rasteriser unless a GPU driver is present), so a busy machine shows
in the numbers: run it on an idle one.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

TARGET_MS = 20.0


def measure(character: str = "leopard", size: str = "640x480", frames: int = 120,
            repeats: int = 5, mode: str | None = None) -> dict:
    """Frame times of an off-screen preview.

    Returns
    -------
    dict
        ``frame_ms`` (median of the repeats' medians), ``p95_ms``,
        ``update_ms``, ``render_ms`` (medians), ``repeats_ms`` (list),
        ``gait_change_max_ms`` (the longest frame of the second after a gait change).
    """
    from quadsim.viz import Preview

    p = Preview(character, mode=mode, size=size, off_screen=True)
    data = p.mode == "data"
    try:
        p.on_key("3" if data else "2")          # trot
        p.on_key("Left")       # and turn
        for _ in range(60):
            p.update(p.dt)
            p.render()
        med, upd, ren, every = [], [], [], []
        for _ in range(repeats):
            t_frame, t_upd, t_ren = [], [], []
            for _ in range(frames):
                t0 = time.perf_counter()
                p.update(p.dt)
                t1 = time.perf_counter()
                p.render()
                t2 = time.perf_counter()
                t_frame.append(t2 - t0)
                t_upd.append(t1 - t0)
                t_ren.append(t2 - t1)
            med.append(np.median(t_frame))
            upd.append(np.median(t_upd))
            ren.append(np.median(t_ren))
            every += t_frame
        p.on_key("5" if data else "3")          # canter
        change = []
        for _ in range(60):
            t0 = time.perf_counter()
            p.update(p.dt)
            p.render()
            change.append(time.perf_counter() - t0)
    finally:
        p.close()
    return {"frame_ms": 1e3 * float(np.median(med)),
            "p95_ms": 1e3 * float(np.percentile(every, 95)),
            "update_ms": 1e3 * float(np.median(upd)), "render_ms": 1e3 * float(np.median(ren)),
            "repeats_ms": [round(1e3 * float(m), 2) for m in med],
            "gait_change_max_ms": 1e3 * float(max(change))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Off-screen frame time of the quadsim preview.")
    ap.add_argument("--character", default="leopard")
    ap.add_argument("--mode", choices=("procedural", "data"), default=None,
                    help="the data-driven horse with --mode data (default procedural)")
    ap.add_argument("--size", default="640x480", metavar="WxH")
    ap.add_argument("--frames", type=int, default=120, help="frames per repeat (120)")
    ap.add_argument("--repeats", type=int, default=5, help="repeats (5)")
    args = ap.parse_args(argv)
    r = measure(args.character, args.size, args.frames, args.repeats, mode=args.mode)
    print(f"preview frame, {args.character} ({args.mode or 'procedural'}) at {args.size}, "
          "off screen: "
          f"{r['frame_ms']:.1f} ms median ({1e3 / r['frame_ms']:.0f} fps), "
          f"p95 {r['p95_ms']:.1f} ms")
    print(f"  update (controller, pose, mesh, camera, text) {r['update_ms']:.1f} ms, "
          f"draw {r['render_ms']:.1f} ms; repeats: {r['repeats_ms']} ms")
    print(f"  longest frame in the second after a gait change: "
          f"{r['gait_change_max_ms']:.1f} ms")
    print(f"  target < {TARGET_MS:.0f} ms: {'met' if r['frame_ms'] < TARGET_MS else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
