"""Calling the compiled kernels: rows in blocks on threads, fixed entry points.

:func:`run_blocks` runs rows in blocks on threads (the kernels release the GIL).

A step over many rows (characters or frames) is split into one block of
rows per thread, each block run by the same serial compiled kernel
(compiled with ``nogil=True``) on a thread of a shared pool. Rows are
independent, so the result is the one of a single call whatever the number
of threads; no threaded (``parallel=True``) variant of a kernel is compiled.
The number of threads is numba's (:func:`numba.get_num_threads`, set with
``NUMBA_NUM_THREADS`` or :func:`numba.set_num_threads`).

:class:`FixedEntry` (:mod:`quadsim.kinematics.compiled`, shared with the
horse) calls a kernel's compiled entry point directly, for arguments whose
types never change: finding the types of a call of bundles of some thirty
arrays (numba's dispatch) costs more than a one-row step.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

from numba import get_num_threads

from quadsim.kinematics.compiled import FixedEntry

__all__ = ["FixedEntry", "run_blocks"]

_POOL: ThreadPoolExecutor | None = None


def _pool() -> ThreadPoolExecutor:
    global _POOL
    if _POOL is None:
        _POOL = ThreadPoolExecutor(max_workers=max(get_num_threads(), 1),
                                   thread_name_prefix="quadsim-rows")
    return _POOL


def run_blocks(task, n: int) -> None:
    """``task(a, e)`` for blocks ``a:e`` covering rows ``0:n``, one a thread.

    The calling thread runs the first block itself while the pool's threads
    run the others (it would otherwise only wait, and a pool thread's wake-up
    is paid once less); the first error raised in a block is raised once
    every block has ended.
    """
    blocks = min(max(get_num_threads(), 1), max(n, 1))
    if blocks <= 1:
        task(0, n)
        return
    size = -(-n // blocks)
    futures = [_pool().submit(task, a, min(n, a + size)) for a in range(size, n, size)]
    try:
        task(0, min(n, size))
    finally:
        for f in futures:
            f.exception()  # wait for every block, even after an error here
    for f in futures:
        f.result()
