"""The quadsim benchmark suite: real-time margins and many characters at once.

    python -m benchmarks [--quick] [--max-n N] [--characters A,B] [--out FILE.json]
    quadsim bench [same options]

Measures, on this machine and CPU only:

(a) ``step``: one character's interactive :meth:`ProceduralController.step`
    in frames per second, with ``pose=True`` (plan, leg IK and full-skeleton
    forward kinematics every frame) and ``pose=False`` (the plan only, as
    :func:`simulate` steps before posing all frames at once);
(b) ``simulate``: offline generation of a 60 s clip at 60 fps (s);
(c) ``many``: N characters stepped together (character-frames per second),
    N = 1, 10, 100, 1000 (and 10000 with ``--max-n 10000``); how they are
    stepped is recorded in the result (``method``);
(d) ``export``: :func:`write_bvh` and :func:`write_glb` of the 60 s clip (s).

Every figure is the median over repeats (fewer repeats for the large N)
of wall-clock time (the step and simulate figures also in CPU time of this
process, ``*_cpu_*``, steadier on a shared machine); the JSON result also keeps each repeat and the load
average, since a busy machine shows in the numbers. The result goes to
``benchmarks/results/<machine>.json`` unless ``--out`` says otherwise, where
``<machine>`` names the CPU model and its number of cores.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import platform
import re
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"
CHARACTERS = ("leopard", "leopard_cub", "dog_cub", "horse")
#: what an interactive step is asked to do: trot on with a gentle left turn
STEP_SPEED_FRACTION = 0.35
STEP_TURN_RATE = 0.3  # rad/s
CLIP_SECONDS = 60.0
CLIP_FPS = 60.0


# ------------------------------------------------------------------ machine
def cpu_model() -> str:
    """The CPU's model name, as the operating system reports it."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


def machine_info() -> dict:
    """CPU model, cores, operating system, Python and numpy versions."""
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count()
    import quadsim

    try:
        load = [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):
        load = None
    return {"cpu": cpu_model(), "cores": usable, "logical_cpus": os.cpu_count(),
            "load_average_1_5_15_min": load,
            "machine": platform.machine(), "system": platform.platform(),
            "python": platform.python_version(), "numpy": np.__version__,
            "quadsim": getattr(quadsim, "__version__", "?")}


def machine_slug(info: dict) -> str:
    """File-name form of the machine: ``amd-epyc-2-cores``."""
    cpu = re.sub(r"\(r\)|\(tm\)|cpu|processor|@.*$", "", info["cpu"].lower())
    cpu = re.sub(r"[^a-z0-9]+", "-", cpu).strip("-") or "cpu"
    return f"{cpu}-{info['cores']}-cores"


# ------------------------------------------------------------------ helpers
def _median(xs) -> float:
    return float(np.median(np.asarray(xs, dtype=float)))


def _load(character: str):
    from quadsim.skeleton.character import load_character

    return load_character(character)


def _step_command(controller):
    from quadsim.locomotion.commands import Command

    return Command(speed=STEP_SPEED_FRACTION * controller.max_speed, turn_rate=STEP_TURN_RATE)


def _warm(controller, command, steps: int = 120) -> None:
    for _ in range(steps):
        controller.step(command, pose=False)


def _clone(controller):
    """An independent copy of a controller's state sharing its immutable parts."""
    memo = {id(controller.character): controller.character, id(controller.poser): controller.poser}
    return copy.deepcopy(controller, memo)


# ------------------------------------------------------------------ (a) step
def bench_step(character: str, frames: int, repeats: int) -> dict:
    """Interactive steps per second, with and without posing."""
    from quadsim.locomotion.controller import ProceduralController

    ch = _load(character)
    base = ProceduralController(ch, seed=0)
    cmd = _step_command(base)
    _warm(base, cmd)
    out = {}
    for mode, pose in (("pose", True), ("plan_only", False)):
        rates, cpu = [], []
        for _ in range(repeats):
            ctl = _clone(base)
            t0, c0 = time.perf_counter(), time.process_time()
            for _ in range(frames):
                ctl.step(cmd, pose=pose)
            rates.append(frames / (time.perf_counter() - t0))
            cpu.append(frames / max(time.process_time() - c0, 1e-9))
        out[mode] = {"steps_per_s": _median(rates), "repeats": [round(r, 1) for r in rates],
                     "steps_per_cpu_s": _median(cpu), "frames": frames}
    return out


