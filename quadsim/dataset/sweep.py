"""Running a sweep: the clips not yet made, in tasks, on local processes or Dask.

:func:`run_sweep` reads what the folder's manifest already holds, splits the
remaining clips into tasks (clips of one character, length and frame rate,
stepped together), runs the tasks -- in this process, in local worker
processes, or on a Dask distributed cluster -- and appends each finished
clip to the manifest as its task returns. Local workers write their clips
themselves; Dask workers, which may be on other machines, send the bytes
back and this process writes them. Either way every file is written
atomically and its bytes depend only on the clip's parameters.

A stopped run (SIGTERM, Ctrl-C) stops its workers, whose unfinished files
are removed; the next run removes any temporary file left by a harder stop,
skips the finished clips and makes the rest.

Before forking local workers this process loads the compiled kernels once
(a clip alone and a batch), and each worker keeps the memory it frees for
its next arrays (:func:`keep_freed_memory`); neither changes a byte.
"""

from __future__ import annotations

import math
import os
import signal
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from quadsim.dataset.clips import make_clips
from quadsim.dataset.grid import ClipSpec, Grid
from quadsim.dataset.manifest import (
    MANIFEST,
    Manifest,
    compact,
    publish,
    read_manifest,
    remove_leftovers,
)
from quadsim.errors import InputError

__all__ = ["MAX_BATCH", "Progress", "SweepSummary", "cpu_count", "pending", "run_sweep",
           "tasks_of"]

#: Most clips stepped together in one task (a step's fixed cost is shared by its
#: clips: 64 of the benchmark's clips cost 0.3 ms of CPU a clip less than 32 did).
MAX_BATCH = 64
#: Most character-frames in one task (the arrays generated: about 2.5 kB a frame of 34
#: joints).
MAX_BATCH_FRAMES = 16384
#: Tasks per worker a sweep is split into at least (so the workers finish together).
TASKS_PER_WORKER = 2
#: Local workers share the CPUs' threads out between them (one each for one
#: worker a CPU) rather than each using all of them.
WORKER_THREADS_SPLIT = True
#: Local workers' allocators keep the memory they free (:func:`keep_freed_memory`).
KEEP_FREED_MEMORY = True
#: Blocks from this size up (bytes) come from the system by themselves (glibc's largest).
MMAP_THRESHOLD = 32 << 20
#: Seconds to wait for a Dask scheduler to answer.
CONNECT_TIMEOUT = 10.0
#: Seconds a stopped local worker is given to end before it is killed.
WORKER_STOP_WAIT = 5.0


@dataclass(frozen=True)
class Progress:
    """Where a running sweep is: ``done`` of ``total`` clips after ``elapsed`` seconds."""

    done: int
    total: int
    elapsed: float

    @property
    def rate(self) -> float:
        """Clips per second so far."""
        return self.done / self.elapsed if self.elapsed > 0 else 0.0

    @property
    def eta(self) -> float | None:
        """Seconds left at the rate so far (None before the first clip)."""
        return (self.total - self.done) / self.rate if self.rate > 0 else None


@dataclass(frozen=True)
class SweepSummary:
    """What a run of a sweep did.

    Attributes
    ----------
    folder : str
    clips : int
        Clips in the grid.
    made : int
        Clips made by this run.
    skipped : int
        Clips already finished by an earlier run.
    remaining : int
        Clips still to make (``--limit``).
    seconds : float
        Wall-clock time of the run (s).
    frames : int
        Character-frames written by this run.
    bytes : int
        Bytes written by this run.
    workers : str
        ``"1 process"``, ``"N local processes"`` or the Dask scheduler's address.
    """

    folder: str
    clips: int
    made: int
    skipped: int
    remaining: int
    seconds: float
    frames: int
    bytes: int
    workers: str

    @property
    def clips_per_second(self) -> float:
        return self.made / self.seconds if self.seconds > 0 else 0.0

    @property
    def frames_per_second(self) -> float:
        """Character-frames written per second."""
        return self.frames / self.seconds if self.seconds > 0 else 0.0


