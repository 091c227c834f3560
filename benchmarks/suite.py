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
    N = 1, 10, 100, 1000 (and 10000 with ``--max-n 10000``) by
    :class:`~quadsim.locomotion.batch.BatchController`, with the memory a step
    takes; the result records the method (``method``) and, for small N, the
    Python loop over lone controllers for comparison; and N = 1000 again with
    another process keeping a core busy, on every thread and on one
    (``many_busy_core``; not in ``--quick``);
(a') the data-driven horse's step, when ``quadsim.horse`` provides
    ``HorseDataController`` (``step["horse_data"]``), and (b') its offline
    60 s clip (``simulate["horse_data"]``): the shipped tour
    ``configs/horse_data.toml`` played twice over (14 gait transitions, turns,
    slopes, two leaps), the clip database loaded beforehand (its load is
    ``database_load_s``);
(d) ``export``: :func:`write_bvh` and :func:`write_glb` of the 60 s clip (s);
(w) ``warm_up``: the one-off cost, in a fresh process, of the first posed
    step -- the compiled kernels loaded from numba's on-disk cache
    (``cached_s``) and, with an empty cache, compiled from scratch
    (``compile_s``, paid once per install or source change) -- then of the
    first batched step of 256 rows (``batch_*``, the threaded kernels), the
    data-driven horse's set-up and first step (``data_*``), and of
    importing quadsim (``import_s``). The other figures exclude it.

Every figure is the median over repeats of wall-clock time, and also of
this process's CPU time (``*_cpu_*``), steadier on a shared machine; the
JSON result also keeps each repeat and the load average, since a busy
machine shows in the numbers. The command line is :mod:`benchmarks.command`.
"""

from __future__ import annotations

import copy
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
#: The source checkout the suite lives in (its configs/ hold the data-mode tour).
ROOT = Path(__file__).resolve().parent.parent
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
            "numba": _version("numba"),
            "numba_threads": _numba_threads(),
            "omp_wait_policy": os.environ.get("OMP_WAIT_POLICY"),
            "quadsim": getattr(quadsim, "__version__", "?")}


def _numba_threads() -> int | None:
    try:
        from numba import get_num_threads
    except ImportError:
        return None
    return int(get_num_threads())


def _version(module: str) -> str | None:
    try:
        return __import__(module).__version__
    except ImportError:
        return None


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
    from quadsim.commands import Command

    return Command(speed=STEP_SPEED_FRACTION * controller.max_speed, turn_rate=STEP_TURN_RATE)


def _warm(controller, command, steps: int = 120) -> None:
    """Walk a controller into its gait; the last step posed, so that the
    compiled posing kernel is loaded (its one-off cost is ``warm_up``'s)."""
    for k in range(steps):
        controller.step(command, pose=k == steps - 1)


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
    from quadsim.commands import Command, Script
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


# ------------------------------------------------------------------ (a') horse data mode
def bench_horse_data(frames: int, repeats: int) -> dict | None:
    """Interactive steps per second of the data-driven horse, if that mode exists."""
    try:
        from quadsim.horse.controller import HorseDataController
    except ImportError:
        return None
    from quadsim.commands import Command

    from quadsim.io.clips import load_default_database

    ch = _load("horse")
    base = HorseDataController(ch, load_default_database(ch))
    cmd = Command(speed=3.0, turn_rate=STEP_TURN_RATE)
    for _ in range(60):
        base.step(cmd)
    rates, cpu = [], []
    for _ in range(repeats):
        ctl = copy.deepcopy(base, {id(base.character): base.character, id(base.db): base.db})
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(frames):
            ctl.step(cmd)
        rates.append(frames / (time.perf_counter() - t0))
        cpu.append(frames / max(time.process_time() - c0, 1e-9))
    return {"steps_per_s": _median(rates), "repeats": [round(r, 1) for r in rates],
            "steps_per_cpu_s": _median(cpu), "frames": frames,
            "command": "3 m/s, 0.3 rad/s turn"}


def _data_tour_script():
    """The shipped data-mode tour played twice over (60 s): a fresh command object for
    each start, so the second pass leaps too (a leap is once per command object)."""
    import dataclasses

    from quadsim.commands import Script
    from quadsim.config import load_config

    s = load_config(ROOT / "configs" / "horse_data.toml").commands
    half = CLIP_SECONDS / 2
    return Script(tuple(s.times) + tuple(t + half for t in s.times),
                  tuple(s.commands) + tuple(dataclasses.replace(c) for c in s.commands))


def bench_simulate_data(repeats: int) -> dict | None:
    """Seconds to generate the data-driven horse's 60 s clip at 60 fps (fresh controller
    each repeat: clip expansions and transitions computed anew)."""
    try:
        from quadsim.horse.controller import simulate as simulate_data
        from quadsim.io.clips import load_default_database
    except ImportError:
        return None
    ch = _load("horse")
    load_default_database(ch)                               # kernels loaded
    t0 = time.perf_counter()
    db = load_default_database(ch)
    load_s = time.perf_counter() - t0
    script = _data_tour_script()
    simulate_data(ch, script, 2.0, CLIP_FPS, database=db)   # kernels loaded
    times, cpu, motion = [], [], None
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        motion = simulate_data(ch, script, CLIP_SECONDS, CLIP_FPS, database=db)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    gaits = sorted({g for g in motion.gaits if "->" in g})
    return {"seconds": _median(times), "repeats": [round(t, 3) for t in times],
            "cpu_seconds": _median(cpu), "frames": motion.n_frames,
            "real_time_factor": CLIP_SECONDS / _median(times),
            "database_load_s": load_s, "transitions": len(gaits),
            "script": "configs/horse_data.toml twice over"}


# ------------------------------------------------------------------ (c) many
MANY_METHOD = ("BatchController.step(pose=True): the N characters as arrays with a leading "
               "character axis; the whole plan (speed, turning, gait choice and "
               "transitions, stride limits, CPG, feet, spine and body) as one compiled "
               "(numba) kernel looping over the characters, then the compiled posing (leg "
               "IK and forward kinematics of every joint)")
LOOP_METHOD = "N independent ProceduralController.step(pose=True) calls in a Python loop"


def _herd_commands(max_speed: float, n: int, rng):
    """Each character its own speed (10-60 % of the top speed) and turn rate."""
    return max_speed * rng.uniform(0.1, 0.6, n), rng.uniform(-0.4, 0.4, n)


def bench_many(character: str, ns, frames_for, repeats_for, loop_up_to: int = 10) -> dict:
    """Character-frames per second for N characters of one kind stepped together.

    The characters have their own seeds, speeds and turn rates and are warmed
    up for a second before timing. For N up to ``loop_up_to`` the Python loop
    over lone controllers is timed too, for comparison. The memory figures
    are the peak Python heap (``tracemalloc``) over one posed step, with the
    controller's state, and the process's peak resident size so far.
    """
    import resource
    import tracemalloc

    from quadsim.commands import Command
    from quadsim.locomotion.batch import BatchController
    from quadsim.locomotion.controller import ProceduralController

    ch = _load(character)
    rng = np.random.default_rng(0)
    out = {"character": character, "pose": True, "method": MANY_METHOD, "by_n": {}}
    for n in ns:
        tracemalloc.start()
        herd = BatchController([ch] * n, seeds=np.arange(n))
        speeds, turns = _herd_commands(herd.max_speed[0], n, rng)
        for _ in range(60):
            herd.step(speeds, turns, pose=False)
        state_bytes = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        herd.step(speeds, turns, pose=True)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        frames, rates, cpu = frames_for(n), [], []
        for _ in range(repeats_for(n)):
            t0, c0 = time.perf_counter(), time.process_time()
            for _ in range(frames):
                herd.step(speeds, turns, pose=True)
            rates.append(n * frames / (time.perf_counter() - t0))
            cpu.append(n * frames / max(time.process_time() - c0, 1e-9))
        r = {"character_frames_per_s": _median(rates),
             "character_frames_per_cpu_s": _median(cpu),
             "real_time_characters_at_60fps": _median(rates) / 60.0,
             "frames": frames, "repeats": [round(x, 1) for x in rates],
             "state_bytes": int(state_bytes), "peak_step_bytes": int(peak),
             "max_rss_bytes": int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) * 1024}
        del herd
        if n <= loop_up_to:
            base = ProceduralController(ch, seed=0)
            ctls = [_clone(base) for _ in range(n)]
            cmds = [Command(speed=float(v), turn_rate=float(w)) for v, w in zip(speeds, turns)]
            loop_frames = max(2, min(60, 300 // n))
            t0 = time.process_time()
            for _ in range(loop_frames):
                for c, k in zip(ctls, cmds):
                    c.step(k, pose=True)
            r["loop_character_frames_per_cpu_s"] = n * loop_frames / max(
                time.process_time() - t0, 1e-9)
        out["by_n"][str(n)] = r
    out["loop_method"] = LOOP_METHOD
    return out


def bench_busy_core(character: str, n: int = 1000, frames: int = 30, repeats: int = 5) -> dict:
    """N characters stepped together while another process keeps one core busy:
    character-frames per second on every thread and on one thread (the machine
    shared with another job). Threads wait passively when ``OMP_WAIT_POLICY`` is
    ``PASSIVE`` (set by ``quadsim bench`` and ``python -m benchmarks`` unless given)."""
    import subprocess

    import numba

    from quadsim.locomotion.batch import BatchController

    ch = _load(character)
    herd = BatchController([ch] * n, seeds=np.arange(n))
    speeds, turns = _herd_commands(herd.max_speed[0], n, np.random.default_rng(0))
    for _ in range(30):
        herd.step(speeds, turns, pose=True)
    threads = numba.get_num_threads()
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    out = {"character": character, "n": n, "omp_wait_policy": os.environ.get("OMP_WAIT_POLICY")}
    try:
        time.sleep(0.5)
        for label, k in (("all_threads", threads), ("one_thread", 1)):
            numba.set_num_threads(k)
            rates = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                for _ in range(frames):
                    herd.step(speeds, turns, pose=True)
                rates.append(n * frames / (time.perf_counter() - t0))
            out[label] = {"threads": k, "character_frames_per_s": _median(rates),
                          "repeats": [round(x, 1) for x in rates]}
    finally:
        numba.set_num_threads(threads)
        busy.kill()
        busy.wait()
    return out


# ------------------------------------------------------------------ (w) warm-up
_WARM_UP_CODE = """
import time
t0, c0 = time.perf_counter(), time.process_time()
from quadsim.locomotion.controller import ProceduralController
from quadsim.commands import Command
from quadsim.skeleton.character import load_character
ctl = ProceduralController(load_character({character!r}))
t1, c1 = time.perf_counter(), time.process_time()
ctl.step(Command(speed=1.0), pose=True)
t2, c2 = time.perf_counter(), time.process_time()
t3 = t4 = t5 = t6 = c3 = c4 = c5 = c6 = 0.0
if {full}:
    from quadsim.locomotion.batch import BatchController
    herd = BatchController([ctl.character] * 256)
    t3, c3 = time.perf_counter(), time.process_time()
    herd.step([1.0] * 256, pose=True)
    t4, c4 = time.perf_counter(), time.process_time()
    from quadsim.horse.controller import HorseDataController
    t5, c5 = time.perf_counter(), time.process_time()
    from quadsim.io.clips import load_default_database
    horse = load_character("horse")
    HorseDataController(horse, load_default_database(horse)).step(Command(speed=3.0))
    t6, c6 = time.perf_counter(), time.process_time()
print(t1 - t0, c1 - c0, t2 - t1, c2 - c1, t4 - t3, c4 - c3, t6 - t5, c6 - c5)
"""


def bench_warm_up(character: str, full: bool = True) -> dict:
    """One-off costs in fresh processes: importing quadsim and building a
    controller, and the first posed step with numba's cache warm and empty;
    with ``full``, also the first threaded batch step and the data-driven
    horse's first step (0 without)."""
    import subprocess

    def fresh(env):
        out = subprocess.run([sys.executable, "-c", _WARM_UP_CODE.format(character=character, full=bool(full))],
                             env=env, capture_output=True, text=True, check=True)
        return [float(x) for x in out.stdout.split()]

    env = dict(os.environ)
    fresh(env)  # fill the cache if this install has not yet
    cached = fresh(env)
    with tempfile.TemporaryDirectory() as empty:
        env["NUMBA_CACHE_DIR"] = empty
        compiled = fresh(env)
    return {"character": character,
            "import_s": cached[0], "import_cpu_s": cached[1],
            "cached_s": cached[2], "cached_cpu_s": cached[3],
            "compile_s": compiled[2], "compile_cpu_s": compiled[3],
            "batch_cached_s": cached[4], "batch_cached_cpu_s": cached[5],
            "batch_compile_s": compiled[4], "batch_compile_cpu_s": compiled[5],
            "data_cached_s": cached[6], "data_cached_cpu_s": cached[7],
            "data_compile_s": compiled[6], "data_compile_cpu_s": compiled[7],
            "note": "first posed ProceduralController.step of a fresh process (loads or "
                    "compiles the plan and posing kernels), then the first "
                    "BatchController.step of 256 rows (adds the threaded kernels), then "
                    "the data-driven horse's set-up and first step (its clip database "
                    "and kernels), numba's on-disk cache warm (cached) and empty "
                    "(compile); import_s: importing quadsim and building the controller "
                    "(with the character's reach measured)"}


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
        log(f"load average {info['load_average_1_5_15_min']} (figures are wall-clock, "
            "CPU time in brackets: run on an idle machine)")
    step_frames, step_repeats = (60, 2) if quick else (600, 5)
    sim_repeats = 3
    result = {"machine": info, "quick": quick,
              "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
              "step": {}, "simulate": {}, "many": {}, "export": {}}
    t_all = time.perf_counter()
    warnings.simplefilter("ignore")  # clamp warnings are not what is measured
    log("(w) one-off warm-up of a fresh process (compiled kernels), seconds")
    w = result["warm_up"] = bench_warm_up(characters[0], full=not quick)
    log(f"    import and set-up {w['import_s']:.2f} s; first posed step {w['cached_s']:.2f} s "
        f"(numba cache warm), {w['compile_s']:.2f} s (cache empty: compiling); first "
        f"batch step (256, threaded) {w['batch_cached_s']:.2f} s / "
        f"{w['batch_compile_s']:.2f} s; data-driven horse {w['data_cached_s']:.2f} s / "
        f"{w['data_compile_s']:.2f} s")
    log("(a) interactive step, frames per second (median of repeats), 60 fps = real time")
    for c in characters:
        r = bench_step(c, step_frames, step_repeats)
        result["step"][c] = r
        log(f"    {c:12s} pose {r['pose']['steps_per_s']:7.0f}/s "
            f"[{r['pose']['steps_per_cpu_s']:5.0f}] "
            f"({r['pose']['steps_per_s'] / 60:5.1f}x real time)   plan only "
            f"{r['plan_only']['steps_per_s']:7.0f}/s [{r['plan_only']['steps_per_cpu_s']:5.0f}]")
    if "horse" in characters:
        r = bench_horse_data(step_frames, step_repeats)
        if r is not None:
            result["step"]["horse_data"] = r
            log(f"    {'horse (data)':12s} pose {r['steps_per_s']:7.0f}/s "
                f"[{r['steps_per_cpu_s']:5.0f}] ({r['steps_per_s'] / 60:5.1f}x real time)")
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
        cpu = f" [{r['cpu_seconds']:.2f}]" if "cpu_seconds" in r else ""
        log(f"    {c:12s} {r['seconds']:7.2f} s{cpu} for {r['frames']} frames "
            f"({r['real_time_factor']:.0f}x real time)")
    if "horse" in characters:
        r = bench_simulate_data(1 if quick else sim_repeats)
        if r is not None:
            result["simulate"]["horse_data"] = r
            log(f"    {'horse (data)':12s} {r['seconds']:7.2f} s [{r['cpu_seconds']:.2f}] for "
                f"{r['frames']} frames ({r['real_time_factor']:.0f}x real time; "
                f"{r['transitions']} kinds of gait change; database loaded first in "
                f"{r['database_load_s']:.2f} s)")
    ns = [n for n in (1, 10, 100, 1000, 10000) if n <= max_n]
    if quick:
        ns = [n for n in ns if n <= 100]
    log(f"(c) N characters stepped together ({characters[0]}, posed), "
        "character-frames per second")
    if quick:
        many = bench_many(characters[0], ns, frames_for=lambda n: 20,
                          repeats_for=lambda n: 1, loop_up_to=1)
    else:
        many = bench_many(characters[0], ns, frames_for=lambda n: max(10, min(120, 30000 // n)),
                          repeats_for=lambda n: 3)
    result["many"] = many
    for n, r in many["by_n"].items():
        loop = r.get("loop_character_frames_per_cpu_s")
        log(f"    N = {n:>5s}: {r['character_frames_per_s']:9.0f}/s "
            f"[{r['character_frames_per_cpu_s']:6.0f}] "
            f"({r['real_time_characters_at_60fps']:.1f} characters in real time; "
            f"peak {r['peak_step_bytes'] / 1e6:.0f} MB a step)"
            + (f"; Python loop {loop:.0f}/s" if loop else ""))
    log(f"    method: {many['method']}")
    if not quick and 1000 in ns:
        b = result["many_busy_core"] = bench_busy_core(characters[0])
        log(f"    N =  1000 with another process busy on a core: "
            f"{b['all_threads']['character_frames_per_s']:9.0f}/s on "
            f"{b['all_threads']['threads']} threads, "
            f"{b['one_thread']['character_frames_per_s']:9.0f}/s on one "
            f"(OMP_WAIT_POLICY={b['omp_wait_policy']})")
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