# ------------------------------------------------------------------ (b) simulate
def _clip_script(character):
    """A 60 s tour: start, trot, run, turn both ways, slow down."""
    from quadsim.locomotion.commands import Command, Script
    from quadsim.locomotion.gaits import max_speed

    top = max_speed(character)
    cmds = [(0.0, 0.15, 0.0), (8.0, 0.35, 0.0), (18.0, 0.7, 0.0), (28.0, 0.7, 0.4),
            (36.0, 0.35, -0.3), (46.0, 0.15, 0.0), (55.0, 0.0, 0.0)]
    return Script(tuple(at for at, _, _ in cmds),
                  tuple(Command(speed=f * top, turn_rate=w) for _, f, w in cmds))


def bench_simulate(character: str, repeats: int):
    """Seconds to generate a 60 s clip at 60 fps; also returns the last clip."""
    from quadsim.locomotion import simulate

    ch = _load(character)
    script = _clip_script(ch)
    times, cpu, motion = [], [], None
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        motion = simulate(ch, script, CLIP_SECONDS, CLIP_FPS)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return {"seconds": _median(times), "repeats": [round(t, 3) for t in times],
            "cpu_seconds": _median(cpu),
            "frames": motion.n_frames, "real_time_factor": CLIP_SECONDS / _median(times)}, motion


# ------------------------------------------------------------------ (c) many
def bench_many(character: str, ns, frames_for, repeats_for) -> dict:
    """Character-frames per second for N characters of one kind stepped together."""
    from quadsim.locomotion.controller import ProceduralController

    ch = _load(character)
    rng = np.random.default_rng(0)
    base = ProceduralController(ch, seed=0)
    cmd = _step_command(base)
    _warm(base, cmd, 60)
    try:
        from quadsim.locomotion.batch import BatchController  # noqa: F401
        method = "batch"
    except ImportError:
        method = "loop"
    from quadsim.locomotion.commands import Command

    out = {"character": character, "pose": True,
           "method": {"loop": "N independent ProceduralController.step(pose=True) "
                      "calls in a Python loop"}.get(method, "BatchController"),
           "by_n": {}}
    for n in ns:
        ctls = [_clone(base) for _ in range(n)]
        speeds = base.max_speed * rng.uniform(0.1, 0.6, n)
        cmds = [Command(speed=float(v), turn_rate=float(w))
                for v, w in zip(speeds, rng.uniform(-0.4, 0.4, n))]
        frames, rates = frames_for(n), []
        for _ in range(repeats_for(n)):
            t0 = time.perf_counter()
            for _ in range(frames):
                for c, k in zip(ctls, cmds):
                    c.step(k, pose=True)
            rates.append(n * frames / (time.perf_counter() - t0))
        out["by_n"][str(n)] = {"character_frames_per_s": _median(rates),
                               "real_time_characters_at_60fps": _median(rates) / 60.0,
                               "frames": frames, "repeats": [round(r, 1) for r in rates]}
        del ctls
    return out


# ------------------------------------------------------------------ (d) export
def bench_export(motion, repeats: int) -> dict:
    from quadsim.io.bvh import write_bvh
    from quadsim.io.gltf import write_glb

    out = {"frames": motion.n_frames}
    with tempfile.TemporaryDirectory() as tmp:
        for name, write, ext in (("bvh", write_bvh, "bvh"), ("glb", write_glb, "glb")):
            times = []
            path = Path(tmp) / f"clip.{ext}"
            for _ in range(repeats):
                t0 = time.perf_counter()
                write(motion, path)
                times.append(time.perf_counter() - t0)
            out[name] = {"seconds": _median(times), "repeats": [round(t, 3) for t in times],
                         "bytes": path.stat().st_size}
    return out


