"""`quadsim sweep` end to end: clips and character-frames per second written to NPZ.

    python -m benchmarks.sweep [--seeds K] [--repeats R] [--quick] [--out FILE.json]

The clips are the issue's grid -- leopard and dog cub, walk, trot and
canter at their preferred speeds, turn rates 0 and 20 deg/s, 4 s at 60 fps
-- with K seeds (default 16: 192 clips, 46,080 character-frames). Measured,
each the median of R repeats (default 3) of wall-clock time (and CPU time, steadier on a
shared machine):

- ``in_memory``: :class:`~quadsim.locomotion.batch.BatchController` stepping
  the same clips, posed, one batch per character, nothing kept or written
  (character-frames per second): the reference;
- ``stages``: per clip, in one worker process set up as the sweep's, the
  sweep's steps one by one on the batches two workers get -- ``generate``
  (batched: the motions built, with their quaternions and forward
  kinematics), ``measure`` (the figures of ``quadsim metrics``, the batch's
  contacts, touchdowns and per-frame arrays found together, each clip's
  figures then read from its own), ``encode`` (the ``.npz`` bytes),
  ``publish`` (the file written atomically, its manifest line appended) --
  and each one's share;
- ``end_to_end``: :func:`quadsim.dataset.run_sweep` into an empty folder
  with 1, 2, the CPU count and twice the CPU count of local worker
  processes (clips/s, character-frames/s), with ``overhead_ms_per_clip``:
  the CPU time per clip on one worker (the sweep in this process) beyond the
  stages' (the sweep's own machinery: tasks, manifest, progress,
  compaction; and this process's allocator, which gives freed memory back
  where a worker's keeps it), and
  ``startup_s``: a sweep of two clips on two workers (forking the workers,
  compacting the manifest);
- ``files_only``: the same clips generated and written by 2 worker
  processes, split into the sweep's tasks, with nothing measured: what the
  files alone cost;
- ``ratio``: end-to-end character-frames per second on 2 workers over
  ``in_memory``; the issue asks for at least 0.5.

A full run writes ``benchmarks/results/sweep-<machine>.json``; ``--quick``
(one seed, one repeat) writes ``out/bench-sweep-quick.json`` unless
``--out`` says otherwise. A busy machine shows in the numbers: the JSON
keeps every repeat, the load average and ``free_cores_before_after``, the CPUs
two busy-loop processes got just before and just after the end-to-end runs
(less than 2 when other jobs hold a core, whose processes may not even be
visible from here).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from benchmarks.suite import RESULTS, machine_info, machine_slug

TARGET_RATIO = 0.5
QUICK_RESULT = Path("out") / "bench-sweep-quick.json"


def grid(seeds: int):
    """The benchmark's grid (see the module notes)."""
    from quadsim.dataset import parse_grid

    return parse_grid({"characters": ["leopard", "dog_cub"], "gaits": ["walk", "trot", "canter"],
                       "turn_rates_deg_s": [0, 20], "seeds": list(range(seeds)), "seconds": 4},
                      source="benchmarks.sweep")


def _median(xs) -> float:
    return float(np.median(np.asarray(xs, dtype=float)))


def _groups(clips):
    out: dict[str, list] = {}
    for c in clips:
        out.setdefault(c.source, []).append(c)
    return list(out.values())