def cpu_count() -> int:
    """CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def pending(grid_clips: Sequence[ClipSpec], entries: dict, folder) -> list[ClipSpec]:
    """The clips without a manifest entry whose file exists with the recorded size."""
    folder = Path(folder)
    out = []
    for c in grid_clips:
        e = entries.get(c.id)
        if e is not None:
            try:
                if (folder / c.path).stat().st_size == e.get("bytes"):
                    continue
            except OSError:
                pass
        out.append(c)
    return out


def tasks_of(clips: Sequence[ClipSpec], workers: int) -> list[tuple[ClipSpec, ...]]:
    """Split clips into tasks: each of one character, length and frame rate, of at most
    :data:`MAX_BATCH` clips and :data:`MAX_BATCH_FRAMES` character-frames, and at
    least :data:`TASKS_PER_WORKER` tasks a worker when there are enough clips; in the
    grid's order."""
    size = max(1, min(MAX_BATCH, math.ceil(len(clips) / (TASKS_PER_WORKER * max(workers, 1)))))
    groups: dict[tuple, list[ClipSpec]] = {}
    for c in clips:
        groups.setdefault((c.source, c.digest, c.seconds, c.fps), []).append(c)
    out = []
    for g in groups.values():
        k = max(1, min(size, MAX_BATCH_FRAMES // g[0].frames))
        out += [tuple(g[i:i + k]) for i in range(0, len(g), k)]
    first = {c.id: k for k, c in enumerate(clips)}
    return sorted(out, key=lambda t: first[t[0].id])


# ------------------------------------------------------------------ executors
def _inline(tasks, out: str) -> Iterator[list[dict]]:
    for t in tasks:
        yield make_clips(t, out)


def _worker_stop(signum, frame):  # pragma: no cover - runs in a worker process
    from quadsim.io.atomic import remove_temporaries

    remove_temporaries()
    os._exit(128 + signum)


def keep_freed_memory() -> bool:
    """Have this process's C allocator keep the memory it frees, for the next array.

    A task's arrays are large (a clip's file alone is half a megabyte) and
    made afresh for every clip; glibc hands such blocks back to the system
    when they are freed, so every new one is faulted in again page by page
    (about 2 us a page here: a quarter of a millisecond to make one clip's
    bytes). With large blocks taken from the heap and the heap not trimmed,
    a worker reuses its memory instead; it keeps its largest task's memory
    (tens of megabytes) until it ends. Only with glibc (``mallopt``); returns
    whether it was done. The bytes are the same either way.
    """
    try:
        import ctypes

        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    m_trim_threshold, m_mmap_threshold = -1, -3
    return bool(mallopt(m_mmap_threshold, MMAP_THRESHOLD)) and \
        bool(mallopt(m_trim_threshold, 1 << 30))


def _worker_init(threads: int = 0) -> None:  # pragma: no cover - runs in a worker process
    """A local worker: SIGTERM and SIGINT remove its unfinished files and end it; with
    ``threads``, its compiled kernels run on that many threads (the workers already
    share the CPUs out: more threads a worker would only wait for each other). The
    bytes are the same whatever the threads. Its allocator keeps freed memory
    (:func:`keep_freed_memory`)."""
    for s in (signal.SIGTERM, signal.SIGINT):
        signal.signal(s, _worker_stop)
    if KEEP_FREED_MEMORY:
        keep_freed_memory()
    if threads:
        try:
            from numba import get_num_threads, set_num_threads

            set_num_threads(max(1, min(threads, get_num_threads())))
        except (ImportError, ValueError):
            pass


_WARM: set[tuple[str, int]] = set()  # (character file, clips a task) warmed up here


def _warm_up(tasks) -> None:
    """Load the compiled kernels here once, before the workers are forked from this
    process (each would load them again otherwise): once a process for each
    character and path (a clip alone, a batch)."""
    from dataclasses import replace

    from quadsim.dataset.clips import BATCH_MIN_ROWS, generate, measure, measure_clips, \
        npz_bytes

    for t in tasks:
        spec = t[0]
        short = replace(spec, seconds=3.0 / spec.fps)
        if (spec.source, 1) not in _WARM:
            m = generate([short])[0]  # a clip alone
            measure(m)
            npz_bytes(m)
            _WARM.add((spec.source, 1))
        if len(t) >= BATCH_MIN_ROWS and (spec.source, BATCH_MIN_ROWS) not in _WARM:
            batch = generate([short] * BATCH_MIN_ROWS)  # and a batch: its own kernels
            npz_bytes(batch[0], measure_clips(batch)[0].contacts)
            _WARM.add((spec.source, BATCH_MIN_ROWS))


def _stop_workers(pool) -> None:
    """Stop a local pool's workers: SIGTERM (each removes its unfinished files and
    ends), then SIGKILL for any still alive after :data:`WORKER_STOP_WAIT` s. A worker
    blocked in C -- on the task queue's lock, which a worker killed outright held --
    never runs its SIGTERM handler: the pool's own clean-up waited for it, and the
    interpreter's exit waited for that, forever (the sweep whose worker was killed
    printed its message and never ended)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    stop = getattr(pool, "terminate_workers", None)  # Python 3.14
    if stop is not None:
        stop()
    else:
        for p in procs:
            try:
                p.terminate()
            except (OSError, AttributeError):
                pass
    for p in procs:
        try:
            p.join(WORKER_STOP_WAIT)
            if p.is_alive():
                p.kill()
                p.join(WORKER_STOP_WAIT)
        except (OSError, AttributeError, AssertionError, ValueError):
            pass


def _local(tasks, out: str, workers: int) -> Iterator[list[dict]]:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    methods = multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("fork" if "fork" in methods else None)
    if ctx.get_start_method() == "fork":
        _warm_up(tasks)
    n = min(workers, len(tasks))
    threads = max(1, cpu_count() // n) if WORKER_THREADS_SPLIT else 0
    pool = ProcessPoolExecutor(max_workers=n, mp_context=ctx, initializer=_worker_init,
                               initargs=(threads,))
    from concurrent.futures.process import BrokenProcessPool

    try:
        try:
            futures = [pool.submit(make_clips, t, out) for t in tasks]
            finished = as_completed(futures)
            del futures  # as_completed lets go of each future it yields: results do not pile up
            for f in finished:
                yield f.result()
        except BrokenProcessPool:
            raise InputError(f"a worker process stopped unexpectedly (killed, or out of "
                             f"memory?); the finished clips in {out} are kept: run the same "
                             "command again to make the rest (with fewer --workers if memory "
                             "is short)") from None
    except BaseException:
        _stop_workers(pool)
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def _dask_client(address: str):
    from quadsim._optional import require

    Client = require("distributed", f"`--scheduler` {address}", extra="dask").Client
    try:
        return Client(address, timeout=f"{CONNECT_TIMEOUT}s")
    except (OSError, TimeoutError, ValueError, TypeError) as e:
        raise InputError(f"`--scheduler` {address}: cannot reach a Dask scheduler there "
                         f"({e}); start one with `dask scheduler` and give its address, "
                         "e.g. tcp://HOST:8786") from None


def _dask(tasks, client) -> Iterator[list[dict]]:
    from dask.distributed import as_completed

    futures = client.map(make_clips, tasks, pure=False)
    waiting = set(futures)
    finished = as_completed(futures)
    del futures
    try:
        for f in finished:
            entries = f.result()
            waiting.discard(f)
            f.release()  # the cluster forgets the clips' bytes
            del f
            yield entries
    finally:
        if waiting:
            client.cancel(list(waiting))


def _publish(folder: Path, entries: list[dict]) -> None:
    """Write the clips a remote worker sent back, and their manifest lines."""
    for e in entries:
        data = e.pop("data", None)
        if data is not None:
            publish(folder, e, data)


# ------------------------------------------------------------------ the sweep
def run_sweep(grid: Grid, out, *, workers: int | None = None, scheduler: str | None = None,
              limit: int | None = None,
              progress: Callable[[Progress], None] | None = None) -> SweepSummary:
    """Make every clip of ``grid`` not yet in ``out`` (see the module notes).

    Parameters
    ----------
    grid : Grid
    out : path-like
        The sweep's folder: ``clips/`` and ``manifest.jsonl`` inside.
    workers : int, optional
        Local worker processes (default: the CPU count; 1 runs in this process).
        Ignored with ``scheduler``.
    scheduler : str, optional
        Address of a running Dask distributed scheduler (``tcp://HOST:PORT``).
    limit : int, optional
        Make at most this many clips in this run (the first ones not yet made).
    progress : callable, optional
        Called with a :class:`Progress` at the start and after each task.

    Returns
    -------
    SweepSummary

    Raises
    ------
    InputError
        For a bad worker count or limit, a folder another sweep is writing, an
        unreachable scheduler, or a clip's bad input.
    """
    workers = cpu_count() if workers is None else workers
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InputError(f"`--workers` = {workers!r}: give a number of processes >= 1")
    if limit is not None and (isinstance(limit, bool) or not isinstance(limit, int)
                              or limit < 1):
        raise InputError(f"`--limit` = {limit!r}: give a number of clips >= 1")
    folder = Path(out)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"`--out` {str(folder)!r} is a file; give a folder")
    clips = grid.clips()
    t0 = time.perf_counter()
    client = None
    if scheduler and pending(clips, read_manifest(folder / MANIFEST), folder):
        client = _dask_client(scheduler)  # before the folder is made: nothing if it fails
    try:
        manifest = Manifest(folder)
    except BaseException:
        if client is not None:
            client.close()
        raise
    with manifest:
        remove_leftovers(folder)
        todo = pending(clips, manifest.entries(), folder)
        skipped = len(clips) - len(todo)
        if limit is not None:
            todo = todo[:limit]
        try:
            if client is not None:
                n = max(1, sum(client.nthreads().values()))
                tasks = tasks_of(todo, n)
                label = f"Dask at {scheduler} ({n} threads)"
                results = _dask(tasks, client)
            else:
                tasks = tasks_of(todo, workers)
                n = min(workers, len(tasks))
                label = "1 process" if n <= 1 else f"{n} local processes"
                results = _inline(tasks, str(folder)) if n <= 1 else \
                    _local(tasks, str(folder), n)
            made = frames = size = 0
            if progress:
                progress(Progress(0, len(todo), time.perf_counter() - t0))
            try:
                for entries in results:
                    _publish(folder, entries)
                    made += len(entries)
                    frames += sum(e["frames"] for e in entries)
                    size += sum(e["bytes"] for e in entries)
                    if progress:
                        progress(Progress(made, len(todo), time.perf_counter() - t0))
            finally:
                results.close()  # a stop here stops the workers at once
        finally:
            if client is not None:
                client.close()
        compact(manifest, [c.id for c in clips])
    done = skipped + made
    return SweepSummary(str(folder), len(clips), made, skipped, len(clips) - done,
                        time.perf_counter() - t0, frames, size, label)