# ------------------------------------------------------------------ driver
def run(quick: bool = False, max_n: int = 1000, characters=CHARACTERS, log=print) -> dict:
    """Run every benchmark and return the result (a JSON-ready dict)."""
    info = machine_info()
    log(f"quadsim {info['quadsim']} on {info['cpu']}, {info['cores']} cores "
        f"({info['system']}); Python {info['python']}, numpy {info['numpy']}")
    if info["load_average_1_5_15_min"]:
        log(f"load average {info['load_average_1_5_15_min']} (figures are wall-clock: "
            "run on an idle machine)")
    step_frames, step_repeats = (60, 2) if quick else (300, 3)
    sim_repeats = 1
    result = {"machine": info, "quick": quick,
              "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
              "step": {}, "simulate": {}, "many": {}, "export": {}}
    t_all = time.perf_counter()
    warnings.simplefilter("ignore")  # clamp warnings are not what is measured
    log("(a) interactive step, frames per second (median of repeats), 60 fps = real time")
    for c in characters:
        r = bench_step(c, step_frames, step_repeats)
        result["step"][c] = r
        log(f"    {c:12s} pose {r['pose']['steps_per_s']:8.0f}/s "
            f"({r['pose']['steps_per_s'] / 60:5.1f}x real time)   plan only "
            f"{r['plan_only']['steps_per_s']:8.0f}/s "
            f"(posing costs {r['plan_only']['steps_per_s'] / r['pose']['steps_per_s']:.2f}x)")
    log(f"(b) offline {CLIP_SECONDS:g} s clip at {CLIP_FPS:g} fps (simulate), seconds")
    clip = None
    sim_chars = characters[:1] if quick else characters
    for c in sim_chars:
        if quick:
            r, motion = bench_simulate_short(c)
        else:
            r, motion = bench_simulate(c, sim_repeats)
        clip = clip or motion
        result["simulate"][c] = r
        log(f"    {c:12s} {r['seconds']:7.2f} s for {r['frames']} frames "
            f"({r['real_time_factor']:.0f}x real time)")
    ns = [n for n in (1, 10, 100, 1000, 10000) if n <= max_n]
    if quick:
        ns = [n for n in ns if n <= 100]
    log("(c) N characters stepped together (leopard, posed), character-frames per second")
    if quick:
        many = bench_many(characters[0], ns, frames_for=lambda n: max(2, min(20, 100 // n)),
                          repeats_for=lambda n: 1)
    else:
        many = bench_many(characters[0], ns, frames_for=lambda n: max(2, min(120, 1000 // n)),
                          repeats_for=lambda n: 3 if n <= 10 else 1)
    result["many"] = many
    for n, r in many["by_n"].items():
        log(f"    N = {n:>5s}: {r['character_frames_per_s']:9.0f}/s "
            f"({r['real_time_characters_at_60fps']:.1f} characters in real time)")
    log(f"    method: {many['method']}")
    log(f"(d) export of the {clip.n_frames}-frame clip ({characters[0]}), seconds")
    result["export"] = bench_export(clip, 1 if quick else 3)
    for k in ("bvh", "glb"):
        r = result["export"][k]
        log(f"    write_{k}: {r['seconds']:.3f} s ({r['bytes'] / 1e6:.1f} MB)")
    result["total_seconds"] = time.perf_counter() - t_all
    try:
        result["load_average_at_end"] = [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):
        pass
    log(f"total {result['total_seconds']:.0f} s")
    return result


def bench_simulate_short(character: str):
    """Quick mode: a 5 s clip, scaled to a 60 s one."""
    from quadsim.locomotion import simulate

    ch = _load(character)
    t0 = time.perf_counter()
    motion = simulate(ch, _clip_script(ch), 5.0, CLIP_FPS)
    t = (time.perf_counter() - t0) * CLIP_SECONDS / 5.0
    return {"seconds": t, "repeats": [round(t, 3)], "frames": motion.n_frames,
            "real_time_factor": CLIP_SECONDS / t, "note": "5 s clip, scaled to 60 s"}, motion


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--quick", action="store_true",
                    help="a short smoke run (seconds, not minutes); figures are rough")
    ap.add_argument("--max-n", type=int, default=1000, metavar="N",
                    help="largest number of characters stepped together (1000; 10000 adds "
                    "the largest herd)")
    ap.add_argument("--characters", metavar="A,B",
                    help="characters to measure, comma-separated (default: all four; the "
                    "first is used for the many-characters and export figures)")
    ap.add_argument("--out", metavar="FILE.json",
                    help="result file (default benchmarks/results/<machine>.json)")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks",
                                 description="Benchmark quadsim: step, simulate, many "
                                 "characters, export.")
    add_arguments(ap)
    return run_from_args(ap.parse_args(argv))


def run_from_args(args) -> int:
    chars = tuple(args.characters.split(",")) if getattr(args, "characters", None) else CHARACTERS
    result = run(quick=args.quick, max_n=args.max_n, characters=chars)
    out = Path(args.out) if args.out else RESULTS / f"{machine_slug(result['machine'])}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