def in_memory(clips, repeats: int) -> dict:
    """BatchController stepping the clips posed, one batch per character."""
    from quadsim.config import constant_command
    from quadsim.locomotion.batch import BatchController
    from quadsim.skeleton.character import load_character

    def once() -> float:
        t = 0.0
        for group in _groups(clips):
            ch = load_character(group[0].source)
            cmds = [constant_command(ch, speed=c.speed, gait=c.gait,
                                     turn_rate_deg_s=c.turn_rate_deg_s) for c in group]
            b = BatchController([ch] * len(group), dt=1.0 / group[0].fps,
                                seeds=[c.seed for c in group], gaits=[c.gait for c in cmds])
            speed = np.array([c.speed for c in cmds])
            turn = np.array([c.turn_rate or 0.0 for c in cmds])
            gait = b.gait_ids([c.gait for c in cmds])
            t0, c0 = time.perf_counter(), time.process_time()
            for _ in range(group[0].frames):
                b.step(speed, turn, None, gait, pose=True)
            t += time.perf_counter() - t0
            cpu[0] += time.process_time() - c0
        return t

    cpu = [0.0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        once()  # warm
        cpu[0] = 0.0
        runs = [once() for _ in range(repeats)]
    frames = sum(c.frames for c in clips)
    return {"frames": frames, "seconds": runs, "frames_per_s": frames / _median(runs),
            "frames_per_cpu_s": frames * repeats / cpu[0]}


def stages(clips, repeats: int) -> dict:
    """Per-clip milliseconds of each step of making a clip, in one worker process set up
    as the sweep's (:func:`quadsim.dataset.sweep._worker_init`)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from quadsim.dataset.sweep import _worker_init, cpu_count

    ctx = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods()
                                      else None)
    with ProcessPoolExecutor(1, mp_context=ctx, initializer=_worker_init,
                             initargs=(max(1, cpu_count() // 2),)) as pool:
        return pool.submit(_stages, clips, repeats).result()


def _stages(clips, repeats: int) -> dict:
    from quadsim.dataset.clips import generate, measure_clips, npz_bytes
    from quadsim.dataset.manifest import publish
    from quadsim.dataset.sweep import tasks_of

    def once(folder: Path) -> dict:
        keys = ("generate", "measure", "encode", "publish")
        t, cpu = dict.fromkeys(keys, 0.0), dict.fromkeys(keys, 0.0)

        def clock():
            return time.perf_counter(), time.process_time()

        def add(key, a, b):
            t[key] += b[0] - a[0]
            cpu[key] += b[1] - a[1]

        for group in tasks_of(clips, 2):  # batches as two workers have them
            c0 = clock()
            motions = generate(group)
            c1 = clock()
            measured = measure_clips(motions)
            add("generate", c0, c1)
            add("measure", c1, clock())
            for c, m, x in zip(group, motions, measured):
                c1 = clock()
                data = npz_bytes(m, x.contacts)
                c2 = clock()
                publish(folder, {"id": c.id, "path": c.path, "metrics": x.report}, data)
                c3 = clock()
                add("encode", c1, c2)
                add("publish", c2, c3)
        n = len(clips)
        return {"wall": {k: 1e3 * v / n for k, v in t.items()},
                "cpu": {k: 1e3 * v / n for k, v in cpu.items()}}

    runs = []
    for r in range(repeats + 1):
        with tempfile.TemporaryDirectory() as tmp:
            (Path(tmp) / "clips").mkdir()
            res = once(Path(tmp))
        if r:  # the first is a warm-up
            runs.append(res)
    ms = {k: _median([x["wall"][k] for x in runs]) for k in runs[0]["wall"]}
    cpu = {k: _median([x["cpu"][k] for x in runs]) for k in runs[0]["cpu"]}
    total, total_cpu = sum(ms.values()), sum(cpu.values())
    return {"ms_per_clip": ms, "total_ms_per_clip": total, "cpu_ms_per_clip": cpu,
            "total_cpu_ms_per_clip": total_cpu,
            "share": {k: v / total_cpu for k, v in cpu.items()}, "repeats": runs}


def _spin(seconds: float) -> float:
    """CPU seconds a busy loop gets in ``seconds`` of wall-clock time (a worker process)."""
    t0, c0 = time.perf_counter(), time.process_time()
    x = 0
    while time.perf_counter() - t0 < seconds:
        x += 1
    return time.process_time() - c0


def free_cores(n: int, seconds: float = 1.0) -> float:
    """How many CPUs this process's work gets now: ``n`` busy-loop processes for
    ``seconds``, their CPU time over the wall-clock time. Other jobs on the machine
    show as less than ``n`` (their processes may be out of sight, in other containers)."""
    import multiprocessing

    ctx = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods()
                                      else None)
    with ctx.Pool(n) as pool:
        return sum(pool.map(_spin, [seconds] * n)) / seconds


def _cpu() -> float:
    """CPU seconds of this process and of its finished children."""
    import resource

    me, kids = (resource.getrusage(w) for w in (resource.RUSAGE_SELF,
                                                 resource.RUSAGE_CHILDREN))
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def end_to_end(g, workers: list[int], repeats: int) -> dict:
    """run_sweep into an empty folder, for each number of local workers."""
    from quadsim.dataset import run_sweep

    out = {}
    clips = g.clips()
    frames = sum(c.frames for c in clips)
    for n in workers:
        runs, cpus = [], []
        for _ in range(repeats):
            tmp = Path(tempfile.mkdtemp(prefix="quadsim-bench-sweep-"))
            try:
                c0, t0 = _cpu(), time.perf_counter()
                s = run_sweep(g, tmp / "data", workers=n)
                runs.append(time.perf_counter() - t0)
                cpus.append(_cpu() - c0)
                assert s.made == len(clips)
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
        t = _median(runs)
        out[str(n)] = {"seconds": runs, "cpu_seconds": cpus, "clips_per_s": len(clips) / t,
                       "frames_per_s": frames / t, "ms_per_clip": 1e3 * t / len(clips),
                       "cpu_ms_per_clip": 1e3 * _median(cpus) / len(clips)}
    return out


def _files_only(task, out: str) -> int:
    """A sweep task without the measuring: generate, encode, publish (benchmark only)."""
    from quadsim.dataset.clips import generate, npz_bytes
    from quadsim.dataset.manifest import publish

    for c, m in zip(task, generate(task)):
        publish(out, {"id": c.id, "path": c.path, "frames": len(m)}, npz_bytes(m))
    return len(task)


def files_only(g, workers: int, repeats: int) -> dict:
    """Clips generated and written by ``workers`` local processes as the sweep splits them,
    nothing measured: how fast the files alone go."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    from functools import partial

    from quadsim.dataset.sweep import _worker_init, cpu_count, tasks_of

    clips = g.clips()
    frames = sum(c.frames for c in clips)
    tasks = tasks_of(clips, workers)
    threads = max(1, cpu_count() // workers)  # as the sweep's workers
    ctx = multiprocessing.get_context("fork")
    runs = []
    for _ in range(repeats):
        tmp = Path(tempfile.mkdtemp(prefix="quadsim-bench-sweep-"))
        try:
            (tmp / "clips").mkdir()
            t0 = time.perf_counter()
            with ProcessPoolExecutor(workers, mp_context=ctx, initializer=_worker_init,
                                     initargs=(threads,)) as pool:
                assert sum(pool.map(partial(_files_only, out=str(tmp)), tasks)) == len(clips)
            runs.append(time.perf_counter() - t0)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    t = _median(runs)
    return {"workers": workers, "seconds": runs, "clips_per_s": len(clips) / t,
            "frames_per_s": frames / t}


def startup(repeats: int) -> float:
    """Seconds of a sweep of two clips (a walk of each character) on two workers."""
    from dataclasses import replace

    from quadsim.dataset import run_sweep

    one = grid(1)
    small = replace(one, gaits=one.gaits[:1], turn_rates_deg_s=one.turn_rates_deg_s[:1])
    runs = []
    for _ in range(repeats):
        tmp = Path(tempfile.mkdtemp(prefix="quadsim-bench-sweep-"))
        try:
            t0 = time.perf_counter()
            s = run_sweep(small, tmp / "data", workers=2)
            runs.append(time.perf_counter() - t0)
            assert s.made == 2
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    return _median(runs)


def run(seeds: int = 16, repeats: int = 3, log=print) -> dict:
    """The whole benchmark; returns the result (see the module notes)."""
    from quadsim.dataset.sweep import cpu_count

    g = grid(seeds)
    clips = g.clips()
    cores = cpu_count()
    workers = sorted({1, 2, cores, 2 * cores})
    log(f"sweep benchmark: {len(clips)} clips of 4 s at 60 fps "
        f"({sum(c.frames for c in clips):,} character-frames), {repeats} repeats, "
        f"{cores} CPUs")
    mem = in_memory(clips, repeats)
    log(f"  BatchController in memory (posed, one batch per character): "
        f"{mem['frames_per_s']:,.0f} character-frames/s "
        f"({mem['frames_per_cpu_s']:,.0f} per CPU second)")
    st = stages(clips, repeats)
    parts = ", ".join(f"{k} {v:.2f} ms ({100 * st['share'][k]:.0f} %)"
                      for k, v in st["cpu_ms_per_clip"].items())
    log(f"  per clip, one worker, CPU time: {parts}; {st['total_cpu_ms_per_clip']:.2f} ms "
        f"({st['total_ms_per_clip']:.2f} ms wall-clock)")
    free = [free_cores(2)]
    e2e = end_to_end(g, workers, repeats)
    free.append(free_cores(2))
    for n, r in e2e.items():
        log(f"  end to end, {n} worker{'s' if n != '1' else ''}: {r['clips_per_s']:.1f} clips/s, "
            f"{r['frames_per_s']:,.0f} character-frames/s, {r['ms_per_clip']:.2f} ms a clip "
            f"({r['cpu_ms_per_clip']:.2f} ms of CPU)")
    files = files_only(g, 2, repeats)
    log(f"  files only (nothing measured), 2 workers: {files['clips_per_s']:.1f} clips/s, "
        f"{files['frames_per_s']:,.0f} character-frames/s "
        f"({files['frames_per_s'] / mem['frames_per_s']:.2f} of in memory)")
    overhead = e2e["1"]["cpu_ms_per_clip"] - st["total_cpu_ms_per_clip"]
    start = startup(repeats)
    ratio = e2e["2"]["frames_per_s"] / mem["frames_per_s"]
    log(f"  sweep overhead on one worker: {overhead:.2f} ms of CPU a clip; a 2-clip sweep "
        f"on 2 workers: {start:.2f} s")
    log(f"  CPUs free for 2 busy processes, before and after the end-to-end runs: "
        f"{free[0]:.2f}, {free[1]:.2f} (of 2)")
    log(f"  2 workers end to end / BatchController in memory: {ratio:.2f} "
        f"(target >= {TARGET_RATIO}: {'met' if ratio >= TARGET_RATIO else 'NOT met'})")
    return {"machine": machine_info(), "load_average": list(os.getloadavg()),
            "clips": len(clips), "seeds": seeds, "repeats": repeats,
            "in_memory": mem, "stages": st, "end_to_end": e2e, "files_only": files,
            "overhead_ms_per_clip": overhead, "startup_s": start, "ratio_2_workers": ratio,
            "free_cores_before_after": free,
            "target_ratio": TARGET_RATIO}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.sweep",
                                 description="Measure `quadsim sweep` end to end.")
    ap.add_argument("--seeds", type=int, default=16, help="seeds in the grid (16: 192 clips)")
    ap.add_argument("--repeats", type=int, default=3, help="repeats of each figure (3)")
    ap.add_argument("--quick", action="store_true", help="one seed, one repeat; written to "
                    f"{QUICK_RESULT} unless --out says otherwise")
    ap.add_argument("--out", metavar="FILE.json", help="result file (default "
                    "benchmarks/results/sweep-<machine>.json)")
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.repeats < 1:
        print("benchmarks.sweep: --seeds and --repeats must be >= 1", file=sys.stderr)
        return 2
    seeds, repeats = (1, 1) if args.quick else (args.seeds, args.repeats)
    result = run(seeds, repeats)
    path = Path(args.out) if args.out else (
        QUICK_RESULT if args.quick else RESULTS / f"sweep-{machine_slug(result['machine'])}.json")
    from quadsim.io.atomic import atomic_write

    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, lambda f: f.write(json.dumps(result, indent=2) + "\n"))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
